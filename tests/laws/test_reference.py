"""The references (``laws/reference.py``): the smooth step's formula."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from mfcontrol.laws import reference


@njit
def _cosine_always(initial, final, t0, duration, t):
    """The smooth step as written before its ends skipped the cosine."""
    x = (t - t0) / duration if duration > 0.0 else (1.0 if t >= t0 else 0.0)
    x = min(max(x, 0.0), 1.0)
    return initial + (final - initial) * (1.0 - math.cos(math.pi * x)) / 2.0


@njit
def _evaluate(initial, final, t0, duration, t):
    return reference.evaluate(reference.SMOOTH_STEP, initial, final, t0, duration, t)


_level = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(_level, _level, st.floats(0.0, 5.0), st.sampled_from([0.0, 1e-3, 0.5, 2.0]),
       st.floats(-1.0, 10.0))
def test_the_smooth_steps_ends_skip_the_cosine_with_its_bits(initial, final, t0, duration,
                                                             t):
    got = _evaluate(initial, final, t0, duration, t)
    want = _cosine_always(initial, final, t0, duration, t)
    assert np.float64(got).view(np.uint64) == np.float64(want).view(np.uint64)


def test_the_cosine_is_exact_at_the_ramps_ends():
    # what the shortcut rests on, in the compiled cosine and in Python's
    cos_pi = njit(lambda x: math.cos(math.pi * x))
    assert cos_pi(0.0) == 1.0 and cos_pi(1.0) == -1.0
    assert math.cos(0.0) == 1.0 and math.cos(math.pi) == -1.0
