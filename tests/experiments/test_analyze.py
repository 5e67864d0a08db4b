"""The analysis of a case's loop against facts: python-control's margins, the simulated
run (its response, its steady state, its noise), the paper's stable/unstable pair, and
the analysis's own bookkeeping (delays, notes, files)."""

import json
import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.experiments.cases import resolve_case
from mfcontrol.experiments.report import growth_rate

control = pytest.importorskip("control")

#: a case's loop made linear: no noise, no load step, limits out of reach
LINEAR = {"sensor.noise": "none", "disturbance.kind": "none",
          "controller.duty_min": -1e6, "controller.duty_max": 1e6}


def _rate(fidelity, gain, R):
    cfg = resolve_case("voltage-stable-standard", {"fidelity": fidelity})[1]
    return growth_rate(cfg, gain, R)


@pytest.mark.parametrize("R,grows", [(10, False), (11, False), (12, False), (15, True),
                                     (20, True)])
def test_published_plant_standard_ip(R, grows):
    assert (_rate("published", 0.1, R) > 0) is grows


@pytest.mark.parametrize("R", [10, 12, 20])
def test_textbook_plant_standard_ip_grows_even_at_nominal_load(R):
    assert _rate("paper", 0.1, R) > 0


@pytest.mark.parametrize("fidelity", ["published", "paper"])
@pytest.mark.parametrize("R", [10, 12, 20])
def test_gain_one_is_stable_everywhere(fidelity, R):
    assert _rate(fidelity, 1.0, R) < -1000


def test_a_growing_mode_shows_in_the_simulation():
    r = mfcontrol.run_case("voltage-stable-standard", {"fidelity": "paper",
                                                         "plant.change_times": []})
    e = abs(r.error)
    early, late = e[(r.time > 2.5e-3) & (r.time < 4e-3)].max(), e[r.time > 8.5e-3].max()
    assert late > early


def test_the_growth_rate_is_the_simulated_envelopes():
    # the textbook plant at nominal load grows at ln(rho)/h: with the reference held at
    # 2.5 V, the error's envelope (its peak over 2 ms windows, once the start has died
    # out) grows at that rate, to 1 %
    rate = _rate("paper", 0.1, 10.0)
    assert rate > 10.0
    r = mfcontrol.run_case("voltage-stable-standard", {"fidelity": "paper",
                                                         "plant.change_times": [],
                                                         "reference.t_ramp2": 1.0,
                                                         "sim.t_end": 32e-3})
    e = np.abs(r.error)
    windows = [(10e-3, 12e-3), (30e-3, 32e-3)]
    peaks = [e[(r.time >= a) & (r.time < b)].max() for a, b in windows]
    measured = math.log(peaks[1] / peaks[0]) / 20e-3
    assert measured == pytest.approx(rate, rel=0.01)


def _loop_gain(a):
    """L = -C_y P q^d of an analysis, as a python-control discrete system."""
    cy, _ = a.transfer_functions()
    delay = control.tf([1.0], [1.0] + [0.0] * a.loop.delay, a.sample_time)
    return -cy * a.loop.plant * delay


@pytest.mark.parametrize("case", ["bench-lag3", "bench-delay-lag-t1", "motor-noise-pid"])
def test_a_pids_margins_are_python_controls(case):
    a = mfcontrol.analyze(case)
    gm, pm, _, _, _, _ = control.stability_margins(_loop_gain(a), method="frd")
    assert a.margins["gain_margin"] == pytest.approx(gm, rel=1e-4)
    assert a.margins["phase_margin_deg"] == pytest.approx(pm, rel=1e-4)


