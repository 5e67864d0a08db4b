"""The tuner's model without a browser: settings read as --set reads them, the runs they
give, freeze, the case file it writes, the options it shows, a map and a tuning."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from mfcontrol.api.run.simulate import keys_read_by_run, simulate
from mfcontrol.cli import main
from mfcontrol.config.toml import parse_assignment
from mfcontrol.errors import CaseError, ConfigError
from mfcontrol.experiments.cases import resolve_case, run_case
from mfcontrol.tuner.session import Session, axis_values, control_figures, span, text_of

CASE = "voltage-stable-standard"
MOTOR = "motor-noise-ipi-algebraic"  # 10,000 samples, alpha 50, kp 20, ki 50
SHORT = {"sim.t_end": 2e-3}  # 2,000 samples


def cli_message(case: str, key: str, text: str, capsys) -> str:
    assert main(["show", case, "--set", f"{key}={text}"]) == 2
    return capsys.readouterr().err.strip().removeprefix("mfcontrol: error: ")


def test_a_setting_is_read_as_the_cli_reads_it():
    s = Session(CASE)
    assert s.set("controller.kp", "3") is None
    assert s.value("controller.kp") == 3.0
    assert s.set("controller.law", "variational") is None  # a bare word, as --set
    assert s.value("controller.law") == "variational"
    assert s.set("controller.rate_term", "true") is None
    assert s.value("controller.rate_term") is True
    assert s.set("plant.change_times", "[0.002, 0.005]") is None
    assert s.value("plant.change_times") == [0.002, 0.005]


@pytest.mark.parametrize("key, text", [
    ("controller.alpha", "-1"), ("controller.kp", "abc"), ("controller.law", "P"),
    ("sim.h", "0"), ("controller.duty_min", "0.95"), ("controller.alphaa", "1"),
    ("sensor.delay", "2.5")])
def test_a_refused_entry_gives_the_clis_line_and_changes_nothing(key, text, capsys):
    s = Session(CASE)
    before = s.cfg
    assert s.set(key, text) == cli_message(CASE, key, text, capsys)
    assert s.cfg is before


def test_restore_goes_back_to_a_snapshot():
    s = Session(CASE)
    state = s.snapshot()
    s.set("controller.law", "variational")
    assert "controller.law" in s.changed() and "controller.Gamma" in {
        f.key for f in s.fields()}
    s.restore(state)
    assert s.changed() == {} and s.value("controller.law") == "ip"
    assert "controller.Gamma" not in {f.key for f in s.fields()}


def test_an_empty_entry_of_an_option_the_case_does_not_set_restores_the_default():
    s = Session(CASE, {"controller.k_aw": 5.0, "controller.u0": 0.5})
    assert s.set("controller.k_aw", "") is None
    assert s.value("controller.k_aw") is None
    assert s.note == ("controller.k_aw back to the default (the case does not set it): "
                      "unset")
    assert s.set("controller.u0", "") is None and s.value("controller.u0") == 1.0
    # one the case sets: the case's value
    assert s.set("reference.t_ramp2", "0.007") is None
    assert s.set("reference.t_ramp2", "") is None and s.value("reference.t_ramp2") == 0.005


def test_an_empty_entry_returns_to_the_cases_value():
    """Issue 28: an emptied alpha became the library's 10, not the case's 50 (IAE 1.03
    became 2.97)."""
    s = Session(MOTOR)
    own = s.run().metrics["iae"]
    assert s.set("controller.alpha", "70") is None
    assert s.set("controller.alpha", "") is None
    assert s.value("controller.alpha") == 50.0 and s.changed() == {}
    assert s.note == "controller.alpha back to the case's 50.0"
    assert s.run().metrics["iae"] == own
    # a case set with --set: the case file's value, the --set one counting as a change
    t = Session(MOTOR, {"controller.kp": 5.0})
    assert t.set("controller.kp", " ") is None and t.value("controller.kp") == 20.0


def test_a_law_switch_loads_that_laws_gains_and_says_so():
    """Issue 28: i-PI -> PID kept the i-PI's gains (kp 20, ki 50) and the control
    chattered rail to rail (TV(u) 1.3e5) under "stable: yes"."""
    s = Session(MOTOR)
    assert s.set("controller.kp", "25") is None
    assert s.set("controller.law", "pid") is None
    assert (s.value("controller.kp"), s.value("controller.ki"), s.value("controller.kd")) \
        == (2.0, 0.0, 0.0)  # the library's defaults: the case's gains are the i-PI's
    assert s.note == ("controller.law = pid: its gains kp = 2.0, ki = 0.0, kd = 0.0, the "
                      "library's defaults (the case's gains are for i-PI)")
    _, cfg = resolve_case(MOTOR, {"controller.law": "pid", "controller.kp": 2.0,
                                  "controller.ki": 0.0})
    assert s.run().metrics == simulate(cfg).metrics
    assert s.run().metrics["tv_u"] < 2e4  # not the kept gains' 1.3e5
    # the i-PI's alpha is unset: the saved case holds the PID's gains only
    assert "alpha" not in s.toml() and "controller.alpha" not in s.changed()
    # back to the case's law: the case's gains, not the 25 typed before the switch
    assert s.set("controller.law", "i-PI") is None
    assert [s.value(f"controller.{k}") for k in ("alpha", "kp", "ki")] == [50.0, 20.0, 50.0]
    assert s.note.endswith("alpha = 50.0, kp = 20.0, ki = 50.0, from the case")
    assert s.changed() == {}
    # to the ADRC: its bandwidths and b0, the library's defaults, the PID's gains unset
    a = Session("motor-noise-pid")
    assert a.set("controller.law", "adrc") is None
    assert [a.value(f"controller.{k}") for k in ("b0", "wc", "wo")] == [1.0, 1.0, 10.0]
    assert "kp" not in a.toml() and a.run().metrics["n_samples"] > 0
    # from the PID case to an i-P: the i-P's defaults
    p = Session("motor-noise-pid")
    assert p.set("controller.law", "i-P") is None
    assert (p.value("controller.alpha"), p.value("controller.kp")) == (10.0, 2.0)
    # a law the settings refuse changes nothing
    assert p.set("controller.law", "ip").startswith("controller.law = 'ip': the paper's")
    assert p.value("controller.law") == "i-P" and p.value("controller.kp") == 2.0


def test_undo_goes_back_one_change_at_a_time():
    s = Session(CASE, SHORT)
    assert not s.can_undo() and s.undo() is None
    s.set("controller.kp", "")  # already the case's: nothing to undo
    assert not s.can_undo()
    s.set("controller.kp", "3")
    s.set("controller.alpha", "-1")  # refused: no step
    s.set("controller.law", "variational")  # the law and its gains: one step
    assert s.value("controller.gamma0") == 1.0
    assert s.undo() == "controller.law = variational"
    assert s.value("controller.law") == "ip" and s.value("controller.kp") == 3.0
    assert "controller.Gamma" not in {f.key for f in s.fields()}
    # a slider's moves are one step; a typed value after them another
    for v in ("1.1", "1.2", "1.3"):
        s.set("controller.alpha", v, slide=True)
    s.set("controller.alpha", "14")
    assert s.undo() == "controller.alpha = 14.0" and s.value("controller.alpha") == 1.3
    assert s.undo() == "controller.alpha = 1.3" and s.value("controller.alpha") == 10.0
    assert s.undo() == "controller.kp = 3.0" and s.changed() == {"sim.t_end": 0.002}
    assert not s.can_undo()
    # a change the run then refused is restored with its step
    before = s.snapshot()
    s.set("controller.kp", "5")
    s.restore(before)
    assert not s.can_undo()


def test_several_frozen_runs_the_oldest_dropped_beyond_three():
    s = Session(CASE, SHORT)
    runs = []
    for kp in ("1", "2", "3", "4"):
        s.set("controller.kp", kp)
        runs.append(s.run())
        s.freeze()
    assert s.frozen == runs[1:] and s.frozen_numbers == [2, 3, 4]
    # each frozen run's settings against the current ones
    s.set("controller.kp", "2.5")
    assert s.differences(s.frozen[0].config) == {"controller.kp": (2.0, 2.5)}
    s.clear()
    assert s.frozen == [] and s.frozen_numbers == []


def test_tuned_values_are_applied_to_four_digits_as_one_step():
    """Issue 28: tuned values were shown with 16 digits."""
    s = Session(CASE, SHORT)
    applied = s.apply_tuned({"controller.alpha": 93.12345678901234,
                             "controller.kp": 2.0417379446695296})
    assert applied == {"controller.alpha": 93.12, "controller.kp": 2.042}
    assert text_of(s.value("controller.kp")) == "2.042"
    assert "controller.kp = 2.042" in s.toml()
    assert s.undo() == "tuning: controller.alpha = 93.12, controller.kp = 2.042"
    assert s.value("controller.alpha") == 10.0


def test_map_axes_leave_out_seeds_and_initial_states():
    """Issue 28: the map's axes offered sensor.seed and plant.i0."""
    keys = Session(MOTOR).numeric_keys()
    assert {"controller.alpha", "controller.kp", "controller.ki", "plant.J",
            "sensor.noise_std"} <= set(keys)
    assert not {"sensor.seed", "plant.i0", "plant.y0"} & set(keys)
    assert "controller.u0" not in Session(CASE).numeric_keys()
    # every axis is read by the run: setting it changes the run's configuration's reads
    s = Session(MOTOR)
    assert set(keys) <= keys_read_by_run(s.cfg)


