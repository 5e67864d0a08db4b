"""The closed loop's poles and margins against facts: python-control's stability margin,
and the loop gain and the loop delay at which the poles leave the unit circle."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.analysis.loop import LinearLoop

control = pytest.importorskip("control")

H = 0.01
#: 1 / ((s + 1) (s + 2)), stepped by its zero-order hold
PLANT = control.c2d(control.tf([1.0], [1.0, 3.0, 2.0]), H)

CONTROLLERS = {
    "i-PI": lambda: mfcontrol.IPI(alpha=50.0, kp=2.0, ki=1.0, sample_time=H),
    "i-P algebraic": lambda: mfcontrol.IP(alpha=50.0, kp=5.0, sample_time=H,
                                          estimator="algebraic", window=10),
    "i-PID order 2": lambda: mfcontrol.IPID(alpha=1.0, kp=4.0, ki=1.0, kd=4.0,
                                            sample_time=H),
    "PID": lambda: mfcontrol.PID(kp=3.0, ki=2.0, kd=0.4, N=8.0, b=0.5, sample_time=H),
}


def _scaled(filt, gain):
    """The same law with its output scaled by ``gain`` (the loop gain times gain)."""
    return type(filt)(filt.a, gain * filt.b_y, gain * filt.b_r, filt.dt)


def _delayed(plant, d):
    """The plant behind d more samples of delay."""
    return plant * control.tf([1.0], [1.0] + [0.0] * d, H)


@pytest.mark.parametrize("name", CONTROLLERS)
def test_ms_is_the_inverse_of_the_nyquist_curves_distance_to_minus_one(name):
    loop = LinearLoop(CONTROLLERS[name]().linear_filter(), PLANT)
    m = loop.margins()
    assert m["stable"]
    cy, _ = loop.controller.transfer_functions()
    sm = control.stability_margins(-cy * PLANT, method="frd")[2]
    assert m["Ms"] == pytest.approx(1.0 / sm, rel=1e-5)
    assert m["Ms"] >= 1.0 and m["Mt"] > 0.0 and m["noise_gain_peak"] > 0.0


@pytest.mark.parametrize("name", ["i-PI", "PID"])
def test_the_gain_margin_is_where_the_poles_leave_the_unit_circle(name):
    filt = CONTROLLERS[name]().linear_filter()
    gm = LinearLoop(filt, PLANT).margins()["gain_margin"]
    assert 1.0 < gm < math.inf

    def radius(gain):
        return LinearLoop(_scaled(filt, gain), PLANT).margins()["spectral_radius"]

    assert radius(gm * (1 - 1e-3)) < 1.0 < radius(gm * (1 + 1e-3))


@pytest.mark.parametrize("name", CONTROLLERS)
def test_the_delay_margin_is_the_delay_that_destabilises_the_loop(name):
    filt = CONTROLLERS[name]().linear_filter()
    m = LinearLoop(filt, PLANT).margins()
    d = m["delay_margin_samples"]
    assert m["delay_margin_s"] == pytest.approx(d * H)
    below, above = math.floor(d), math.ceil(d)
    if d - below < 0.02 or above - d < 0.02:
        pytest.skip(f"delay margin {d:.3f} samples: too near a whole number to bracket")
    assert LinearLoop(filt, _delayed(PLANT, below)).margins()["stable"]
    assert not LinearLoop(filt, _delayed(PLANT, above)).margins()["stable"]


def test_the_poles_are_the_simulated_loops_decay():
    # the i-P = PI on 1/(s + 1): from a disturbed start, the error decays as the largest
    # pole's modulus to the power k (the filter tests hold the loop's equation itself)
    ctrl = mfcontrol.IP(alpha=20.0, kp=5.0, sample_time=H)
    plant = control.c2d(control.tf([1.0], [1.0, 1.0]), H)
    radius = LinearLoop(ctrl.linear_filter(), plant).margins()["spectral_radius"]
    res = mfcontrol.simulate_loop(mfcontrol.FirstOrder(a=-1.0, b=1.0, integrator="exact"),
                                  ctrl, 1.0, t_end=3.0)
    e = np.abs(res.signals["y"] - 1.0)
    k1, k2 = 100, 250
    rate = (e[k2] / e[k1]) ** (1.0 / (k2 - k1))
    assert rate == pytest.approx(radius, rel=1e-3)


@pytest.mark.parametrize("name", CONTROLLERS)
def test_gain_and_phase_margins_are_python_controls(name):
    loop = LinearLoop(CONTROLLERS[name]().linear_filter(), PLANT)
    m = loop.margins()
    cy, _ = loop.controller.transfer_functions()
    # python-control's frequency-response method: its polynomial one (what "best" tries
    # first, with a warning) misplaces these loops' crossovers (|L| = 1.013 at its gain
    # crossover of the PID, a negative phase margin for the stable i-PI)
    gm, pm, *_ = control.stability_margins(-cy * PLANT, method="frd")
    assert m["phase_margin_deg"] == pytest.approx(pm, rel=1e-5)
    assert m["gain_margin"] == pytest.approx(gm, rel=1e-5)


def test_a_continuous_plant_is_stepped_by_its_zero_order_hold():
    # python-control's continuous model and the library's own LTI plant object give the
    # loop of the plant's zero-order hold at the controller's sample time
    filt = CONTROLLERS["i-PI"]().linear_filter()
    expected = LinearLoop(filt, PLANT).margins()
    for plant in (control.tf([1.0], [1.0, 3.0, 2.0]),
                  mfcontrol.LTI([[0.0, 1.0], [-2.0, -3.0]], [0.0, 1.0], [1.0, 0.0])):
        loop = LinearLoop(filt, plant)
        assert loop.plant.dt == H
        m = loop.margins()
        for key, value in expected.items():
            # (the H2 norm sums a long impulse response of poles near 1: to 1e-7)
            rel = 1e-7 if key == "noise_gain_h2" else 1e-9
            assert m[key] == pytest.approx(value, rel=rel), key


def test_a_plant_of_another_sample_time_is_refused():
    filt = CONTROLLERS["PID"]().linear_filter()
    with pytest.raises(ValueError, match="^plant.dt = 0.02: must be the controller's sample "
                                         "time 0.01, or 0"):
        LinearLoop(filt, control.c2d(control.tf([1.0], [1.0, 1.0]), 0.02))
    with pytest.raises(TypeError, match="^plant: a python-control StateSpace or "
                                        "TransferFunction, or a mfcontrol.LTI, not FirstOrder"):
        LinearLoop(filt, mfcontrol.FirstOrder(a=-1.0, b=1.0))
    with pytest.raises(ValueError, match="^plant: must have one input and one output"):
        LinearLoop(filt, control.ss(np.eye(2) * -1.0, np.eye(2), np.eye(2), 0.0))


@pytest.mark.parametrize("name", CONTROLLERS)
def test_the_bandwidth_and_the_steady_state_are_python_controls(name):
    # the setpoint response T_ry = P C_r / (1 + L) evaluated by python-control
    # (its own bandwidth() searches discrete systems unreliably: the definition instead)
    loop = LinearLoop(CONTROLLERS[name]().linear_filter(), PLANT)
    m = loop.margins()
    cy, cr = loop.controller.transfer_functions()

    def gain(w):  # each factor evaluated alone (their product's polynomials lose DC)
        z = np.exp(1j * np.asarray(w) * H)
        p = PLANT(z)
        return np.abs(p * cr(z) / (1 - p * cy(z)))

    # at z = 1 the law's integrator cancels (0 / 0): the gain just above it
    dc = gain(1e-5)
    assert 1.0 - m["steady_state_error"] == pytest.approx(dc, rel=1e-6)

    bw = m["bandwidth_rad_s"]
    assert gain(bw) == pytest.approx(abs(dc) / np.sqrt(2), rel=1e-9)
    below = np.logspace(np.log10(bw) - 4, np.log10(bw), 2000)[:-1]
    assert np.all(gain(below) > abs(dc) / np.sqrt(2))


def test_a_delay_in_the_loop_is_the_plants_delay():
    filt = CONTROLLERS["PID"]().linear_filter()
    a = LinearLoop(filt, PLANT, delay=7).margins()
    b = LinearLoop(filt, _delayed(PLANT, 7)).margins()
    for key in ("spectral_radius", "Ms", "gain_margin", "phase_margin_deg"):
        assert a[key] == pytest.approx(b[key], rel=1e-9), key
    with pytest.raises(ValueError, match="^delay = 1.5: must be a whole number"):
        LinearLoop(filt, PLANT, delay=1.5)