@pytest.mark.parametrize("case,overrides", [
    ("bench-lag3", {}),
    ("bench-delay-lag-t1", {"sensor.delay": 3}),
    ("bench-lag3", {"controller.law": "i-PI", "controller.alpha": 10.0,
                    "controller.kp": 1.0, "controller.ki": 0.3, "controller.window": 20,
                    "controller.estimator": "algebraic", "actuator.delay": 4}),
    ("motor-noise-ipi", {"plant.schedule": []}),
])
def test_the_analysed_loop_is_the_simulated_run(case, overrides):
    # from rest, the setpoint response of the analysis's loop (the law's filter, the
    # plant's exact step, the delays) is the library's run, sample for sample: the law's
    # start-up acts on zeros
    a = mfcontrol.analyze(case, overrides={**LINEAR, **overrides})
    assert a.margins["stable"]
    res = mfcontrol.run_case(case, {**LINEAR, **overrides})
    r, y_meas = res.signals["y_ref"], res.signals["y_meas"]
    # the loop run as a linear system: the filter's difference equation, the sampled
    # plant's state, the whole loop delay before the plant (y behind a sensor delay is
    # the same signal as y of a plant whose input waits as long)
    f, plant, d = a.controller, a.loop.plant, a.loop.delay
    Ad, Bd, Cd = (np.asarray(m, dtype=float) for m in (plant.A, plant.B, plant.C))
    x = np.zeros(Ad.shape[0])
    y, u = np.zeros(r.size), np.zeros(r.size)
    for k in range(r.size):
        y[k] = (Cd @ x)[0]
        u[k] = (sum(f.b_y[i] * y[k - i] for i in range(f.b_y.size) if k >= i)
                + sum(f.b_r[i] * r[k - i] for i in range(f.b_r.size) if k >= i)
                - sum(f.a[i] * u[k - i] for i in range(1, f.a.size) if k >= i))
        x = Ad @ x + Bd[:, 0] * (u[k - d] if k >= d else 0.0)
    assert np.abs(y - y_meas).max() <= 1e-9 * np.abs(y_meas).max()


def test_the_algebraic_estimators_steady_state_error_is_the_runs():
    # the trapezoid window's F_hat is off at rest: the i-P on y' = -y + u leaves a
    # finite error, which the analysis gives before the run
    overrides = {"plant.schedule": [], "controller.duty_min": -1e6,
                 "controller.duty_max": 1e6, "controller.kernel": "trapezoid"}
    a = mfcontrol.analyze("first-order-ip-algebraic", overrides=overrides)
    res = mfcontrol.run_case("first-order-ip-algebraic", overrides)
    final = res.signals["y_ref"][-1]
    error = 1.0 - res.signals["y"][-1] / final
    assert abs(a.margins["steady_state_error"]) > 1e-4
    assert error == pytest.approx(a.margins["steady_state_error"], rel=1e-6)
    # the closed form (docs/theory.md): the trapezoid window estimates alpha u with the
    # DC gain 1 - 1/M^2, so an i-P leaves e = -alpha u / (kp M^2); on y' = -y + u,
    # alpha = 1, that is a relative error 1 / (kp M^2 + 1)
    kp, window = 5.0, 20
    assert a.margins["steady_state_error"] == pytest.approx(1 / (kp * window**2 + 1),
                                                            rel=1e-9)
    # the held kernel (the default) is exact at rest: no error, in the analysis and the run
    held = {**overrides, "controller.kernel": "held"}
    a = mfcontrol.analyze("first-order-ip-algebraic", overrides=held)
    res = mfcontrol.run_case("first-order-ip-algebraic", held)
    assert abs(a.margins["steady_state_error"]) < 1e-12
    assert abs(1.0 - res.signals["y"][-1] / res.signals["y_ref"][-1]) < 1e-9


def test_the_h2_noise_gain_is_the_runs_control_noise():
    # white sensor noise of std sigma moves u by noise_gain_h2 sigma: the run's standard
    # deviation of u over 200,000 samples, to 2 %
    overrides = {"disturbance.kind": "none", "controller.duty_min": -1e6,
                 "controller.duty_max": 1e6, "reference.final": 0.0, "sim.t_end": 4000.0}
    a = mfcontrol.analyze("bench-lag3", overrides=overrides)
    res = mfcontrol.run_case("bench-lag3", overrides)
    u = res.signals["u"][1000:]
    assert np.std(u) == pytest.approx(0.01 * a.margins["noise_gain_h2"], rel=0.02)
    # and the peak is at least the root mean square over frequency
    assert a.margins["noise_gain_peak"] >= a.margins["noise_gain_h2"]


