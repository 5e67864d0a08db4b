"""Running loops: a loop of objects, compiled or in Python (:mod:`.loop`), a sweep of one
(:mod:`.sweep`), a resolved configuration on the fastest engine (:mod:`.simulate`), the
objects a configuration describes (:mod:`.from_config`), the paper's kernels' stacked
scenarios (:mod:`.scenario`) and grids of configurations run in chunks (:mod:`.batch`).
Builds on :mod:`mfcontrol.api.params` and :mod:`mfcontrol.api.model` and returns the
types of :mod:`mfcontrol.api.results`.
"""
