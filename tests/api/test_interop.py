"""python-control: the controller as a discrete nlsys reproduces mfcontrol's own loop."""

import numpy as np
import pytest

import mfcontrol
from mfcontrol.api.interop import as_nlsys, as_nlsys_state
from mfcontrol.api.model.plants import FirstOrder

control = pytest.importorskip("control")


def _plant_sys(plant, h):
    return control.nlsys(lambda t, x, u, p: plant.step(t, x, u[0], h),
                         lambda t, x, u, p: np.array([plant.output(x)]),
                         inputs=["u"], outputs=["y"], states=plant.x0.size, dt=h,
                         name="plant")


@pytest.mark.parametrize("make", [
    lambda h: mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=h),
    lambda h: mfcontrol.IPI(alpha=2.0, kp=5.0, ki=2.0, sample_time=h, output_limits=(-2, 2)),
    lambda h: mfcontrol.IPID(alpha=1.0, kp=20.0, ki=5.0, kd=0.05, sample_time=h, order=1,
                             estimator="algebraic", window=10),
    lambda h: mfcontrol.PID(kp=2.0, ki=3.0, kd=0.05, Tf=0.02, sample_time=h,
                            output_limits=(-2, 2)),
    lambda h: mfcontrol.ADRC(order=2, b0=1.0, wc=4.0, wo=20.0, sample_time=h,
                             output_limits=(-2, 2)),
])
def test_interconnected_response_equals_simulate_loop(make):
    h, n = 0.01, 300
    plant = FirstOrder(a=-1.0, b=1.0, w=0.3)
    ours = mfcontrol.simulate_loop(plant, make(h), 1.0, t_end=n * h)
    assert ours.time.size == n and ours.metrics["settled"]
    ctrl = make(h)
    loop = control.interconnect([as_nlsys(ctrl), _plant_sys(plant, h)], inplist=["r"],
                                outlist=["y", "u"])
    resp = control.input_output_response(
        loop, ours.time, U=np.ones(n), X0=np.concatenate([as_nlsys_state(ctrl), plant.x0]))
    np.testing.assert_allclose(resp.outputs[0], ours.signals["y"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(resp.outputs[1], ours.signals["u"], rtol=0, atol=1e-12)


def test_update_and_output_are_pure():
    ctrl = mfcontrol.IPI(alpha=1.0, kp=2.0, ki=1.0, sample_time=0.1)
    sys = as_nlsys(ctrl)
    x = as_nlsys_state(ctrl)
    a = sys._rhs(0.0, x, np.array([0.5, 1.0]))
    b = sys._rhs(0.0, x, np.array([0.5, 1.0]))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(x, as_nlsys_state(ctrl))  # the live object is untouched


def test_recursive_ip_needs_dt():
    with pytest.raises(ValueError, match="dt"):
        as_nlsys(mfcontrol.RecursiveIP())
    assert as_nlsys(mfcontrol.RecursiveIP(), dt=1e-6).isdtime()


def test_external_gain_takes_alpha_as_an_input():
    # it ran with alpha = 1 whatever the caller meant (found in review)
    h, n = 0.01, 300
    make = lambda: mfcontrol.IPI(alpha=1.0, kp=5.0, ki=2.0, sample_time=h,  # noqa: E731
                                 gain="external")
    alpha = 1.0 + 0.5 * np.sin(np.arange(n) * h)
    plant = FirstOrder(a=-1.0, b=1.0, w=0.3)
    ours = mfcontrol.simulate_loop(plant, make(), 1.0, t_end=n * h, alpha=alpha)
    ctrl = make()
    sys = as_nlsys(ctrl)
    assert sys.input_labels == ["y", "r", "alpha"]
    loop = control.interconnect([sys, _plant_sys(plant, h)], inplist=["r", "alpha"],
                                outlist=["y", "u"])
    resp = control.input_output_response(
        loop, ours.time, U=np.vstack([np.ones(n), alpha]),
        X0=np.concatenate([as_nlsys_state(ctrl), plant.x0]))
    np.testing.assert_allclose(resp.outputs[0], ours.signals["y"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(resp.outputs[1], ours.signals["u"], rtol=0, atol=1e-12)