def test_labels_are_in_the_plants_words():
    """Issue 28: a motor's voltage limits were labelled duty_min / duty_max."""
    motor = Session(MOTOR)
    assert motor.label("controller.duty_min") == "armature voltage u, lower limit (V)"
    assert motor.label("controller.duty_max") == "armature voltage u, upper limit (V)"
    assert motor.label("sensor.noise_std") == "sensor noise, standard deviation (rad/s)"
    assert motor.label("plant.J") == "rotor inertia J (kg m\u00b2)"
    buck = Session(CASE)
    assert buck.label("controller.duty_max") == "duty cycle d, upper limit (1)"
    assert buck.label("sim.h") == "sim.h"  # no words in the option table: the key
    by_key = {f.key: f for f in motor.fields()}
    assert by_key["controller.duty_min"].label == "armature voltage u, lower limit (V)"
    assert not by_key["controller.duty_max"].log  # a level, not a gain


def test_the_schedule_is_shown_and_editable():
    """Issue 28: the scheduled load step could not be seen or edited."""
    s = Session(MOTOR)
    by_key = {f.key: f for f in s.fields()}
    assert by_key["plant.schedule"].kind == "list"
    assert text_of(s.value("plant.schedule")) == '[{t = 5.0, name = "load", set = 0.05}]'
    assert s.events() == [(5.0, "load torque set to 0.05 N m")]
    assert s.set("plant.schedule", '[{t = 3.0, name = "load", set = 0.1}]') is None
    assert s.events() == [(3.0, "load torque set to 0.1 N m")]
    _, cfg = resolve_case(MOTOR, {"plant.schedule": [{"t": 3.0, "name": "load",
                                                      "set": 0.1}]})
    assert s.run().metrics == simulate(cfg).metrics
    assert s.set("plant.schedule", '[{t = 3.0, name = "R", set = 1.0}]').startswith(
        "plant.schedule = ")  # the CLI's check: R is no motor parameter
    assert s.set("plant.schedule", "") is None and s.events()[0][0] == 5.0
    # the buck's load changes and a disturbance's start, in words
    b = Session(CASE, {"disturbance.kind": "step", "disturbance.t0": 0.005,
                       "disturbance.amplitude": 0.01})
    assert b.events() == [(0.004, "R +1 ohm, C +1e-09 F"),
                          (0.005, "step disturbance at the input"),
                          (0.006, "R +1 ohm, C +1e-09 F")]
    assert "plant.schedule" not in {f.key for f in Session("bench-lag3").fields()}


