"""The compiled zero-order-hold discretisation against scipy."""

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from mfcontrol.numerics import zoh


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 5), st.integers(0, 2**31 - 1), st.floats(1e-4, 2.0))
def test_discretisation_equals_scipy_cont2discrete(n, seed, h):
    rng = np.random.default_rng(seed)
    A = rng.normal(scale=3.0, size=(n, n))
    B = rng.normal(size=n)
    Ad, Bd = np.empty((n, n)), np.empty(n)
    zoh.discretise(A, B, h, Ad, Bd)
    ref = scipy.signal.cont2discrete((A, B[:, None], np.eye(n), np.zeros((n, 1))), h,
                                     method="zoh")
    # exp(A h) is as sensitive to rounding as ||A h|| (its relative condition number is at
    # least that): two correct algorithms agree to 1e-12 times it, relative to the result.
    # Found by hypothesis: n = 5, seed = 505, h = 1.5 (||A h|| = 20, |Ad| ~ 3e6) differ by
    # 1.6e-12 relative, with [6/6] and [13/13] Pade alike
    cond = max(1.0, np.abs(A * h).sum(axis=0).max())
    scale = max(1.0, np.abs(ref[0]).max()) * cond
    np.testing.assert_allclose(Ad, ref[0], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Bd, ref[1][:, 0], rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("scale", [1e-3, 0.4, 3.0, 40.0])
def test_expm_equals_scipy(scale):
    M = np.random.default_rng(1).normal(scale=scale, size=(4, 4))
    ref = scipy.linalg.expm(M)
    np.testing.assert_allclose(zoh.expm(M), ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_an_integrator_is_exact():
    # x' = u: Ad = 1, Bd = h whatever h
    Ad, Bd = np.empty((1, 1)), np.empty(1)
    zoh.discretise(np.zeros((1, 1)), np.ones(1), 0.25, Ad, Bd)
    assert abs(Ad[0, 0] - 1.0) <= 3e-16 and abs(Bd[0] - 0.25) <= 1e-16
