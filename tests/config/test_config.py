"""Configuration rules at the Python level: ``mfcontrol.resolve`` and ``mfcontrol.run_case``.

Bad input raises ``ConfigError`` (or ``CaseError`` for a case that cannot be loaded) whose
``key``/``value``/``allowed`` name the key, the offending value and what is allowed, and
whose one-line message says all three.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping

import numpy as np
import pytest

import mfcontrol
from mfcontrol import CaseError, Config, ConfigError, Result, SweepResult, resolve, run_case
from mfcontrol.config.options import BY_KEY, OPTIONS
from mfcontrol.config.toml import flatten, parse_assignment
from mfcontrol.experiments.cases import CASES_DIR, resolve_case

FLOAT_KEYS = [o.key for o in OPTIONS if o.kind == "float"]
POSITIVE_KEYS = [o.key for o in OPTIONS if o.check == "positive" and o.kind == "float"]
PRESET_KEYS = ("plant.coupling", "controller.integrator", "controller.rate_term",
               "controller.gain")
PRESETS = {
    "published": {"plant.coupling": "published", "controller.integrator": "first-order",
                  "controller.rate_term": False, "controller.gain": "gamma"},
    "paper": {"plant.coupling": "textbook", "controller.integrator": "second-order",
              "controller.rate_term": True, "controller.gain": "gamma"},
}
SHORT = {"sim.t_end": 1e-3}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


def check_error(exc: ConfigError, key: str, value=None, *phrases: str) -> str:
    """The error names ``key`` (and ``value`` unless None) and what is allowed, on one line."""
    assert isinstance(exc, ConfigError)
    assert isinstance(exc, ValueError)
    assert exc.key == key
    if value is not None:
        assert _same(exc.value, value), (exc.value, value)
    msg = str(exc)
    assert "\n" not in msg
    assert msg == f"{key} = {exc.value!r}: {exc.allowed}"
    assert exc.allowed
    for phrase in phrases:
        assert phrase in msg, (phrase, msg)
    return msg


def rejects(settings: Mapping, key: str, value=None, *phrases: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        resolve(settings)
    check_error(info.value, key, value, *phrases)
    return info.value


# ---------------------------------------------------------------------------------------
# resolving
# ---------------------------------------------------------------------------------------


def test_defaults():
    cfg = resolve({})
    assert isinstance(cfg, Config)
    assert isinstance(cfg, Mapping)
    assert set(cfg.public()) == set(BY_KEY)
    for o in OPTIONS:
        expected = o.preset["published"] if o.preset else o.default
        assert cfg[o.key] == expected, o.key
    assert cfg.explicit == {}


def test_the_options_the_requirement_names_must_be_positive():
    for key in ("sim.h", "plant.L", "plant.C", "plant.R", "controller.alpha", "sim.t_end"):
        assert key in POSITIVE_KEYS


def test_explicit_values_are_kept_and_converted():
    cfg = resolve({"controller.alpha": 5, "plant.change_times": (1e-3, 2), "sim.h": 1e-6,
                   "description": "x"})
    assert cfg["controller.alpha"] == 5.0 and isinstance(cfg["controller.alpha"], float)
    assert cfg["plant.change_times"] == [1e-3, 2.0]
    assert all(isinstance(x, float) for x in cfg["plant.change_times"])
    assert cfg.explicit == {"controller.alpha": 5.0, "plant.change_times": [1e-3, 2.0],
                            "sim.h": 1e-6, "description": "x"}


def test_numpy_floats_are_numbers():
    cfg = resolve({"controller.alpha": np.float64(4.0)})
    assert cfg["controller.alpha"] == 4.0
    rejects({"controller.alpha": np.float64("nan")}, "controller.alpha")


def test_config_error_fields_and_message():
    exc = ConfigError("a.b", 3, "must be x")
    assert (exc.key, exc.value, exc.allowed) == ("a.b", 3, "must be x")
    assert str(exc) == "a.b = 3: must be x"
    assert issubclass(ConfigError, ValueError)
    assert issubclass(CaseError, ValueError)
    assert mfcontrol.ConfigError is ConfigError and mfcontrol.CaseError is CaseError


# ---------------------------------------------------------------------------------------
# unknown keys, malformed values, choices
# ---------------------------------------------------------------------------------------


def test_unknown_key_suggests_the_close_one():
    exc = rejects({"controller.alpah": 3}, "controller.alpah", 3, "unknown key",
                  "did you mean controller.alpha?")
    assert "controller.alpah = 3" in str(exc)


def test_unknown_key_without_a_close_match():
    rejects({"bogus": 1.0}, "bogus", 1.0, "unknown key")


def test_unknown_key_is_reported_even_when_its_value_is_none():
    rejects({"controller.alpah": None}, "controller.alpah", None, "unknown key")


def test_a_renamed_key_names_its_new_name():
    # `stable` was a tracking test; the tolerance key followed the metric to `settled`
    rejects({"metrics.stable_tol": 0.2}, "metrics.stable_tol", 0.2,
            "renamed metrics.settled_tol")


def test_unknown_key_through_run_case():
    with pytest.raises(ConfigError) as info:
        run_case("voltage-stable-standard", overrides={"plant.RR": 3.0})
    check_error(info.value, "plant.RR", 3.0, "unknown key", "did you mean plant.R?")


MALFORMED = [
    ("controller.alpha", "abc", "must be a finite number > 0"),
    ("controller.alpha", "10", "must be a finite number > 0"),
    ("controller.alpha", [1.0], "must be a finite number > 0"),
    ("controller.alpha", {"x": 1.0}, "must be a finite number > 0"),
    ("controller.kp", "1,5", "must be a finite number"),
    ("sim.h", True, "must be a finite number > 0"),
    ("controller.kp", False, "must be a finite number"),
    ("controller.rate_term", "yes", "must be true or false"),
    ("controller.rate_term", 1, "must be true or false"),
    ("plant.change_times", 0.004, "must be a list of finite numbers >= 0"),
    ("plant.change_times", ["a"], "must be a list of finite numbers >= 0"),
    ("plant.change_times", [True], "must be a list of finite numbers >= 0"),
    ("plant.change_times", "0.004", "must be a list of finite numbers >= 0"),
    ("description", 3, "must be a string"),
    ("sweep.key", 3.0, "must be a string"),
    ("fidelity", "wrong", "must be one of published, paper"),
    ("fidelity", "Paper", "must be one of published, paper"),
    ("controller.law", "PID", "must be one of ip, variational, i-P, i-PI, i-PD, i-PID, pid, adrc"),
    ("plant.output", "current", "must be one of voltage, power"),
    ("plant.coupling", "loose", "must be one of published, textbook"),
    ("controller.integrator", "third-order", "must be one of first-order, second-order"),
    ("controller.gain", "beta", "must be one of gamma, alpha"),
    ("controller.rate_sign", "+", "must be one of plus, minus"),
    ("controller.p_sample", "next", "must be one of previous, current"),
    ("controller.p_error", "r+y", "must be one of r-y, y-r"),
    ("plant.model", "tank", "must be one of buck, boost, first-order, dc-motor, lti"),
    ("reference.kind", "step", "must be one of ramp-hold-ramp, smooth-step"),
    ("metrics.final_window", 1.5, "must be a number in (0, 1]"),
    ("metrics.final_window", 0.0, "must be a number in (0, 1]"),
    ("metrics.settle_time", -1.0, "must be a finite number >= 0"),
    ("reference.t_ramp2", -1e-3, "must be a finite number >= 0"),
    ("plant.change_times", [4e-3, -1e-3], "must be a list of finite numbers >= 0"),
    # the loop's elements, the PID and the DC motor
    ("sensor.noise", "white", "must be one of none, gaussian, uniform"),
    ("sensor.noise_std", -0.1, "must be a finite number >= 0"),
    ("sensor.noise_std", "0.1", "must be a finite number >= 0"),
    ("sensor.seed", -1, "must be a whole number >= 0"),
    ("sensor.seed", 1.5, "must be a whole number >= 0"),
    ("sensor.seed", 2**53, "must be a whole number from 0 to 9,007,199,254,740,991"),
    ("sensor.quantum", float("inf"), "must be a finite number >= 0"),
    ("sensor.delay", -2, "must be a whole number >= 0"),
    ("sensor.delay", 10_000, "must be fewer samples than the run's 10,000 (sim.t_end / sim.h)"),
    ("actuator.delay", 2.0, "must be a whole number >= 0"),
    ("actuator.delay", 10_000, "must be fewer samples than the run's 10,000 (sim.t_end / sim.h)"),
    ("actuator.rate_limit", -5.0, "must be a finite number >= 0"),
    ("disturbance.kind", "impulse", "must be one of none, step, ramp, sine, table"),
    ("disturbance.at", "state", "must be one of input, output"),
    ("disturbance.amplitude", float("nan"), "must be a finite number"),
    ("disturbance.t0", -1.0, "must be a finite number >= 0"),
    ("disturbance.frequency", -50.0, "must be a finite number >= 0"),
    ("disturbance.times", [1.0, "x"], "must be a list of finite numbers >= 0"),
    ("disturbance.values", 3.0, "must be a list of finite numbers"),
    ("sim.substeps", 0, "must be a whole number > 0"),
    ("sim.substeps", 10_001, "must be a whole number from 1 to 10,000 (at most "
                             "100,000,000 plant steps in a run)"),
    ("sensor.delay", 1_000_001, "must be a whole number from 0 to 1,000,000"),
    ("controller.N", 0.0, "must be a finite number > 0"),
    ("controller.b", "one", "must be a finite number"),
    ("controller.Tt", -1.0, "must be a finite number > 0"),
    ("plant.J", 0.0, "must be a finite number > 0"),
    ("plant.friction", -1e-4, "must be a finite number >= 0"),
]


@pytest.mark.parametrize(("key", "value", "allowed"), MALFORMED,
                         ids=[f"{k}={v!r}" for k, v, _ in MALFORMED])
def test_malformed_value(key, value, allowed):
    exc = rejects({key: value}, key, value, allowed)
    assert exc.allowed == allowed


def test_every_choice_is_accepted():
    for o in OPTIONS:
        for choice in o.choices:
            value = int(choice) if o.kind == "int" else choice
            # a first-order plant only takes the positional laws
            extra = ({"controller.law": "i-P"} if value in ("first-order", "dc-motor", "lti")
                     else {})
            if value == "exact":  # the zero-order hold of a linear plant
                extra = {"plant.model": "lti", "controller.law": "i-P"}
            if value == "table":
                extra = {"disturbance.times": [0.0], "disturbance.values": [1.0]}
            assert resolve({o.key: value, **extra})[o.key] == value


# ---------------------------------------------------------------------------------------
# non-positive, NaN, inf
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", [0, -3, 2.5, "20", True])
def test_whole_number_options(value):
    rejects({"controller.window": value}, "controller.window", value,
            "must be a whole number > 0")


@pytest.mark.parametrize("value", [0, 0.0, -0.0, -1, -1e-300, -5.0])
@pytest.mark.parametrize("key", POSITIVE_KEYS)
def test_non_positive(key, value):
    rejects({key: value}, key, value, "must be a finite number > 0")


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("key", FLOAT_KEYS)
def test_nan_and_inf_in_every_number(key, value):
    msg = str(rejects({key: value}, key, value, "finite" if key != "metrics.final_window"
                      else "must be a number in (0, 1]"))
    assert repr(value) in msg


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_nan_and_inf_in_lists(value):
    rejects({"plant.change_times": [4e-3, value]}, "plant.change_times", [4e-3, value],
            "must be a list of finite numbers >= 0")
    rejects({"sweep.key": "controller.Gamma", "sweep.values": [1e-8, value]}, "sweep.values",
            [1e-8, value], "must be a list of finite numbers")


@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_nan_and_inf_through_run_case(value):
    with pytest.raises(ConfigError) as info:
        run_case("voltage-stable-standard", overrides={"controller.kp": value})
    check_error(info.value, "controller.kp", value, "must be a finite number")


def test_huge_integer_is_rejected_not_an_overflow():
    # regression: float(10**400) raised OverflowError out of check_value
    rejects({"controller.alpha": 10**400}, "controller.alpha", 10**400,
            "must be a finite number > 0")
    rejects({"plant.change_times": [10**400]}, "plant.change_times", [10**400])


@pytest.mark.parametrize(("text", "key", "value"), [
    ("[controller]\nalpha = nan\n", "controller.alpha", math.nan),
    ("[plant]\nE = inf\n", "plant.E", math.inf),
    ("[controller]\nkp = -inf\n", "controller.kp", -math.inf),
    ("[reference]\nt_ramp2 = nan\n", "reference.t_ramp2", math.nan),
    ("[plant]\nchange_times = [4e-3, nan]\n", "plant.change_times", [4e-3, math.nan]),
    ('[sweep]\nkey = "plant.dR"\nvalues = [1.0, inf]\n', "sweep.values", [1.0, math.inf]),
    ("[sim]\nh = 0.0\n", "sim.h", 0.0),
    ("[plant]\nL = -1.0\n", "plant.L", -1.0),
], ids=["nan", "inf", "-inf", "nan-optional", "nan-in-list", "inf-in-sweep", "zero-h",
        "negative-L"])
def test_bad_numbers_in_a_case_file(tmp_path, text, key, value):
    path = tmp_path / "case.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        resolve_case(path)
    check_error(info.value, key, value)
    with pytest.raises(ConfigError) as info:
        run_case(str(path))
    check_error(info.value, key, value)


# ---------------------------------------------------------------------------------------
# rules between keys
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("t_end", "h"), [
    (0.0010005, 1e-6), (1e-3, 3e-4), (1e-6, 1e-6), (1e-6, 2e-6), (0.01, 0.004),
    (1e308, 1e-6), (0.01, 5e-324),
], ids=["fraction-of-a-step", "3.33-steps", "one-step", "half-a-step", "2.5-steps",
        "t_end/h-overflows", "h-denormal"])
def test_t_end_must_be_a_whole_number_of_steps(t_end, h):
    rejects({"sim.t_end": t_end, "sim.h": h}, "sim.t_end", t_end, "sim.h")


def test_t_end_not_whole_message():
    exc = rejects({"sim.t_end": 0.0010005}, "sim.t_end", 0.0010005)
    assert "must be a whole number (>= 2) of sim.h = 1e-06 steps" in str(exc)


@pytest.mark.parametrize(("t_end", "h", "n"), [
    (1e-3, 1e-6, 1000), (1.5e-3, 1e-6, 1500), (2e-6, 1e-6, 2), (0.01, 1e-6, 10000),
    (0.3, 0.1, 3),
])
def test_whole_number_of_steps_allowing_rounding(t_end, h, n):
    from mfcontrol.api.run.scenario import n_steps

    cfg = resolve({"sim.t_end": t_end, "sim.h": h})
    assert n_steps(cfg) == n


def test_duty_min_above_duty_max():
    exc = rejects({"controller.duty_min": 0.95}, "controller.duty_min", 0.95)
    assert "must not exceed controller.duty_max = 0.9" in str(exc)
    rejects({"controller.duty_max": 5e-4}, "controller.duty_min", 1e-3, "duty_max = 0.0005")
    rejects({"controller.duty_min": 0.5, "controller.duty_max": 0.4}, "controller.duty_min",
            0.5)
    cfg = resolve({"controller.duty_min": 0.5, "controller.duty_max": 0.5})
    assert cfg["controller.duty_min"] == cfg["controller.duty_max"] == 0.5


@pytest.mark.parametrize(("settings", "key"), [
    ({"plant.dR": -5.0}, "plant.dR"),  # 10 - 2*5 = 0
    ({"plant.dR": -6}, "plant.dR"),
    ({"plant.dR": -10.0, "plant.change_times": [4e-3]}, "plant.dR"),
    ({"plant.R": 1.0, "plant.dR": -0.5}, "plant.dR"),
    ({"plant.dR": -2.0, "plant.change_times": [1e-3, 2e-3, 3e-3, 4e-3, 5e-3]}, "plant.dR"),
    ({"plant.dC": -5e-6}, "plant.dC"),
])
def test_load_change_that_makes_r_or_c_non_positive(settings, key):
    exc = rejects(settings, key, float(settings[key]))
    name = key[-1]
    n = len(settings.get("plant.change_times", [4e-3, 6e-3]))
    assert f"must keep plant.{name} > 0 after {n} load changes" in str(exc)


@pytest.mark.parametrize("settings", [
    {"plant.dR": -4.9},
    {"plant.dR": -9.9, "plant.change_times": [4e-3]},
    {"plant.dR": -100.0, "plant.change_times": []},
    {"plant.dR": 1e6},
    {"plant.dC": -4e-6},
])
def test_load_change_that_keeps_r_and_c_positive(settings):
    resolve(settings)


def test_dR_through_run_case():
    with pytest.raises(ConfigError) as info:
        run_case("voltage-unstable-standard", overrides={"plant.R": 10.0, "plant.dR": -5.0})
    check_error(info.value, "plant.dR", -5.0, "plant.R > 0")


# ---------------------------------------------------------------------------------------
# None unsets a key
# ---------------------------------------------------------------------------------------


def test_none_unsets_a_key():
    cfg = resolve({"controller.alpha": None, "controller.kp": 3.0})
    assert cfg["controller.alpha"] == BY_KEY["controller.alpha"].default
    assert cfg.explicit == {"controller.kp": 3.0}


def test_none_unsets_a_case_value():
    _, cfg = resolve_case("voltage-unstable-standard")
    assert cfg["plant.dR"] == 5.0
    _, cfg = resolve_case("voltage-unstable-standard", {"plant.dR": None})
    assert cfg["plant.dR"] == BY_KEY["plant.dR"].default
    assert "plant.dR" not in cfg.explicit


def test_none_unsets_with_overrides():
    cfg = resolve({"controller.alpha": 3.0, "fidelity": "paper"})
    back = cfg.with_overrides({"controller.alpha": None})
    assert back["controller.alpha"] == 10.0
    assert back["fidelity"] == "paper"
    assert cfg["controller.alpha"] == 3.0  # the original is unchanged


@pytest.mark.parametrize("case", ["voltage-stable-standard", "bench-lag3", "motor-noise-pid"])
def test_with_overrides_is_resolve_of_the_merged_settings(case):
    # with_overrides checks only the keys it is given (the configuration's own were
    # checked when it was resolved): what it returns must be what resolve gives the
    # merged settings, and no list may be shared with the configuration it came from
    _, cfg = resolve_case(case)
    overrides = {"controller.kp": 2.5, "plant.schedule": [], "sim.t_end": 3,
                 "sensor.noise": None}
    got = cfg.with_overrides(overrides)
    want = resolve({**cfg.explicit, **overrides})
    assert got.values == want.values
    assert list(got.explicit) == list(want.explicit)  # the same keys in the same order
    for key, v in got.values.items():
        if isinstance(v, list) and key in cfg.values:
            assert v is not cfg.values[key] or key not in cfg.explicit
    with pytest.raises(ConfigError, match="controller.kp"):
        cfg.with_overrides({"controller.kp": "x"})
    with pytest.raises(ConfigError, match="controller.nope"):
        cfg.with_overrides({"controller.nope": 1.0})


def test_none_on_a_preset_key_gives_the_preset_back():
    cfg = resolve({"fidelity": "paper", "plant.coupling": None})
    assert cfg["plant.coupling"] == "textbook"


def test_none_unsets_the_sweep_of_a_sweep_case():
    result = run_case("sweep-Gamma", {"sweep.key": None, "sweep.values": None, **SHORT})
    assert isinstance(result, Result)
    swept = run_case("sweep-epsM", SHORT)
    assert isinstance(swept, SweepResult)
    assert swept.values == [1e-5, 0.1, 1e3]


# ---------------------------------------------------------------------------------------
# fidelity presets
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("fidelity", ["published", "paper"])
def test_fidelity_preset(fidelity):
    cfg = resolve({"fidelity": fidelity})
    assert {k: cfg[k] for k in PRESET_KEYS} == PRESETS[fidelity]
    assert cfg.explicit == {"fidelity": fidelity}
    # the preset governs exactly these keys
    assert {o.key for o in OPTIONS if o.preset} == set(PRESET_KEYS)


def test_published_is_the_default_fidelity():
    cfg = resolve({})
    assert cfg["fidelity"] == "published"
    assert {k: cfg[k] for k in PRESET_KEYS} == PRESETS["published"]


@pytest.mark.parametrize("fidelity", ["published", "paper"])
@pytest.mark.parametrize("key", PRESET_KEYS)
def test_explicit_key_beats_the_preset(fidelity, key):
    other = {"plant.coupling": {"published": "textbook", "paper": "published"},
             "controller.integrator": {"published": "second-order", "paper": "first-order"},
             "controller.rate_term": {"published": True, "paper": False},
             "controller.gain": {"published": "alpha", "paper": "alpha"}}[key][fidelity]
    cfg = resolve({"fidelity": fidelity, key: other})
    assert cfg[key] == other
    for k in PRESET_KEYS:
        if k != key:
            assert cfg[k] == PRESETS[fidelity][k]
    # the order of the keys does not matter
    assert resolve({key: other, "fidelity": fidelity})[key] == other


def test_case_file_values_beat_the_preset_and_overrides_beat_the_case(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('fidelity = "paper"\n[plant]\ncoupling = "published"\n'
                    '[controller]\nalpha = 4.0\n')
    _, cfg = resolve_case(path)
    assert cfg["plant.coupling"] == "published"
    assert cfg["controller.integrator"] == "second-order"
    _, cfg = resolve_case(path, {"fidelity": "published", "controller.alpha": 6.0})
    assert cfg["plant.coupling"] == "published"
    assert cfg["controller.integrator"] == "first-order"
    assert cfg["controller.alpha"] == 6.0


def test_with_overrides_reapplies_the_preset_to_keys_never_set():
    cfg = resolve({"fidelity": "published", "controller.integrator": "first-order"})
    paper = cfg.with_overrides({"fidelity": "paper"})
    assert paper["controller.integrator"] == "first-order"  # explicit, kept
    assert paper["plant.coupling"] == "textbook"
    assert paper["controller.rate_term"] is True


def test_run_case_applies_the_fidelity():
    r = run_case("voltage-stable-variational", {"fidelity": "paper", **SHORT})
    assert {k: r.config[k] for k in PRESET_KEYS} == PRESETS["paper"]


# ---------------------------------------------------------------------------------------
# sweeps
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("key", [
    "controller.law", "description", "fidelity", "controller.rate_term", "plant.change_times",
    "sweep.values", "sweep.key", "nope", "controller.alpah", "sim.h", "sim.t_end",
])
def test_sweep_key_must_name_a_numeric_option(key):
    exc = rejects({"sweep.key": key, "sweep.values": [1.0]}, "sweep.key", key)
    assert "must name a numeric option" in str(exc)


@pytest.mark.parametrize("key", ["controller.Gamma", "controller.eps_M", "plant.dR",
                                 "controller.alpha", "plant.E", "controller.kp"])
def test_sweep_key_numeric_option_accepted(key):
    cfg = resolve({"sweep.key": key, "sweep.values": [1.0, 2.0]})
    assert cfg["sweep.key"] == key
    assert cfg["sweep.values"] == [1.0, 2.0]


def test_sweep_values_obey_the_swept_option():
    rejects({"sweep.key": "controller.alpha", "sweep.values": [1.0, 0.0]}, "controller.alpha",
            0.0, "must be a finite number > 0")
    rejects({"sweep.key": "metrics.final_window", "sweep.values": [2.0]},
            "metrics.final_window", 2.0)


def test_sweep_key_and_values_go_together():
    rejects({"sweep.key": "controller.Gamma"}, "sweep.values", None, "go together")
    rejects({"sweep.values": [1.0]}, "sweep.values", [1.0], "go together")


def test_sweep_member_that_breaks_a_rule_between_keys_is_rejected_at_run():
    with pytest.raises(ConfigError) as info:
        run_case("voltage-stable-standard",
                 {"sweep.key": "plant.dR", "sweep.values": [-20.0], **SHORT})
    check_error(info.value, "plant.dR", -20.0, "plant.R > 0")


# ---------------------------------------------------------------------------------------
# key=value from the command line
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "key", "value"), [
    ("controller.alpha=5", "controller.alpha", 5),
    ("controller.alpha = 5.5", "controller.alpha", 5.5),
    ("plant.dR=-1e-3", "plant.dR", -1e-3),
    ("controller.rate_term=true", "controller.rate_term", True),
    ("plant.change_times=[1e-3, 2e-3]", "plant.change_times", [1e-3, 2e-3]),
    ("fidelity=paper", "fidelity", "paper"),
    ('fidelity="paper"', "fidelity", "paper"),
    ("description=a b=c", "description", "a b=c"),
    ("controller.alpha=abc", "controller.alpha", "abc"),
    ("controller.alpha=", "controller.alpha", ""),
    ("controller.kp=nan", "controller.kp", math.nan),
    ("plant.E=inf", "plant.E", math.inf),
    ("plant.E=-inf", "plant.E", -math.inf),
])
def test_parse_assignment(text, key, value):
    k, v = parse_assignment(text)
    assert k == key
    assert _same(v, value), (v, value)


@pytest.mark.parametrize("text", ["controller.alpha", "=3", " = 3", ""])
def test_parse_assignment_needs_key_and_equals(text):
    with pytest.raises(ConfigError) as info:
        parse_assignment(text)
    assert "expected key=value" in str(info.value)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------
# cases, files, TOML
# ---------------------------------------------------------------------------------------


def test_unknown_case():
    with pytest.raises(CaseError) as info:
        run_case("nope")
    msg = str(info.value)
    assert "'nope'" in msg and "\n" not in msg
    for name in mfcontrol.case_names():
        assert name in msg


def test_missing_case_file(tmp_path):
    for path in (tmp_path / "nope.toml", str(tmp_path / "nope.toml")):
        with pytest.raises(CaseError, match="not found"):
            run_case(path)
    with pytest.raises(CaseError, match="is a folder, not a case"):
        run_case(tmp_path)


@pytest.mark.parametrize("text", [
    b"[plant\nE = 3.0\n", b"[controller]\nalpha =\n", b"[plant]\nE = 1.0\nE = 2.0\n",
    b'description = "open\n', b"alpha = 1.0.0\n",
], ids=["unclosed-table", "no-value", "duplicate", "unterminated-string", "bad-number"])
def test_malformed_toml(tmp_path, text):
    path = tmp_path / "bad.toml"
    path.write_bytes(text)
    with pytest.raises(CaseError) as info:
        run_case(path)
    msg = str(info.value)
    assert "bad.toml" in msg and "is not valid TOML" in msg and "\n" not in msg


def test_case_file_not_utf8(tmp_path):
    path = tmp_path / "bin.toml"
    path.write_bytes(b"\xff\xfe[plant]\n")
    with pytest.raises(CaseError, match="cannot be read"):
        resolve_case(path)


def test_flatten():
    assert flatten({"a": 1, "b": {"c": 2, "d": {"e": 3}}}) == {"a": 1, "b.c": 2, "b.d.e": 3}


CASE_NAMES = sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def test_builtin_cases():
    assert CASE_NAMES == sorted(mfcontrol.case_names())
    # the paper's eight, three toolkit cases, three maps, five realistic loops, the ten
    # plants of the benchmark set
    assert len(CASE_NAMES) == 29
    assert sum(n.startswith("bench-") for n in CASE_NAMES) == 10


@pytest.mark.parametrize("fidelity", ["published", "paper"])
@pytest.mark.parametrize("name", CASE_NAMES)
def test_to_toml_round_trip(tmp_path, name, fidelity):
    _, cfg = resolve_case(name, {"fidelity": fidelity})
    text = cfg.to_toml()
    again = resolve(flatten(tomllib.loads(text)))
    assert again.public() == cfg.public()
    assert again.to_toml() == text
    path = tmp_path / "x.toml"
    path.write_text(text)
    assert resolve_case(path)[1].to_toml() == text


@pytest.mark.parametrize("description", ["two\nlines", "bell\x07", "del\x7f"])
def test_to_toml_round_trip_of_control_characters(description):
    cfg = resolve({"description": description})
    again = resolve(flatten(tomllib.loads(cfg.to_toml())))
    assert again["description"] == description


def test_to_toml_round_trip_of_quotes_and_backslashes():
    description = 'say "hi" \\ back\tslash, unicode: \u03b3'
    cfg = resolve({"description": description})
    again = resolve(flatten(tomllib.loads(cfg.to_toml())))
    assert again["description"] == description


# ---------------------------------------------------------------------------------------
# run_case happy paths
# ---------------------------------------------------------------------------------------


def test_run_case_builtin():
    r = run_case("voltage-stable-standard", overrides=SHORT)
    assert isinstance(r, Result)
    assert r.metrics["settled"] is True
    assert 0.5 < float(r.signals["y"][-1]) < 1.0  # tracking the 1000 V/s ramp (0.999 at t_end)
    assert len(r.time) == 1000
    assert r.config["sim.t_end"] == 1e-3
    assert r.name == "voltage-stable-standard"


def test_run_case_user_file_with_overrides(tmp_path):
    text = (CASES_DIR / "voltage-stable-standard.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text.replace("alpha = 10.0", "alpha = 5.0"))
    r = run_case(path, SHORT)
    assert r.name == "mine"
    assert r.config["controller.alpha"] == 5.0
    assert r.metrics["final_gamma"] == pytest.approx(0.2)
    r = run_case(str(path), {"controller.alpha": 4.0, **SHORT})
    assert r.config["controller.alpha"] == 4.0


@pytest.mark.parametrize("case", ["voltage-stable-standard", "buck-ipi",
                                  "first-order-ip-algebraic", "first-order-order2"])
def test_check_axis_refuses_exactly_what_with_overrides_refuses(case):
    # check_axis runs the checks across options only when they read the swept key: for
    # every numeric option and values that break them (an odd window, duty_min over
    # duty_max, R driven negative by the load changes, a grid that is not whole), it
    # must agree with building each member's configuration
    from mfcontrol.config.resolve import axis_value, check_axis
    from mfcontrol.experiments.cases import resolve_case

    _, base = (resolve_case("first-order-ip-algebraic", {"controller.order": 2})
               if case == "first-order-order2" else resolve_case(case))
    for o in OPTIONS:
        if o.kind not in ("float", "int") or o.key.startswith("sweep."):
            continue
        v0 = base[o.key] if base[o.key] is not None else 1.0
        for values in ([v0, 2 * v0 + 1], [v0, -3 * v0 - 1], [v0, v0 + 0.5, 1e9], [11.0],
                       [v0, 2 * v0]):
            refused = False
            for v in values:
                try:
                    base.with_overrides({o.key: axis_value(o.key, v)})
                except ConfigError:
                    refused = True
            try:
                check_axis(base, o.key, values)
                axis_refused = False
            except ConfigError:
                axis_refused = True
            assert axis_refused == refused, (o.key, values)


def test_an_algebraic_window_longer_than_the_run_is_refused_in_one_line():
    # a window of 1e12 samples ended in a 14.6 TiB allocation (found in review)
    for w in (4000, 10**12):
        with pytest.raises(ConfigError, match=r"controller.window = \d+: must be fewer samples "
                                              r"than the run's 4,000"):
            mfcontrol.run_case("first-order-ip-algebraic", {"controller.window": w})
    with pytest.raises(ValueError, match="from 2 to 10,000,000"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=1e-3, estimator="algebraic",
                     window=10**9)


def test_keys_read_are_the_keys_a_translator_reads_for_this_configuration():
    from mfcontrol.api import params
    from mfcontrol.config.resolve import keys_read, resolve

    def read(**keys):
        cfg = resolve({f"controller.{k}": v for k, v in keys.items()})
        return keys_read(params.recursive_law_column, cfg, 1e-6)

    assert {"controller.kp", "controller.duty_max"} <= read(law="ip")
    # k_aw only matters to back-calculation, rate_term only to the variational law
    assert "controller.k_aw" not in read(law="ip", anti_windup="clamp")
    assert "controller.k_aw" in read(law="ip", anti_windup="back-calculation")
    assert "controller.rate_term" not in read(law="ip")
    assert "controller.rate_term" in read(law="variational")


# ---------------------------------------------------------------------------------------
# checks across the new options: tables, the PID's gains, the recursive law's plants
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("settings", "key", "phrase"), [
    ({"disturbance.kind": "table", "disturbance.times": [0.0, 1.0],
      "disturbance.values": [1.0]}, "disturbance.values",
     "must have one value per time of disturbance.times (2), at least one"),
    ({"disturbance.kind": "table"}, "disturbance.values", "at least one"),
    ({"disturbance.kind": "table", "disturbance.times": [1.0, 0.5],
      "disturbance.values": [1.0, 2.0]}, "disturbance.times", "must be nondecreasing"),
    ({"controller.law": "pid", "controller.kp": 0.0, "controller.kd": 1.0},
     "controller.kd", "must have the sign of controller.kp"),
    ({"controller.law": "pid", "controller.kp": 1.0, "controller.kd": -1.0},
     "controller.kd", "must have the sign of controller.kp"),
    ({"controller.law": "pid", "controller.kp": -1.0, "controller.ki": 1.0},
     "controller.ki", "must have the sign of controller.kp"),
    ({"plant.model": "dc-motor"}, "controller.law", "use i-P .. i-PID or pid for dc-motor"),
])
def test_checks_across_the_new_options(settings, key, phrase):
    rejects(settings, key, settings.get(key, resolve({})[key]
                                        if key != "controller.law" else "ip"), phrase)


def test_a_pid_with_a_tracking_time_may_have_any_integral_sign():
    cfg = resolve({"controller.law": "pid", "controller.kp": -1.0, "controller.ki": 1.0,
                   "controller.Tt": 0.1})
    assert cfg["controller.Tt"] == 0.1


def test_numpy_scalars_and_arrays_are_taken_as_the_live_api_takes_them():
    """Issue 14 item 9: numpy values, which the live controllers accept, for every kind."""
    cfg = resolve({"plant.dR": np.int64(3), "controller.alpha": np.float32(2.5),
                   "plant.change_times": np.array([0.004, 0.006]),
                   "fidelity": np.str_("paper")})
    assert cfg["plant.dR"] == 3.0 and type(cfg["plant.dR"]) is float
    assert cfg["controller.alpha"] == 2.5
    assert cfg["plant.change_times"] == [0.004, 0.006]
    assert all(type(t) is float for t in cfg["plant.change_times"])
    rejects({"plant.change_times": np.array([[0.004]])}, "plant.change_times")
    rejects({"plant.dR": np.bool_(True)}, "plant.dR")


def test_axis_labels_name_options_in_words():
    """Figures' axes say the quantity (issue 15: maps showed 'controller.Gamma (1)')."""
    from mfcontrol.config import options

    assert set(options.LABELS) <= set(options.BY_KEY)
    assert all("." not in text.split("(")[0] for text in options.LABELS.values())
    assert options.label("plant.dR") == "load change dR (ohm)"
    assert options.label("sim.custom") == "sim.custom"


