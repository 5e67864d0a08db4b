"""A delay of d whole samples, as a ring of d + 1 values."""

from .._jit import step_jit


@step_jit
def delayed(ring, d, k, v, before):
    """v_k in (k = 0, 1, ... in order), v_{k-d} out, or ``before`` while k < d.
    ``ring`` holds at least d + 1 values; d = 0 returns v."""
    if d == 0:
        return v
    n = d + 1
    ring[k % n] = v
    if k < d:
        return before
    return ring[(k - d) % n]