def test_a_nonlinear_plant_is_linearised_at_the_steady_state():
    a = mfcontrol.analyze("boost-ipd", operating_point=30.0)
    p = a.operating_point
    E, R = 20.0, 10.0
    d = 1.0 - E / 30.0  # v = E / (1 - d)
    assert p["u"] == pytest.approx(d, rel=1e-9) and p["y"] == pytest.approx(30.0)
    assert p["x"] == pytest.approx([30.0 / (R * (1 - d)), 30.0], rel=1e-9)
    assert any("nonlinear" in n for n in a.notes)
    # another level, another loop
    b = mfcontrol.analyze("boost-ipd", operating_point=40.0)
    assert b.margins["Ms"] != pytest.approx(a.margins["Ms"], rel=1e-3)


def test_a_linear_plant_says_nothing_of_a_point():
    a = mfcontrol.analyze("buck-ipi")
    assert a.operating_point is None
    assert not any("nonlinear" in n for n in a.notes)
    # and an operating point asked for would change nothing: refused
    with pytest.raises(ValueError, match="^operating_point = 3.0: the plant is linear"):
        mfcontrol.analyze("buck-ipi", operating_point=3.0)


def test_the_notes_say_what_the_run_has_that_the_loop_does_not():
    notes = " ".join(mfcontrol.analyze("motor-noise-ipi-algebraic").notes)
    for words in ("output limits", "sensor noise", "scheduled changes"):
        assert words in notes
    notes = mfcontrol.analyze("bench-lag3", overrides=LINEAR).notes
    assert len(notes) == 1 and "output limits" in notes[0]


def test_a_moving_gain_is_held_at_its_start_or_where_asked():
    a = mfcontrol.analyze("voltage-stable-variational")
    assert any("gamma = 1 (its start" in n for n in a.notes)
    b = mfcontrol.analyze("voltage-stable-variational", gamma=0.1)
    c = mfcontrol.analyze("voltage-stable-standard")  # 1/alpha = 0.1
    assert b.margins["spectral_radius"] == pytest.approx(c.margins["spectral_radius"],
                                                         rel=1e-12)


def test_a_live_controller_and_a_plant_object():
    ctrl = mfcontrol.IPI(alpha=10.0, kp=1.0, ki=0.3, sample_time=0.02)
    plant = control.tf([1.0], [1.0, 3.0, 3.0, 1.0])
    a = mfcontrol.analyze(ctrl, plant, actuator=mfcontrol.Actuator(delay=5))
    b = mfcontrol.analyze(ctrl, mfcontrol.LTI.from_control(plant, integrator="exact"),
                          actuator=mfcontrol.Actuator(delay=5))
    assert a.loop.delay == 5
    assert a.margins["Ms"] == pytest.approx(b.margins["Ms"], rel=1e-9)
    with pytest.raises(TypeError, match="^plant: required"):
        mfcontrol.analyze(ctrl)
    with pytest.raises(TypeError, match="^plant: a mfcontrol.Plant"):
        mfcontrol.analyze(ctrl, "a plant")


def test_write_gives_the_json_and_the_figure(tmp_path):
    a = mfcontrol.analyze("bench-lag3")
    paths = a.write(tmp_path)
    assert [p.name for p in paths] == ["analysis.json", "analysis.png"]
    data = json.loads((tmp_path / "analysis.json").read_text())
    for key in ("Ms", "Mt", "gain_margin", "phase_margin_deg", "delay_margin_s",
                "noise_gain_peak", "spectral_radius", "stable"):
        assert key in data["margins"]
    assert data["case"] == "bench-lag3" and len(data["poles"]["real"]) == a.poles().size
    assert (tmp_path / "analysis.png").stat().st_size > 10_000


