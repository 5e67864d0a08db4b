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
def back_slot(n_rows, slot, d):
    """The row of a ring of ``n_rows`` rows that holds v_{k-d}, ``slot`` = k % n_rows."""
    back = slot - d
    return back + n_rows if back < 0 else back


@step_jit
def delayed_lane(ring, lane, d, slot, k, v, before):
    """:func:`delayed` for member ``lane`` of a block whose delays share one ring of n
    rows, n more than the longest of them (``ring[i, lane]``), ``slot`` = k % n computed
    once for the block: the same values out, with no division per member and no
    branch on the value (the store is unconditional), so a loop over the block's
    members vectorises."""
    return delayed_lane_at(ring, lane, d, slot, back_slot(ring.shape[0], slot, d), k, v,
                           before)


@step_jit
def delayed_lane_at(ring, lane, d, slot, back, k, v, before):
    """:func:`delayed_lane` with v_{k-d}'s row given (:func:`back_slot`): computed once
    for a block whose members have the same delay, the loop over them reads one row,
    contiguous, instead of a row per member (a gather)."""
    ring[slot, lane] = v
    out = ring[back, lane]
    out = before if k < d else out
    return v if d == 0 else out
