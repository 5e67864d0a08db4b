"""The plant as the sampled loop sees it: linearised against closed forms, made discrete
against the engine's own steps and python-control's zero-order hold."""

import numpy as np
import pytest

import mfcontrol
from mfcontrol.analysis import linearise

control = pytest.importorskip("control")

A = np.array([[0.0, 1.0], [-2.0, -3.0]])
B = np.array([0.0, 1.0])
C = np.array([1.0, 0.0])


@pytest.mark.parametrize("substeps", [1, 3])
def test_rk4s_map_is_the_plants_rk4_step(substeps):
    # the engine's RK4 on x' = A x + B u, u held, over a sample of substeps steps
    h = 0.05
    Ad, Bd = linearise.discretise(A, B, h, "rk4", substeps)
    plant = mfcontrol.LTI(A, B, C, integrator="rk4")
    x0, u = np.array([0.3, -1.2]), 0.7
    x = x0.copy()
    for i in range(substeps):
        x = plant.step(i * h / substeps, x, u, h / substeps)
    np.testing.assert_allclose(Ad @ x0 + Bd * u, x, rtol=1e-14, atol=1e-15)


def test_the_exact_map_is_python_controls_zero_order_hold():
    h = 0.05
    Ad, Bd = linearise.discretise(A, B, h, "exact", 4)  # substeps change nothing
    d = control.c2d(control.ss(A, B[:, None], C[None, :], 0.0), h, "zoh")
    np.testing.assert_allclose(Ad, d.A, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(Bd, d.B[:, 0], rtol=1e-12, atol=1e-15)
    with pytest.raises(ValueError, match="^integrator = 'euler'"):
        linearise.discretise(A, B, h, "euler")


def test_the_boosts_jacobians_are_its_averaged_models():
    # L i' = E - (1 - d) v, C v' = (1 - d) i - v / R, y = v
    E, L, R, Cap = 20.0, 1e-3, 10.0, 10e-6
    boost = mfcontrol.Boost(E=E, L=L, R=R, C=Cap)
    found = linearise.steady_state(boost.derivative, boost.output, 30.0, boost.x0, (0.0, 0.5))
    assert found is not None
    x, d = found
    assert d == pytest.approx(1 / 3, rel=1e-10)
    Aj, Bj, Cj = linearise.jacobians(boost.derivative, boost.output, x, d)
    i, v = x
    np.testing.assert_allclose(Aj, [[0.0, -(1 - d) / L], [(1 - d) / Cap, -1 / (R * Cap)]],
                               rtol=1e-7, atol=1e-6)
    np.testing.assert_allclose(Bj, [v / L, -i / Cap], rtol=1e-7)
    np.testing.assert_allclose(Cj, [0.0, 1.0], atol=1e-9)
    assert not linearise.is_linear(boost.derivative, boost.output,
                                   [(x, d), (x + 1.0, d + 0.1)])


def test_a_linear_plant_is_linear_everywhere():
    motor = mfcontrol.DCMotor()
    assert linearise.is_linear(motor.derivative, motor.output,
                               [(np.zeros(2), 0.0), (np.array([50.0, 3.0]), 12.0)])


def test_no_steady_state_is_none():
    # y' = 1 (no input): never at rest
    plant = mfcontrol.FirstOrder(a=0.0, b=0.0, w=1.0)
    assert linearise.steady_state(plant.derivative, plant.output, 1.0, plant.x0) is None