def test_a_config_needs_its_values():
    """Found in review: dataclass took the inherited Mapping.values as the field's default,
    so Config() was accepted (and failed later) and help() showed values=<function ...>."""
    import inspect

    from mfcontrol.config.resolve import Config

    with pytest.raises(TypeError):
        Config()  # type: ignore[call-arg]
    assert inspect.signature(Config).parameters["values"].default is inspect.Parameter.empty


def test_options_documentation_is_valid_restructuredtext():
    """|F_k - F_{k-1}| in an option's doc became an undefined rST substitution on the API
    page of RecursiveIP (the docs build fails on it); every option's doc renders."""
    import docutils.core
    import docutils.utils

    from mfcontrol.config import options

    text = options.numpydoc_parameters([o.key for o in options.OPTIONS if "." in o.key])
    assert "``|F_k - F_{k-1}|``" in text
    docutils.core.publish_doctree(text, settings_overrides={
        "report_level": docutils.utils.Reporter.WARNING_LEVEL, "halt_level": 2})


# --- issue 29, item 6: sizes bounded up front ----------------------------------------------


def _refusal(settings: Mapping) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        resolve(settings)
    message = str(info.value)
    assert "\n" not in message and len(message) < 400, message  # one short line
    return info.value


def test_load_change_times_are_bounded():
    """1,000 change times in an 8 KB case file cost half a minute of CPU in the run's
    figure, 1.5 million hung sweeps and tuning: at most 1,000, refused before anything."""
    from mfcontrol.config.options import MAX_CHANGE_TIMES

    times = [1e-3 * (i + 1) / MAX_CHANGE_TIMES for i in range(MAX_CHANGE_TIMES)]
    small = {"plant.dR": 1e-3}  # R stays > 0 after every change
    assert len(resolve({**small, "plant.change_times": times})["plant.change_times"]) == 1000
    for n in (MAX_CHANGE_TIMES + 1, 1_500_000):
        exc = _refusal({**small, "plant.change_times": [1e-3] * n})
        assert exc.key == "plant.change_times"
        assert str(exc).startswith("plant.change_times = [0.001, 0.001")
        assert f"must list at most 1,000 times ({n:,} given)" in str(exc)
    assert "at most 1,000" in BY_KEY["plant.change_times"].doc