def test_control_figures_show_a_chattering_control_beside_the_verdict():
    """Issue 28: the page said "stable: yes" while u chattered rail to rail."""
    _, cfg = resolve_case(MOTOR, {"controller.law": "pid"})  # the i-PI's gains kept
    r = simulate(cfg)
    f = control_figures(r)
    u = r.signals["u"]
    assert r.metrics["settled"]  # the library's verdict on the output
    assert f["u_at_limit"] == 100 * np.mean((u <= -24) | (u >= 24))
    assert f["u_at_limit"] > 5
    assert f["step_share"] == pytest.approx(r.metrics["tv_u"] / (u.size - 1) / 48 * 100)
    assert f["step_share"] > 20  # a mean step of a quarter of the range: chatter
    quiet = control_figures(Session(MOTOR).run())
    assert quiet["step_share"] < 1 and quiet["u_at_limit"] < 1


def test_a_map_says_how_it_stands_to_the_settings():
    """Issue 28: after Tune moved alpha 15 -> 93 the map, its title "around the current
    setting (marked)" and its marker stayed where they were."""
    s = Session(CASE, SHORT)
    m = s.robustness_map("controller.alpha", "plant.dR", n=3)
    assert s.map_state(m).kind == "current" and s.map_state(m).here == (10.0, 1.0)
    s.set("controller.alpha", "12")  # on the map: the map holds, the mark moves
    state = s.map_state(m)
    assert state.kind == "moved" and state.here == (12.0, 1.0)
    s.set("controller.alpha", "93")  # off the map
    state = s.map_state(m)
    assert state.kind == "outside" and state.here is None and "off the map" in state.title
    s.set("controller.kp", "3")  # another option the run reads: stale
    state = s.map_state(m)
    assert state.kind == "stale" and state.differences == {"controller.kp": (2.0, 3.0)}
    assert state.title.startswith("Stale") and "controller.kp = 2 (now 3)" in state.text
    s.undo()
    s.undo()
    assert s.map_state(m).kind == "moved"
    s.undo()
    assert s.map_state(m).kind == "current"


