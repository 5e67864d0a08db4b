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
    branch on the value (the store is unconditional)."""
    ring[slot, lane] = v
    out = ring[back_slot(ring.shape[0], slot, d), lane]
    out = before if k < d else out
    return v if d == 0 else out


@step_jit
def delayed_rows(slot_row, back_row, lane, d, k, v, before):
    """:func:`delayed_lane` for a block whose members all have the delay d >= 1, the
    ring's row ``slot`` (where v_k goes) and row :func:`back_slot` (v_{k-d}) given as
    arrays of their own: read, then written, so that a loop over the members vectorises
    (a row per member is a gather, and the compiler cannot tell one row from the
    other in a single array)."""
    out = back_row[lane]
    slot_row[lane] = v
    return before if k < d else out