def test_a_description_is_bounded():
    """A 10 MB description took over two minutes (its figure title): at most 2,000
    characters, the refusal showing only the start of it."""
    from mfcontrol.config.options import MAX_DESCRIPTION

    assert resolve({"description": "x" * MAX_DESCRIPTION})["description"] == "x" * 2000
    for n in (MAX_DESCRIPTION + 1, 10_000_000):
        exc = _refusal({"description": "y" * n})
        assert exc.key == "description" and str(exc).startswith("description = 'yyy")
        assert f"must be at most 2,000 characters ({n:,} given)" in str(exc)
    assert "at most 2,000 characters" in BY_KEY["description"].doc


def test_a_transfer_function_degree_is_bounded():
    """A degree-400 plant.den ran over two minutes: a degree above 20 is refused, naming
    the key and the bound, whichever plant model is set (it is checked up front); so is
    a plant.num of more coefficients than such a denominator has."""
    from mfcontrol.config.options import MAX_TF_DEGREE

    lti = {"plant.model": "lti", "controller.law": "i-P"}
    top = [1.0] * (MAX_TF_DEGREE + 1)  # degree 20
    assert resolve({**lti, "plant.den": top})["plant.den"] == top
    assert resolve({**lti, "plant.den": top, "plant.num": [0.0] + top[1:]})
    for settings in ({**lti, "plant.den": top + [1.0]}, {"plant.den": [1.0] * 401}):
        exc = _refusal(settings)
        assert exc.key == "plant.den"
        assert "must have degree at most 20 (at most 21 coefficients;" in str(exc)
    exc = _refusal({**lti, "plant.den": top, "plant.num": top + [1.0]})
    assert exc.key == "plant.num" and "must have at most 21 coefficients (22 given" in str(exc)
    assert "degree at most 20" in BY_KEY["plant.den"].doc


