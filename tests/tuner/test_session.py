"""The tuner's model without a browser: settings read as --set reads them, the runs they
give, freeze, the case file it writes, the options it shows, a map and a tuning."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from mfcontrol.api.run.simulate import simulate
from mfcontrol.cli import main
from mfcontrol.config.toml import parse_assignment
from mfcontrol.errors import CaseError, ConfigError
from mfcontrol.experiments.cases import resolve_case, run_case
from mfcontrol.tuner.session import Session, axis_values, span, text_of

CASE = "voltage-stable-standard"
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


def test_an_empty_entry_restores_the_default():
    s = Session(CASE, {"reference.t_ramp2": 0.005})
    assert s.value("reference.t_ramp2") == 0.005
    assert s.set("reference.t_ramp2", "") is None
    assert s.value("reference.t_ramp2") is None


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
    assert s.frozen is first and second.metrics["iae"] != first.metrics["iae"]
    s.clear()
    assert s.frozen is None


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
    assert not {"sim.h", "sim.t_end", "metrics.stable_tol", "sim.diverge_above"} & set(keys)


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
    assert m.stable[1, 1]
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
