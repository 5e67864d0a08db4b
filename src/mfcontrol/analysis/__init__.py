"""The linear analysis of the laws: each law's equivalent linear filter
(:mod:`~mfcontrol.analysis.filters`) and that filter closed around a discrete plant, with
its poles and margins (:mod:`~mfcontrol.analysis.loop`)."""