def test_a_window_of_one_sample_is_refused_naming_the_key():
    """controller.window = 1 passed the option's check (positive) and the live law then
    raised a ValueError traceback from `mfcontrol run` (exit 1)."""
    exc = _refusal({"controller.law": "i-PI", "controller.estimator": "algebraic",
                    "controller.window": 1})
    assert exc.key == "controller.window"
    assert str(exc) == ("controller.window = 1: must be at least 2 samples for the algebraic "
                        "estimator")


@pytest.mark.parametrize("keys,message", [
    ({"controller.delay": 100_001},
     "controller.delay = 100001: must be a whole number of samples from 0 to 100,000"),
    ({"controller.delay": 3, "controller.predict": True, "controller.order": 2},
     "controller.predict = True: the prediction over the delay is of order 1: set "
     "controller.order = 1, or remove it"),
    ({"controller.estimator": "algebraic", "controller.order": 2, "controller.window": 9,
      "controller.kernel": "trapezoid"},
     "controller.window = 9: must be even for order 2 with the trapezoid kernel"),
])
def test_the_laws_own_rules_are_refused_in_the_keys_names(keys, message):
    # the rules live once (intelligent.delay_problem, estimators.parity_problem); the
    # configuration and the live classes phrase them in their own keys
    base = {"plant.model": "first-order", "controller.law": "i-PD", "controller.kd": 1.0}
    with pytest.raises(ConfigError, match="^" + message.replace("(", r"\(")):
        resolve({**base, **keys})
    live = {k.removeprefix("controller."): v for k, v in keys.items()}
    with pytest.raises(ValueError, match="^" + message.removeprefix("controller.")
                       .replace("controller.order = ", "order=").replace("(", r"\(")):
        mfcontrol.IPD(alpha=1.0, kp=1.0, kd=1.0, sample_time=0.01, **live)