def test_the_run_is_the_engines_run_of_the_same_configuration():
    s = Session(CASE, SHORT)
    s.set("controller.alpha", "12.5")
    _, cfg = resolve_case(CASE, {**SHORT, "controller.alpha": 12.5})
    assert s.run().metrics == simulate(cfg).metrics
    assert s.seconds > 0


def test_freeze_keeps_the_run_and_clear_drops_it():
    s = Session(CASE, SHORT)
    first = s.run()
    assert s.freeze() is first
    s.set("controller.kp", "4")
    second = s.run()
    assert s.frozen == [first] and second.metrics["iae"] != first.metrics["iae"]
    s.clear()
    assert s.frozen == []


def test_the_saved_case_reproduces_the_run_bit_for_bit(tmp_path):
    s = Session(CASE, SHORT)
    s.set("controller.alpha", "7.3")
    s.set("plant.dR", "2.5")
    text = s.toml()
    assert "# changed: " in text and "controller.alpha = 7.3" in text
    tomllib.loads(text)  # a valid case file
    path = tmp_path / "tuned.toml"
    path.write_text(text)
    assert run_case(path).metrics == s.run().metrics


def test_a_sweep_case_is_tuned_as_its_single_run():
    s = Session("sweep-Gamma", SHORT)
    assert s.value("sweep.key") is None
    assert "[sweep]" not in s.toml()
    assert s.run().time.size == 2000


def test_a_bad_case_or_setting_raises_the_clis_errors():
    with pytest.raises(CaseError):
        Session("no-such-case")
    with pytest.raises(ConfigError):
        Session(CASE, {"controller.alpha": -1.0})


def test_the_fields_are_what_the_run_reads_grouped():
    s = Session(CASE)
    groups = s.groups()
    assert list(groups) == ["plant", "controller", "sensor, actuator, disturbance",
                            "reference", "simulation"]
    keys = {f.key for f in s.fields()}
    assert {"controller.alpha", "controller.kp", "plant.R", "plant.model", "controller.law",
            "sim.h", "fidelity"} <= keys
    # not read by this case's run: another plant's, another law's, the noise's without it
    assert not keys & {"plant.J", "controller.ki", "controller.window", "sensor.noise_std",
                       "sensor.seed", "controller.Gamma", "disturbance.amplitude"}
    by_key = {f.key: f for f in s.fields()}
    assert by_key["controller.alpha"].log and by_key["controller.kp"].log
    assert by_key["controller.law"].kind == "choice"
    assert not by_key["plant.dR"].log  # any sign allowed, and not a gain


def test_the_fields_follow_the_law_and_the_model():
    s = Session(CASE)
    s.set("controller.law", "variational")
    keys = {f.key for f in s.fields()}
    assert {"controller.Gamma", "controller.eps_M", "controller.gamma0"} <= keys
    assert s.adapts()
    s.set("sensor.noise", "gaussian")
    assert {"sensor.noise_std", "sensor.seed"} <= {f.key for f in s.fields()}
    m = Session("motor-noise-ipi-algebraic")
    keys = {f.key for f in m.fields()}
    assert {"plant.J", "controller.ki", "controller.window"} <= keys
    assert "plant.R" not in keys and not m.adapts()


def test_numeric_keys_leave_out_the_time_grid_and_shared_settings():
    keys = Session(CASE).numeric_keys()
    assert "controller.alpha" in keys and "plant.dR" in keys
    assert not {"sim.h", "sim.t_end", "metrics.settled_tol", "sim.diverge_above"} & set(keys)


def test_text_of_reads_back_to_the_same_value():
    for value in (0.1 + 0.2, 5e-08, 20, True, [0.004, 0.006], "i-PI"):
        assert parse_assignment(f"k={text_of(value)}")[1] == value
    s = Session(CASE)
    assert s.set("controller.kp", text_of(0.1 + 0.2)) is None
    assert s.value("controller.kp") == 0.1 + 0.2
    assert text_of(None) == ""


