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
