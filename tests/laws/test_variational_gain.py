"""The gain adaptation's adaptation error: the integral of the force that moves gamma,
against its definition recomputed from the signals, in every driver."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.api.run import batch
from mfcontrol.experiments.cases import resolve_case


def _force_integral(y, r, hd, eps_m, h, first=3):
    """sum |e_dot_k - eps_M| h over k >= first, e_dot_k = (y_k - y_{k-1})/hd - (r_k -
    r_{k-1})/hd: the definition, from the recorded signals."""
    y, r = np.asarray(y, dtype=float), np.asarray(r, dtype=float)
    e_dot = (y[1:] - y[:-1]) / hd - (r[1:] - r[:-1]) / hd  # e_dot_k for k >= 1
    return float(np.sum(np.abs(e_dot[first - 1:] - eps_m)) * h)


@pytest.mark.parametrize("every", [1, 4])
def test_the_live_law_integrates_the_force_over_its_adapting_samples(every):
    # the same measurements, so the same e_dot at every sample: every sample's force
    # counts whether gamma moves at each sample or every 4th
    dt, eps_m = 0.01, 0.1
    ctrl = mfcontrol.IPI(alpha=2.0, kp=5.0, ki=1.0, sample_time=dt, gain="variational",
                         gamma0=0.5, Gamma=1e-3, eps_M=eps_m, adapt_every=every)
    ys = np.cumsum(np.random.default_rng(7).normal(0, 0.05, 200))
    for y in ys:
        ctrl(y, setpoint=1.0)
    expected = _force_integral(ys, np.ones_like(ys), dt, eps_m, dt)
    assert ctrl.adaptation_error == pytest.approx(expected, rel=1e-12)
    ctrl.reset()
    assert ctrl.adaptation_error == 0.0


def test_the_live_law_weighs_each_sample_by_its_own_period():
    ctrl = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=0.01, gain="variational",
                        gamma0=0.5, Gamma=1e-4, eps_M=0.0)
    ys, dts = [0.0, 0.1, 0.3, 0.2, 0.5, 0.4], [0.01, 0.01, 0.02, 0.01, 0.03, 0.01]
    for y, dt in zip(ys, dts, strict=True):
        ctrl(y, setpoint=0.0, dt=dt)
    expected = sum(abs((ys[k] - ys[k - 1]) / dts[k]) * dts[k] for k in range(3, len(ys)))
    assert ctrl.adaptation_error == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("gain", ["constant", "rls"])
def test_the_adaptation_error_does_not_apply_to_a_gain_that_does_not_adapt(gain):
    ctrl = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=0.01, gain=gain)
    for y in (0.0, 0.1, 0.2, 0.25, 0.3):
        ctrl(y, setpoint=1.0)
    assert math.isnan(ctrl.adaptation_error)
    res = mfcontrol.simulate_loop(mfcontrol.FirstOrder(a=-2.0, b=1.0), ctrl,
                                  1.0, t_end=0.5)
    assert math.isnan(res.metrics["adaptation_error"])


def test_a_simulated_intelligent_loop_reports_its_runs_share():
    # the compiled engine's metric against the definition on the recorded signals, and a
    # loop run from a controller that already ran counts this run only
    dt = 0.01
    plant = mfcontrol.FirstOrder(a=-2.0, b=1.0)
    ctrl = mfcontrol.IPI(alpha=2.0, kp=5.0, ki=1.0, sample_time=dt, gain="variational",
                         gamma0=0.5, Gamma=1e-3)
    res = mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=2.0)
    y, r = res.signals["y_meas"], res.signals["y_ref"]
    expected = _force_integral(y, r, dt, 0.1, dt)
    assert res.metrics["adaptation_error"] == pytest.approx(expected, rel=1e-9)
    assert math.isnan(mfcontrol.simulate_loop(
        plant, mfcontrol.PID(kp=1.0, ki=1.0, sample_time=dt), 1.0,
        t_end=0.2).metrics["adaptation_error"])


def test_the_papers_variational_run_reports_it_from_the_law_and_a_sweep_alike():
    # the recursive law's e_dot divides by the published scale (deriv_scale), the
    # integral steps by the sample period h
    name, cfg = resolve_case("voltage-unstable-variational", {"sim.t_end": 1e-3})
    res = mfcontrol.simulate(cfg)
    expected = _force_integral(res.signals["y"], res.signals["y_ref"],
                               cfg["controller.deriv_scale"], cfg["controller.eps_M"],
                               cfg["sim.h"])
    assert res.metrics["adaptation_error"] == pytest.approx(expected, rel=1e-9)
    grid = batch.make_grid(cfg, {"controller.Gamma": np.array([cfg["controller.Gamma"],
                                                                1e-9])})
    cols = batch.run_grid(grid)
    assert cols["adaptation_error"][0] == res.metrics["adaptation_error"]
    standard = mfcontrol.simulate(resolve_case("voltage-stable-standard",
                                               {"sim.t_end": 1e-4})[1])
    assert math.isnan(standard.metrics["adaptation_error"])
