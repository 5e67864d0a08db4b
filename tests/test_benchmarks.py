"""The loops of ``benchmarks/bench_realistic.py`` are what its docstring says: built and
run through mfcontrol only (no JAX, no timing), a few members over a short horizon."""

import sys
from pathlib import Path

import numpy as np
import pytest

from mfcontrol.elements import noise
from mfcontrol.laws.estimators import weights

# a script that imports its siblings by name: importable from their folder
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_realistic as br  # noqa: E402, I001

METRICS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "energy_u", "settled", "n_samples")


def _members_are_single_runs(loop):
    """Every member of the sweep is its single run: the same swept values and metrics,
    bit for bit. Returns the single runs."""
    table = loop.sweep()
    runs = []
    for m in range(loop.n_members):
        res = loop.single(m)
        for key, value in loop.values(m).items():
            assert table[key][m] == value
        for name in METRICS:
            assert np.array_equal(table[name][m], res.metrics[name], equal_nan=True), name
        runs.append(res)
    return runs


def test_default_sizes():
    """1,024 members of 10,000 samples each, the baseline's too."""
    loops = [br.motor_loop("ipi"), br.motor_loop("pid"), br.lag3_loop(), br.paper_loop()]
    assert [(lp.n_members, lp.n_samples) for lp in loops] == [(1024, 10_000)] * 4
    assert list(loops[2].axes) == ["controller.kp", "plant.time_scale"]


@pytest.mark.parametrize("law", ["ipi", "pid"])
def test_motor_loop(law):
    kp = [10.0, 30.0] if law == "ipi" else [0.1, 0.3]
    loop = br.motor_loop(law, {"controller.kp": kp, "plant.J": [4e-4, 7e-4]}, t_end=0.3)
    assert loop.n_samples == 300
    h = br.H
    for m, res in enumerate(_members_are_single_runs(loop)):
        s = res.signals
        y, y_meas, u, u_plant = s["y"], s["y_meas"], s["u"], s["u_plant"]
        # the sensor: noise of seed 1, then 2 samples of delay (s_0 before)
        read = y + np.array([noise.sample(noise.GAUSSIAN, br.NOISE_STD, br.SEED, k)
                             for k in range(y.size)])
        assert np.array_equal(y_meas, np.concatenate([[read[0]] * 2, read[:-2]]))
        # the actuator: 3 samples of delay (0 before), then at most 2000 V/s
        w = np.concatenate([np.zeros(3), u[:-3]])
        prev, expected = 0.0, []
        for wk in w:
            prev = min(max(wk, prev - br.RATE_LIMIT * h), prev + br.RATE_LIMIT * h)
            expected.append(prev)
        assert np.array_equal(u_plant, expected)
        assert np.abs(np.diff(u_plant)).max() > 1.99  # the limit acts
        kp_m = loop.values(m)["controller.kp"]
        if law == "ipi":
            # F_hat once the window is full: the algebraic estimator's FIR over the last
            # 41 measurements and 40 applied inputs (alpha 50, M = 40)
            wy, wu = weights(1, br.WINDOW, h, 1.0 / (1.0 / br.ALPHA), "held")
            M = br.WINDOW
            fir = np.array([wy @ y_meas[k - M:k + 1] + wu @ u[k - M:k]
                            for k in range(M, y.size)])
            assert np.allclose(s["F_hat"][M:], fir, rtol=0, atol=1e-9 * np.abs(fir).max())
            # held until the window is full (startup = "hold"), then within the limits
            assert np.all(u[:M] == 0.0) and np.abs(u).max() <= br.U_MAX
        else:  # a PI on the measurement: P = kp (r - y_meas), no derivative
            assert np.array_equal(s["P"], kp_m * (s["y_ref"] - y_meas))
            assert not np.any(s["D"])


def test_lag3_loop():
    loop = br.lag3_loop({"controller.kp": [1.0, 2.0], "plant.time_scale": [0.8, 1.25]},
                        t_end=24.0)
    assert loop.n_samples == 1200  # h = 20 ms; the load step at 20 s included
    for m, res in enumerate(_members_are_single_runs(loop)):
        cfg = res.config
        assert (cfg["plant.model"], cfg["sim.integrator"]) == ("lti", "exact")
        assert (cfg["controller.law"], cfg["controller.estimator"],
                cfg["controller.window"], cfg["controller.alpha"]) == ("i-PI", "algebraic",
                                                                       10, 30.0)
        assert (cfg["sensor.noise"], cfg["sensor.noise_std"], cfg["disturbance.kind"],
                cfg["disturbance.t0"]) == ("gaussian", 0.01, "step", 20.0)
        assert {k: cfg[k] for k in loop.axes} == loop.values(m)
        # the noise reaches the law, the load the plant
        assert not np.array_equal(res.signals["y_meas"], res.signals["y"])
        t = res.time
        assert np.array_equal(res.signals["u_plant"], res.signals["u"] - 0.5 * (t >= 20.0))


def test_noise_as_the_jax_loops_draw_it():
    """The script's numpy/JAX noise is mfcontrol's: the uniform variates bit for bit."""
    k = np.arange(500)
    for seed in (0, 1, 2**53 - 1):
        key = br.noise_key(seed)
        for stream in (0, 1):
            ours = [noise.uniform(seed, j, stream) for j in k]
            assert np.array_equal(br.uniform(key, k, stream), ours)
        g = [noise.sample(noise.GAUSSIAN, 0.5, seed, j) for j in k]
        assert np.allclose(br.gaussian(key, k, 0.5), g, rtol=1e-15, atol=1e-15)
