"""The ADRC law against the reference written from the papers (tests/laws/
adrc_reference.py), its observer's eigenvalues, and its transfer-function form."""

import math

import numpy as np
import pytest
import scipy.signal

from mfcontrol.laws import adrc

from .adrc_reference import current_observer_gain, matrices, reference_adrc, transfer_functions


def law_outputs(ys, rs, h, order, b0, wc, wo, lo=-math.inf, hi=math.inf, delay=0,
                start=None):
    CP = np.zeros((adrc.N_PARAMS, 1))
    CP[adrc.ORDER], CP[adrc.B0], CP[adrc.WC], CP[adrc.WO] = order, b0, wc, wo
    CP[adrc.OUT_MIN], CP[adrc.OUT_MAX], CP[adrc.DELAY] = lo, hi, delay
    CS = np.zeros((adrc.n_state(delay), 1))
    adrc.reset(CP, CS, 0, math.nan if start is None else start)
    return np.array([adrc.step(CP, CS, 0, y, r, h) for y, r in zip(ys, rs, strict=True)])


def _signals(n=300, seed=0):
    rng = np.random.default_rng(seed)
    ys = np.cumsum(rng.normal(0.0, 0.05, n))  # a wandering measurement
    rs = np.where(np.arange(n) < 20, 0.0, 1.0) + 0.2 * np.sin(np.arange(n) / 15)
    return ys, rs


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("h", [0.01, 0.1])
def test_the_law_is_the_papers_observer_and_control_law(order, h):
    ys, rs = _signals()
    args = (h, order, 2.5, 3.0, 12.0)
    u = law_outputs(ys, rs, *args)
    ref = reference_adrc(ys, rs, *args)
    np.testing.assert_allclose(u, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("order", [1, 2])
def test_limits_feed_the_observer_the_applied_output_and_delay_and_start(order):
    ys, rs = _signals(seed=3)
    args = (0.05, order, 1.5, 2.0, 10.0)
    for extra in ({"lo": -0.5, "hi": 0.8}, {"delay": 3}, {"start": 0.3},
                  {"lo": -0.5, "hi": 0.8, "delay": 2, "start": 0.7}):
        u = law_outputs(ys, rs, *args, **extra)
        ref = reference_adrc(ys, rs, *args, **extra)
        np.testing.assert_allclose(u, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max(),
                                   err_msg=str(extra))
        if "lo" in extra:  # the limits were reached
            assert u.max() == 0.8 and u.min() >= -0.5
        if "start" in extra:
            assert u[0] == pytest.approx(extra["start"], abs=1e-12)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("wo_h", [1e-3, 0.1, 1.0, 5.0])
def test_observer_gain_places_every_eigenvalue_at_exp_minus_wo_h(order, wo_h):
    h = 0.02
    wo = wo_h / h
    beta = math.exp(-wo_h)
    Ad, _, C = matrices(order, 1.0, h)
    L = np.array(adrc.observer_gains(float(order), wo, h))[:order + 1, None]
    # the characteristic polynomial of the error's matrix is (z - beta)^(n + 1)
    char = np.poly((np.eye(order + 1) - L @ C) @ Ad)
    np.testing.assert_allclose(char, np.poly(np.full(order + 1, beta)), atol=1e-9)
    np.testing.assert_allclose(L, current_observer_gain(Ad, C, beta), rtol=1e-7, atol=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_transfer_function_form_gives_the_same_trajectory(order):
    """Herbst's point: the discrete ADRC is a linear two-degree-of-freedom controller.
    Its two transfer functions, filtering the same y and r, give the law's outputs."""
    ys, rs = _signals(seed=5)
    h, b0, wc, wo = 0.05, 2.0, 4.0, 20.0
    u = law_outputs(ys, rs, h, order, b0, wc, wo)
    (ny, d), (nr, _) = transfer_functions(order, b0, wc, wo, h)
    # the filters start from zero, the law from its prediction (y_0, 0, ..): by
    # linearity its outputs are the filters' on (y - y_0, r) plus its own on (y_0, 0)
    tf_u = scipy.signal.lfilter(ny, d, ys - ys[0]) + scipy.signal.lfilter(nr, d, rs)
    u_rest = law_outputs(np.full_like(ys, ys[0]), np.zeros_like(rs), h, order, b0, wc, wo)
    np.testing.assert_allclose(u, tf_u + u_rest, rtol=1e-9, atol=1e-10 * np.abs(u).max())


def test_closed_loop_on_its_own_model_has_the_bandwidths_poles():
    """On the plant y' = b0 u + f (f constant) the loop follows r with the controller's
    pole at -wc and rejects f: the error after a step of r decays as exp(-wc t)
    once the observer has converged (wo >> wc)."""
    h, b0, wc, wo, f = 1e-3, 2.0, 5.0, 200.0, 0.7
    CP = np.zeros((adrc.N_PARAMS, 1))
    CP[adrc.ORDER], CP[adrc.B0], CP[adrc.WC], CP[adrc.WO] = 1, b0, wc, wo
    CP[adrc.OUT_MIN], CP[adrc.OUT_MAX] = -math.inf, math.inf
    CS = np.zeros((adrc.N_STATE, 1))
    adrc.reset(CP, CS, 0, math.nan)
    y, errors = 0.0, []
    for k in range(4000):
        r = 1.0 if k >= 1000 else 0.0
        u = adrc.step(CP, CS, 0, y, r, h)
        y += h * (b0 * u + f)  # the exact ZOH step of y' = b0 u + f
        errors.append(r - y)
    assert abs(errors[999]) < 1e-3  # f rejected before the step (exp(-wc t) from 0)
    e = np.array(errors[1000:])
    # the decay rate over the step's first second: about wc
    rate = -np.log(abs(e[600]) / abs(e[100])) / (500 * h)
    assert rate == pytest.approx(wc, rel=0.05)