def test_span_and_axis_values():
    assert span("controller.alpha", 10.0, 3.0) == (10 / 3, 30.0, True)
    assert span("plant.a", -2.0, 10.0) == (-20.0, -0.2, False)
    assert span("actuator.delay", 0, 3.0) == (0.0, 6.0, False)
    assert span("metrics.final_window", 0.2, 10.0)[1] == 1.0
    with pytest.raises(ConfigError, match="is 0"):
        span("controller.ki", 0.0, 3.0)
    values, log = axis_values("controller.alpha", 10.0)
    assert log and values.size == 9 and values[4] == 10.0
    assert np.allclose(values[[0, -1]], [10 / 3, 30.0])
    whole, _ = axis_values("controller.window", 20)
    assert whole.dtype == float and np.all(whole == np.round(whole)) and 20 in whole


def test_a_robustness_map_is_the_batch_of_its_members():
    s = Session(CASE, SHORT)
    seen = []
    m = s.robustness_map("controller.alpha", "plant.dR", "iae", n=3,
                         progress=lambda done, total: seen.append((done, total)))
    assert m.z.shape == (3, 3) and seen[-1] == (9, 9)
    assert m.at == (10.0, 1.0) and m.xs[1] == 10.0 and m.ys[1] == 1.0
    # a member is its single run: the centre is the case's own
    assert m.z[1, 1] == s.run().metrics["iae"]
    _, cfg = resolve_case(CASE, {**SHORT, "controller.alpha": m.xs[2], "plant.dR": m.ys[0]})
    assert m.z[0, 2] == simulate(cfg).metrics["iae"]
    assert m.settled[1, 1]
    with pytest.raises(ConfigError):
        s.robustness_map("controller.alpha", "controller.alpha")
    with pytest.raises(ConfigError):
        s.robustness_map("sim.h", "plant.dR")


def test_a_tuning_spans_a_decade_and_applies_when_asked():
    s = Session("first-order-ip-algebraic")
    kp = s.value("controller.kp")
    r = s.tune(["controller.kp"], budget=30, seed=1)
    p = r.parameters[0]
    assert (p.low, p.high, p.log) == (kp / 10, kp * 10, True)
    assert s.value("controller.kp") == kp  # nothing applied yet
    assert r.value <= r.start_value
    s.apply(r.best)
    assert s.run().metrics["iae"] == r.nominal
    with pytest.raises(ConfigError):
        s.tune([], budget=30)
    assert math.isfinite(r.value)


def test_a_horizon_too_long_for_a_change_is_refused_with_the_figure():
    """Every change runs on the server's event loop: 10^7 samples took 3 s and 1.2 GB
    there and froze every open page (review)."""
    s = Session("voltage-stable-standard")
    msg = s.set("sim.t_end", "10")
    assert msg.startswith("sim.t_end = 10.0: 10,000,000 samples: the tuner runs at most")
    assert s.cfg["sim.t_end"] == 0.01
    with pytest.raises(ConfigError, match="sim.t_end"):
        Session("voltage-stable-standard", {"sim.t_end": 5.0})


def test_the_read_keys_are_the_librarys_and_kept_per_settings():
    s = Session(CASE, SHORT)
    first = s.reads(s.cfg)
    assert first == keys_read_by_run(s.cfg) and s.reads(s.cfg) is first
    s.set("controller.law", "i-PI")
    assert "controller.ki" in s.reads(s.cfg) and "controller.ki" not in first


def test_the_analysis_is_the_librarys_and_kept_per_settings():
    """Issue 30: the tuner shows the linear loop's margins beside the run."""
    import mfcontrol

    s = Session("bench-lag3")
    a = s.analysis()
    assert a.margins == mfcontrol.analyze(s.cfg).margins and s.analysis() is a
    s.freeze()
    s.set("controller.kp", str(4 * s.cfg["controller.kp"]))
    b = s.analysis()
    assert b is not a and b.margins["Ms"] > a.margins["Ms"]
    assert s.analysis(s.frozen[0].config) is a  # the frozen run's, not analysed again


def test_an_analysis_refused_is_its_reason_in_one_line(monkeypatch):
    from mfcontrol.experiments import analyze as analysis

    def refuse(cfg):
        raise ConfigError("controller.gamma", None, "give the gain to analyse at\nmore")

    monkeypatch.setattr(analysis, "analyze", refuse)
    assert Session(CASE, SHORT).analysis() == \
        "controller.gamma = None: give the gain to analyse at"