@pytest.mark.parametrize("keys,message", [
    ({"controller.kernel": "delay-reduced", "controller.order": 2},
     "controller.kernel = 'delay-reduced': weighs the algebraic estimator's window"),
    ({"controller.kernel": "delay-reduced", "controller.estimator": "algebraic",
      "controller.window": 8, "controller.lag": 8.5},
     "controller.lag = 8.5: must be from 0 to M = 8 samples"),
    ({"controller.kernel": "delay-reduced", "controller.estimator": "algebraic",
      "controller.window": 8, "controller.kappa": 2},
     r"controller.kappa = 2: kappa \+ mu must be at most 2 \(here kappa = 2, mu = 1\)"),
    ({"controller.kernel": "delay-reduced", "controller.estimator": "algebraic",
      "controller.window": 8, "controller.kappa": 0, "controller.mu": 3},
     r"controller.mu = 3: kappa \+ mu must be at most 2"),
])
def test_the_delay_reduced_kernels_rules_in_a_case(keys, message):
    base = {"plant.model": "first-order", "controller.law": "i-P"}
    with pytest.raises(ConfigError, match="^" + message):
        resolve({**base, **keys})
    # a case runs it: at lag M/2 it is the held kernel (to rounding), at lag 0 it is not
    held = run_case("first-order-ip-algebraic").metrics["iae"]
    centre = run_case("first-order-ip-algebraic", {"controller.kernel": "delay-reduced",
                                                   "controller.lag": 10.0})
    assert centre.metrics["iae"] == pytest.approx(held, rel=1e-9)
    assert centre.config["controller.window"] == 20
    newest = run_case("first-order-ip-algebraic", {"controller.kernel": "delay-reduced"})
    assert newest.config["controller.lag"] is None  # the kernel's default, 0
    assert abs(newest.metrics["iae"] / held - 1.0) > 0.1


def test_the_rls_gain_in_a_case():
    base = {"plant.model": "first-order", "controller.law": "i-P", "controller.adapt": "rls"}
    with pytest.raises(ConfigError, match=r"^controller.forgetting = 1.5: must be in \(0, 1\]"):
        resolve({**base, "controller.forgetting": 1.5})
    with pytest.raises(ConfigError, match="^controller.alpha_max = 0.5: must be at least the "
                       "starting alpha"):
        resolve({**base, "controller.alpha": 1.0, "controller.alpha_max": 0.5})
    with pytest.raises(ConfigError, match="^controller.forgetting = 0.9: not read"):
        resolve_case("first-order-ip-algebraic", {"controller.forgetting": 0.9},
                     command="run")
    with pytest.raises(ConfigError, match="^controller.adapt = 'rls': the exact estimate "
                       "alpha = beta"):
        resolve({**base, "controller.kp": 1e3, "sim.h": 0.01, "sim.t_end": 1.0})
    r = mfcontrol.simulate(resolve({**base, "controller.forgetting": 0.98}))
    assert r.config["controller.adapt"] == "rls" and not r.metrics["diverged"]