def test_the_stable_region_is_the_simulated_sweeps_cell_for_cell():
    # the test: over kp x ki of the PID on 1/(s+1)^3, the analysis's region and
    # simulated runs agree on every cell not at the boundary (|ln rho| > 5e-4: over the
    # 4,000 samples compared, a decay or a growth of at least e^2)
    overrides = {**LINEAR, "sim.t_end": 100.0}
    reg = mfcontrol.analyze_region("bench-lag3", ["controller.kp=logspace(-1,1.2,7)",
                                                  "controller.ki=logspace(-2,0.8,6)"],
                                   overrides)
    assert 0 < reg.stable.sum() < reg.stable.size
    compared = 0
    for iy, ki in enumerate(reg.y):
        for ix, kp in enumerate(reg.x):
            rho = reg.spectral_radius[iy, ix]
            if abs(math.log(rho)) <= 5e-4:
                continue
            res = mfcontrol.run_case("bench-lag3", {**overrides, "controller.kp": float(kp),
                                                    "controller.ki": float(ki)})
            e = np.abs(res.error)
            early, late = e[500:1000].max(), e[-500:].max()
            grew = res.metrics["diverged"] or late > early
            assert grew is (rho > 1.0), (kp, ki, rho, early, late)
            compared += 1
    assert compared >= 25, compared  # of 42 cells; the slow ones sit near rho = 1


def test_a_region_over_a_plant_key_is_the_analysis_of_each_cell():
    reg = mfcontrol.analyze_region("voltage-stable-standard",
                                   {"controller.alpha": [5.0, 10.0, 20.0],
                                    "plant.R": [8.0, 10.0, 15.0]})
    assert reg.point == (10.0, 10.0)
    for iy, R in enumerate(reg.y):
        for ix, alpha in enumerate(reg.x):
            one = mfcontrol.analyze("voltage-stable-standard",
                                    overrides={"controller.alpha": alpha, "plant.R": R})
            assert reg.spectral_radius[iy, ix] == pytest.approx(
                one.margins["spectral_radius"], rel=1e-9)
    df = reg.to_pandas()
    assert list(df.columns) == ["controller.alpha", "plant.R", "spectral_radius", "stable",
                                "Ms", "noise_gain_peak"] and len(df) == 9


def test_a_region_needs_two_axes_the_run_reads(tmp_path):
    with pytest.raises(mfcontrol.ConfigError, match="^--region = 'controller.kp': give two"):
        mfcontrol.analyze_region("bench-lag3", ["controller.kp=1,2"])
    with pytest.raises(mfcontrol.ConfigError, match="controller.alpha"):
        mfcontrol.analyze_region("bench-lag3", ["controller.kp=1,2", "controller.alpha=1,2"])
    reg = mfcontrol.analyze_region("bench-lag3", ["controller.kp=1,2,3", "controller.ki=1,2"])
    paths = reg.write(tmp_path)
    assert [p.name for p in paths] == ["region.csv", "region.png"]
    assert "6 of 6" in repr(reg) or "of 6 cells" in repr(reg)


def test_a_plant_of_clustered_poles_is_analysed_from_its_state_space():
    # the PID the benchmark tuned on 1 / (s + 1)^8 (h = 0.05: eight plant poles at 0.951).
    # The roots of the loop's characteristic polynomial put a pole at 1.0039 (a growing
    # loop): coefficients rounded to 1e-16 move eight clustered roots by about
    # 1e-16^(1/8). The run decays, and so does the analysis, from the state space
    tuned = {"controller.kp": 0.8465203977955793, "controller.ki": 0.15060496097983617,
             "controller.kd": 1.6789393444243346}
    a = mfcontrol.analyze("bench-lag8", overrides={**LINEAR, **tuned})
    roots = np.roots(np.trim_zeros(a.loop.characteristic(), "b"))
    assert np.abs(roots).max() > 1.0  # what the polynomial says
    assert a.margins["stable"] and a.margins["spectral_radius"] < 0.995
    res = mfcontrol.run_case("bench-lag8", {**LINEAR, **tuned, "sim.t_end": 400.0})
    e = np.abs(res.error)
    assert e[-500:].max() < 1e-6 * e[:500].max()
    reg = mfcontrol.analyze_region("bench-lag8", {
        "controller.kp": [tuned["controller.kp"], 0.9],
        "controller.ki": [tuned["controller.ki"]]},
        {**LINEAR, "controller.kd": tuned["controller.kd"]})
    assert reg.spectral_radius[0, 0] == pytest.approx(a.margins["spectral_radius"],
                                                      rel=1e-9)
