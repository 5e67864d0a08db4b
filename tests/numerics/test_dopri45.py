"""The compiled Dormand-Prince 5(4) against closed forms and scipy's solve_ivp."""

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

from mfcontrol.numerics import dopri45
from mfcontrol.numerics import signatures as sig
from mfcontrol.plants import first_order, lti


@njit
def _run(rhs_address, x, u, p, h, n, rtol, atol):
    rhs = sig.as_rhs(rhs_address)
    w = np.empty((dopri45.N_WORK, x.size))
    dt = -1.0
    out = np.empty((n + 1, x.size))
    out[0] = x
    for k in range(n):
        dt = dopri45.integrate(rhs, k * h, x, u, p, h, rtol, atol, dt, w)
        out[k + 1] = x
    return out


@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_first_order_step_response_within_tolerance_of_the_closed_form(rtol):
    p = np.array([-3.0, 2.0, 0.5])  # y' = -3 y + 2 u + 0.5
    out = _run(first_order.rhs.address, np.array([1.0]), 1.0, p, 0.05, 40, rtol, rtol * 1e-3)
    t = 0.05 * np.arange(41)
    exact = 2.5 / 3 + (1.0 - 2.5 / 3) * np.exp(-3.0 * t)
    np.testing.assert_allclose(out[:, 0], exact, rtol=20 * rtol, atol=0)


def test_oscillator_agrees_with_solve_ivp_to_the_tolerances():
    A = np.array([[0.0, 1.0], [-25.0, -0.4]])
    p = lti.pack(A, np.array([0.0, 1.0]), np.array([1.0, 0.0]))
    rtol, atol = 1e-8, 1e-11
    h, n = 0.02, 150
    ours = _run(lti.rhs.address, np.array([1.0, 0.0]), 0.3, p, h, n, rtol, atol)
    ref = solve_ivp(lambda t, x: A @ x + np.array([0.0, 0.3]), (0, n * h), [1.0, 0.0],
                    method="RK45", rtol=rtol, atol=atol, t_eval=h * np.arange(n + 1))
    np.testing.assert_allclose(ours, ref.y.T, rtol=0, atol=100 * (atol + rtol))
    # and both against the closed form of the damped oscillator (eigen decomposition)
    lam, V = np.linalg.eig(A)
    xs = np.linalg.solve(A, -np.array([0.0, 0.3]))
    c = np.linalg.solve(V, np.array([1.0, 0.0]) - xs)
    exact = np.array([(V @ (c * np.exp(lam * t))).real + xs for t in h * np.arange(n + 1)])
    np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-6)


def test_a_blow_up_leaves_nan_not_a_hang():
    p = np.array([0.0, 0.0, 0.0])

    out = _run(_explode.address, np.array([1.0]), 0.0, p, 1.0, 3, 1e-9, 1e-12)
    assert np.isnan(out[-1, 0])


@sig.compiled(sig.RHS)
def _explode(t, x, u, p, dxdt, nx, np_):
    dxdt[0] = x[0] * x[0] * 1e300  # finite-time blow-up


@njit
def _one_sample(rhs_address, x, u, p, h, rtol, atol):
    w = np.empty((dopri45.N_WORK, x.size))
    return dopri45.integrate(sig.as_rhs(rhs_address), 0.0, x, u, p, h, rtol, atol, -1.0, w)


def test_a_stiff_plant_stops_after_max_steps_with_the_collapsed_step():
    # y' = -1e9 y + u from y = 1: stable only for steps under about 3.3e-9 s, so a sample
    # of 1 ms needs some 300,000 steps; the integrator gives up after MAX_STEPS, leaves
    # the state NaN and returns minus the step it was at (it used to run for hours)
    x = np.array([1.0])
    dt = _one_sample(first_order.rhs.address, x, 0.0, np.array([-1e9, 1.0, 0.0]), 1e-3,
                     1e-9, 1e-12)
    assert np.isnan(x[0])
    assert -4e-9 < dt < -1e-10
    # a sample that needs fewer steps than the bound is not touched by it
    x = np.array([1.0])
    dt = _one_sample(first_order.rhs.address, x, 0.0, np.array([-1e9, 1.0, 0.0]),
                     0.2 * dopri45.MAX_STEPS * 3e-9, 1e-9, 1e-12)
    assert np.isfinite(x[0]) and dt > 0
