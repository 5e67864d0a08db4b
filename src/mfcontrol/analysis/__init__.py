"""The linear analysis of the laws: each law's equivalent linear filter
(:mod:`~mfcontrol.analysis.filters`) and that filter closed around a discrete plant, with
its poles and margins (:mod:`~mfcontrol.analysis.loop`); rule-tuned reference PIDs from a
first-order-plus-dead-time model (:mod:`~mfcontrol.analysis.tuning_rules`)."""
