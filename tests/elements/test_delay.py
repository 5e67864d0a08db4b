"""The delay ring: v_{k-d} out, ``before`` while k < d."""

import numpy as np
import pytest

from mfcontrol.elements import delay


@pytest.mark.parametrize("d", [0, 1, 3, 17])
def test_the_output_is_the_input_d_samples_earlier(d):
    v = np.random.default_rng(d).normal(size=100)
    ring = np.full(d + 1, np.nan)
    out = np.array([delay.delayed(ring, d, k, v[k], -7.0) for k in range(v.size)])
    assert np.array_equal(out[d:], v[:v.size - d])
    assert np.all(out[:d] == -7.0)


def test_members_of_a_block_sharing_one_ring_get_what_their_own_rings_give():
    # delays of their own (0 to 5) in one ring of 6 rows: each lane's output is the one of
    # delayed() on a ring of its own, sample by sample, before included
    ds = np.array([0, 1, 2, 3, 5, 4])
    v = np.random.default_rng(1).normal(size=(200, ds.size))
    shared = np.full((ds.max() + 1, ds.size), np.nan)
    own = [np.full(d + 1, np.nan) for d in ds]
    for k in range(v.shape[0]):
        slot = k % shared.shape[0]
        for lane, d in enumerate(ds):
            a = delay.delayed_lane(shared, lane, int(d), slot, k, v[k, lane], -7.0)
            b = delay.delayed(own[lane], int(d), k, v[k, lane], -7.0)
            assert a == b, (k, lane)


@pytest.mark.parametrize("d", [1, 2, 5])
def test_a_block_sharing_one_delay_reads_its_rows_as_delayed_gives(d):
    # the ring's rows apart (delayed_rows): what delayed() gives on a ring of each lane's
    # own, a ring one row longer than the delay needs included
    lanes = 4
    v = np.random.default_rng(d).normal(size=(120, lanes))
    shared = np.full((d + 2, lanes), np.nan)
    own = [np.full(d + 1, np.nan) for _ in range(lanes)]
    for k in range(v.shape[0]):
        slot = k % shared.shape[0]
        into, out = shared[slot], shared[delay.back_slot(shared.shape[0], slot, d)]
        for lane in range(lanes):
            a = delay.delayed_rows(into, out, lane, d, k, v[k, lane], -7.0)
            b = delay.delayed(own[lane], d, k, v[k, lane], -7.0)
            assert a == b, (k, lane)
