"""A delay of d whole samples, as a ring of d + 1 values (or more)."""

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


@step_jit
def delayed_lane(ring, lane, d, slot, k, v, before):
    """:func:`delayed` for member ``lane`` of a block whose delays share one ring of n
    rows, n more than the longest of them (``ring[i, lane]``), ``slot`` = k % n computed
    once for the block: the same values out, with no division per member and no
    branch on the value (the store is unconditional), so a loop over the block's
    members vectorises."""
    ring[slot, lane] = v
    back = slot - d
    back = back + ring.shape[0] if back < 0 else back
    out = ring[back, lane]
    out = before if k < d else out
    return v if d == 0 else out
