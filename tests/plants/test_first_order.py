"""The first-order plant against its closed-form solution and the RK4 polynomial."""

import math

import pytest

from mfcontrol.api.model.plants import FirstOrder
from mfcontrol.plants import first_order as fo

# the plant object steps with the engine's functions: the one RK4 on fo.rhs, or fo.advance
RK4, EXACT = "rk4", "exact"


def _closed_form(a, b, w, y0, u, t):
    """y(t) of y' = a y + b u + w with u constant: the textbook formula, with e^{a t} - 1
    evaluated by expm1 so that the reference itself does not cancel for small |a t|."""
    g = b * u + w
    if a == 0:
        return y0 + t * g
    return math.exp(a * t) * y0 + math.expm1(a * t) / a * g


def _run(integrator, a, b, w, y0, u, h, n):
    plant = FirstOrder(a, b, w, x0=y0, integrator=integrator)
    x = plant.x0
    for k in range(n):
        x = plant.step(k * h, x, u, h)
    return x[fo.Y]


@pytest.mark.parametrize("a", [-3.0, -1e-9, 0.7, 2.5])
def test_exact_step_is_the_closed_form(a):
    for h in (1e-6, 1e-3, 0.3):
        y = _run(EXACT, a, 2.0, -0.5, 1.25, 0.8, h, 1)
        assert y == pytest.approx(_closed_form(a, 2.0, -0.5, 1.25, 0.8, h), rel=1e-14)


def test_exact_steps_compose_to_the_closed_form():
    y = _run(EXACT, -2.0, 1.5, 0.3, -1.0, 0.6, 1e-3, 2000)
    assert y == pytest.approx(_closed_form(-2.0, 1.5, 0.3, -1.0, 0.6, 2.0), rel=1e-12)


def test_a_zero_is_a_ramp():
    assert _run(EXACT, 0.0, 2.0, 0.5, 1.0, 3.0, 0.25, 1) == 1.0 + 0.25 * (2.0 * 3.0 + 0.5)
    # RK4 integrates a constant slope exactly as well
    assert _run(RK4, 0.0, 2.0, 0.5, 1.0, 3.0, 0.25, 4) == pytest.approx(7.5, rel=1e-15)


@pytest.mark.parametrize("a", [-4.0, 1.5])
def test_rk4_step_is_the_fourth_degree_taylor_polynomial(a):
    # for y' = a y + g, one RK4 step of size h is y + T(z) (a y + g) h with z = a h and
    # T(z) = 1 + z/2 + z^2/6 + z^3/24: the exponential's series cut after degree 4
    b, w, y0, u, h = 1.0, 0.25, 0.5, 2.0, 0.1
    z = a * h
    expected = y0 + (1 + z / 2 + z**2 / 6 + z**3 / 24) * h * (a * y0 + b * u + w)
    assert _run(RK4, a, b, w, y0, u, h, 1) == pytest.approx(expected, rel=1e-14)


def test_rk4_is_fourth_order_against_the_closed_form():
    a, b, w, y0, u, T = -3.0, 2.0, 0.5, 1.0, -1.0, 2.0
    exact = _closed_form(a, b, w, y0, u, T)
    errs = [abs(_run(RK4, a, b, w, y0, u, T / n, n) - exact) for n in (80, 160, 320)]
    assert all(15 < e0 / e1 < 17.5 for e0, e1 in zip(errs, errs[1:], strict=False))  # 2^4


def test_rk4_local_error_against_exact_step_is_fifth_order():
    a, b, w, y0, u = 1.5, 1.0, -0.2, 0.3, 0.7

    def local_error(h):
        return abs(_run(RK4, a, b, w, y0, u, h, 1) - _run(EXACT, a, b, w, y0, u, h, 1))

    assert 28 < local_error(0.04) / local_error(0.02) < 36  # 2^5


def test_disturbance_shifts_the_equilibrium():
    # stable a: y -> -(b u + w) / a = 1.6 / 2, for RK4 as for the exact step
    for step in (RK4, EXACT):
        assert _run(step, -2.0, 1.0, 0.6, 0.0, 1.0, 0.05, 1000) == pytest.approx(0.8, rel=1e-12)


def test_deriv_and_output():
    plant = FirstOrder(-2.0, 3.0, 0.5, x0=1.5)
    assert plant.derivative(0.0, plant.x0, 4.0).tolist() == [-2.0 * 1.5 + 3.0 * 4.0 + 0.5]
    assert plant.output(plant.x0) == 1.5
    assert set(fo.PARAM_ROWS) == {"a", "b", "w"} and fo.STATE_NAMES == ("y",)
