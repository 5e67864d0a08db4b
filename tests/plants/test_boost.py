"""The averaged boost converter against its equilibrium, a tight ODE solve and its RHP zero."""

import control
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mfcontrol.api.model.plants import Boost
from mfcontrol.plants import boost

P = {"E": 20.0, "L": 1e-3, "R": 10.0, "C": 10e-6}


def _textbook(t, x, d, E=20.0, L=1e-3, R=10.0, C=10e-6):
    """L di/dt = E - (1 - d) v, C dv/dt = (1 - d) i - v / R, written out independently."""
    i, v = x
    return [(E - (1 - d) * v) / L, ((1 - d) * i - v / R) / C]


def _plant(x0=(0.0, 0.0), **params):
    # the plant object steps with the engine's RK4 on boost.rhs, as a run does
    return Boost(**{**P, **params}, x0=x0)


@pytest.mark.parametrize("d", [0.3, 0.5, 0.7])
def test_steady_state_is_the_averaged_equilibrium(d):
    # poles: s^2 + s/(RC) + (1-d)^2/(LC) = 0, the slowest -1000/s at d = 0.7, so 40 ms is
    # 40 time constants; h = 20 us is coarse (|lambda h| <= 0.18) but well inside RK4's region
    plant = _plant()
    x = plant.x0
    for k in range(2000):
        x = plant.step(k * 2e-5, x, d, 2e-5)
    v = P["E"] / (1 - d)
    assert x[boost.V_C] == pytest.approx(v, rel=1e-9)
    assert x[boost.I_L] == pytest.approx(v / ((1 - d) * P["R"]), rel=1e-9)
    assert plant.output(x) == x[boost.V_C]


def test_plant_object_reaches_the_same_equilibrium():
    plant = Boost(**P, x0=(1.0, 5.0))
    x = plant.x0
    for k in range(1000):
        x = plant.step(k * 2e-5, x, 0.6, 2e-5)
    np.testing.assert_allclose(x, [50.0 / (0.4 * 10.0), 50.0], rtol=1e-9)


@pytest.mark.parametrize("d", [0.25, 0.6])
def test_rk4_matches_a_tight_ode_solve(d):
    h, n = 1e-6, 1000  # 1 ms from rest: the start-up transient
    t = h * np.arange(n + 1)
    ref = solve_ivp(_textbook, (0.0, t[-1]), [0.0, 0.0], method="DOP853", t_eval=t,
                    args=(d,), rtol=1e-10, atol=1e-12).y
    plant = _plant()
    x = plant.x0
    traj = np.empty((2, n + 1))
    traj[:, 0] = x
    for k in range(n):
        x = plant.step(k * h, x, d, h)
        traj[:, k + 1] = x
    scale = np.max(np.abs(ref), axis=1, keepdims=True)
    assert np.max(np.abs(traj - ref) / scale) < 1e-8


def test_rk4_is_fourth_order():
    d, T = 0.4, 4e-4
    ref = solve_ivp(_textbook, (0.0, T), [0.0, 0.0], method="DOP853", args=(d,),
                    rtol=1e-13, atol=1e-12).y[:, -1]
    errs = []
    for n in (20, 40):
        plant = _plant()
        x = plant.x0
        for k in range(n):
            x = plant.step(k * T / n, x, d, T / n)
        errs.append(np.max(np.abs(x - ref)))
    assert 13 < errs[0] / errs[1] < 19  # 2^4


def test_deriv_is_the_textbook_right_hand_side():
    plant = _plant(R=7.0)
    np.testing.assert_allclose(plant.derivative(0.0, (3.0, 25.0), 0.35),
                               _textbook(0.0, (3.0, 25.0), 0.35, R=7.0), rtol=1e-15)


def _operating_point(D):
    V = P["E"] / (1 - D)
    return np.array([V / ((1 - D) * P["R"]), V])


def test_small_duty_step_makes_v_dip_before_it_rises():
    D, dd, h = 0.5, 0.02, 1e-6
    plant = Boost(**P, x0=_operating_point(D))
    x = plant.x0
    V0 = plant.output(x)
    v = [V0]
    for k in range(20000):
        x = plant.step(k * h, x, D + dd, h)
        v.append(plant.output(x))
    v = np.array(v)
    # the wrong way first: C dv/dt jumps by -I dd, so v falls for a while ...
    assert plant.derivative(0.0, plant.x0, D + dd)[1] == pytest.approx(
        -dd * _operating_point(D)[0] / P["C"], rel=1e-12)
    k_min = int(np.argmin(v))
    assert v[1] < V0 and k_min > 10 and V0 - v[k_min] > 0.05
    # ... then rises to the new, higher equilibrium E / (1 - D - dd)
    assert v[-1] == pytest.approx(P["E"] / (1 - D - dd), rel=1e-6) and v[-1] > V0


@pytest.mark.parametrize("D", [0.3, 0.5, 0.7])
def test_linearisation_has_the_documented_rhp_zero(D):
    plant = Boost(**P)
    x_op = _operating_point(D)
    # the model is affine in x for a fixed d and in d for a fixed x: central differences
    # are exact up to rounding
    eps_x, eps_d = 1e-3, 1e-6
    A = np.column_stack([(plant.derivative(0, x_op + e, D) - plant.derivative(0, x_op - e, D))
                         / (2 * eps_x) for e in np.eye(2) * eps_x])
    B = (plant.derivative(0, x_op, D + eps_d) - plant.derivative(0, x_op, D - eps_d)) / (2 * eps_d)
    zeros = control.zeros(control.ss(A, B.reshape(2, 1), [[0.0, 1.0]], [[0.0]]))
    assert zeros.size == 1
    assert zeros[0].real == pytest.approx((1 - D) ** 2 * P["R"] / P["L"], rel=1e-6)


def test_set_param_changes_the_equilibrium():
    plant = Boost(**P)
    plant.set_param("E", 12.0)
    assert plant.params["E"] == 12.0
    x = plant.x0
    for k in range(1000):
        x = plant.step(k * 2e-5, x, 0.5, 2e-5)
    assert plant.output(x) == pytest.approx(24.0, rel=1e-9)
    with pytest.raises(ValueError, match="allowed: E, L, R, C"):
        plant.set_param("d", 0.5)
