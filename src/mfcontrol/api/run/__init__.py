"""Running loops: a loop of objects, compiled or in Python (:mod:`.loop`), a sweep of one
(:mod:`.sweep`), a resolved configuration on the fastest engine (:mod:`.simulate`), the
paper's kernels' stacked scenarios (:mod:`.scenario`) and grids of configurations run in
chunks (:mod:`.batch`).
"""
