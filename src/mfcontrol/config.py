"""Configuration: every option, its default, its check, and the two fidelity presets.

A configuration is a flat mapping of dotted keys (``controller.alpha``) to values. It is
resolved in this order: option defaults, then the fidelity preset for the keys it governs,
then the case file, then explicit overrides; explicit keys always beat the preset.
Validation happens here, once; kernels assume valid input.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import ConfigError

FIDELITIES = ("published", "paper")


@dataclass(frozen=True)
class Option:
    key: str
    kind: str  # "float", "str", "bool", "floats"
    default: Any
    doc: str
    choices: tuple[str, ...] = ()
    check: str = ""  # "positive", "nonnegative", "fraction", "" (any finite)
    preset: Mapping[str, Any] = field(default_factory=dict)


def _o(key, kind, default, doc, choices=(), check="", preset=None) -> Option:
    return Option(key, kind, default, doc, tuple(choices), check, preset or {})


OPTIONS: tuple[Option, ...] = (
    _o("description", "str", "", "one line describing the case"),
    _o("fidelity", "str", "published", "preset for the options below that differ between the "
       "published code and the printed equations", FIDELITIES),
    # plant
    _o("plant.model", "str", "buck", "plant model: averaged buck or boost converter, or "
       "y' = a y + b u + w", ("buck", "boost", "first-order")),
    _o("plant.output", "str", "voltage", "converters' measured output: v_C, or v_C * i_L "
       "(buck)", ("voltage", "power")),
    _o("plant.coupling", "str", None, "buck input coupling: the published code adds E d/L to "
       "dv/dt as well", ("published", "textbook"),
       preset={"published": "published", "paper": "textbook"}),
    _o("plant.E", "float", 20.0, "input voltage (V)", check="positive"),
    _o("plant.L", "float", 1e-3, "inductance (H)", check="positive"),
    _o("plant.R", "float", 10.0, "load resistance (ohm)", check="positive"),
    _o("plant.C", "float", 10e-6, "capacitance (F)", check="positive"),
    _o("plant.dR", "float", 1.0, "resistance added at each load change (ohm)"),
    _o("plant.dC", "float", 1e-9, "capacitance added at each load change (F)"),
    _o("plant.change_times", "floats", [4e-3, 6e-3], "load change times (s): applied at the "
       "first sample t_k >= each time, before that sample's plant step", check="nonnegative"),
    _o("plant.i0", "float", 0.0, "initial inductor current (A)"),
    _o("plant.v0", "float", 0.0, "initial capacitor voltage (V)"),
    _o("plant.a", "float", -1.0, "first-order: pole a (1/s)"),
    _o("plant.b", "float", 1.0, "first-order: input gain b"),
    _o("plant.w", "float", 0.0, "first-order: disturbance w"),
    _o("plant.y0", "float", 0.0, "first-order: initial output"),
    _o("plant.schedule", "events", [], "parameter changes: a list of {t = time (s), name = "
       "parameter, set = value} or {..., add = delta}, applied at the first t_k >= t"),
    # reference
    _o("reference.kind", "str", "ramp-hold-ramp", "ramp-hold-ramp: min(slope t, level), "
       "then level + slope2 (t - t_ramp2) from t_ramp2 on; smooth-step: from initial to "
       "final along a half cosine over [t0, t0 + duration]",
       ("ramp-hold-ramp", "smooth-step")),
    _o("reference.slope", "float", 1000.0, "first slope (output unit/s)"),
    _o("reference.level", "float", 2.5, "hold level (output unit)"),
    _o("reference.t_ramp2", "float", None, "start of the second ramp (s); absent: none",
       check="nonnegative"),
    _o("reference.slope2", "float", 0.0, "second slope (output unit/s)"),
    _o("reference.initial", "float", 0.0, "smooth-step: value before t0"),
    _o("reference.final", "float", 1.0, "smooth-step: value after t0 + duration"),
    _o("reference.t0", "float", 0.0, "smooth-step: start (s)", check="nonnegative"),
    _o("reference.duration", "float", 0.0, "smooth-step: length (s); 0 for a plain step",
       check="nonnegative"),
    # controller
    _o("controller.law", "str", "ip", "ip: the paper's recursive i-P (eq. 8); variational: "
       "with the symplectic gamma update (eq. 33); i-P, i-PI, i-PD, i-PID: positional "
       "intelligent controllers", ("ip", "variational", "i-P", "i-PI", "i-PD", "i-PID")),
    _o("controller.alpha", "float", 10.0, "key gain alpha of the ultra-local model",
       check="positive"),
    _o("controller.kp", "float", 2.0, "proportional gain K_P"),
    _o("controller.ki", "float", 0.0, "i-PI, i-PID: integral gain K_I"),
    _o("controller.kd", "float", 0.0, "i-PD, i-PID: derivative gain K_D"),
    _o("controller.order", "int", 1, "positional laws: order n of y^(n) = F + alpha u",
       ("1", "2")),
    _o("controller.estimator", "str", "backward-difference", "positional laws: estimator of "
       "F", ("backward-difference", "algebraic")),
    _o("controller.window", "int", 20, "algebraic estimator: window M (samples; even for "
       "n = 2)", check="positive"),
    _o("controller.anti_windup", "str", "auto", "when the output is limited: the recursive "
       "laws' u (clamp: carry the limited value; back-calculation: a share k_aw h of the "
       "excess), the positional laws' integral; auto = none for the recursive laws (as "
       "published), clamp for the positional ones",
       ("auto", "clamp", "back-calculation", "none")),
    _o("controller.k_aw", "float", None, "back-calculation gain (1/s); absent: 1/sim.h",
       check="positive"),
    _o("controller.adapt", "str", "constant", "positional laws: gain adaptation (variational "
       "uses gamma0, Gamma, eps_M, integrator)", ("constant", "variational")),
    _o("controller.gamma0", "float", 1.0, "variational: initial gamma"),
    _o("controller.Gamma", "float", 5e-8, "variational: integrator gain Gamma (the paper "
       "states 5e-8; code v1.0.1 uses h^2/K_gamma = 1e-12 for single runs)"),
    _o("controller.eps_M", "float", 0.1, "variational: bound eps_M on |F_k - F_{k-1}|"),
    _o("controller.k_gamma", "float", 1.0, "variational: coupling K_gamma of the rate term"),
    _o("controller.integrator", "str", None, "variational: gamma integrator order",
       ("first-order", "second-order"),
       preset={"published": "first-order", "paper": "second-order"}),
    _o("controller.rate_term", "bool", None, "variational: add K_gamma dgamma/dt to u "
       "(always 0 in the published code)", preset={"published": False, "paper": True}),
    _o("controller.rate_sign", "str", "plus", "sign of the rate term: plus as printed, minus "
       "as the published code writes it", ("plus", "minus")),
    _o("controller.gain", "str", None, "what multiplies the derivative error: gamma_k, or "
       "1/alpha (eq. 33 taken literally)", ("gamma", "alpha"),
       preset={"published": "gamma", "paper": "gamma"}),
    _o("controller.deriv_scale", "float", 1e-3, "divisor of the backward differences "
       "(published 1e-3; the paper writes h)", check="positive"),
    _o("controller.output_gain", "float", 1 / 2000, "duty = clip(output_gain * u)",
       check="positive"),
    _o("controller.duty_min", "float", 1e-3, "lower output (duty) limit"),
    _o("controller.duty_max", "float", 0.9, "upper output (duty) limit"),
    _o("controller.p_sample", "str", "previous", "measurement in the P term: y_{k-1} "
       "(published) or y_k (printed)", ("previous", "current")),
    _o("controller.p_error", "str", "r-y", "P term error: Kp (r - y) (published) or "
       "Kp (y - r) (printed; positive feedback for Kp > 0)", ("r-y", "y-r")),
    _o("controller.u0", "float", 1.0, "initial control u_0"),
    # simulation
    _o("sim.h", "float", 1e-6, "sample period and RK4 step (s)", check="positive"),
    _o("sim.integrator", "str", "rk4", "plant integration between samples: one RK4 step "
       "(published) or a compiled adaptive Dormand-Prince 5(4) (scipy's RK45 method, input "
       "held, rtol 1e-9, atol 1e-12)", ("rk4", "rk45")),
    _o("sim.t_end", "float", 0.01, "horizon (s); samples t_k = (k t_end)/N, N = t_end/h",
       check="positive"),
    _o("sim.diverge_above", "float", 1e12, "|y| above this (or any NaN/inf) ends a run as "
       "diverged", check="positive"),
    # metrics
    _o("metrics.settle_time", "float", 1e-3, "max |e| is taken over t >= this (s)",
       check="nonnegative"),
    _o("metrics.final_window", "float", 0.2, "stability window: the last fraction of the "
       "horizon", check="fraction"),
    _o("metrics.stable_tol", "float", 0.1, "stable if max |e| over the window <= this "
       "times max |y*|", check="positive"),
    # sweeps
    _o("sweep.key", "str", None, "sweep cases: the option every member varies"),
    _o("sweep.values", "floats", None, "sweep cases: its values, one member each"),
    _o("sweep.grid", "strs", None, "map cases: the grid `mfcontrol sweep` runs when given no "
       "--grid, as [\"KEY=SPEC\", ...]"),
)

BY_KEY: dict[str, Option] = {o.key: o for o in OPTIONS}


def _allowed(o: Option) -> str:
    if o.choices:
        return "must be one of " + ", ".join(o.choices)
    return {
        "float": {"positive": "must be a finite number > 0",
                  "nonnegative": "must be a finite number >= 0",
                  "fraction": "must be a number in (0, 1]",
                  "": "must be a finite number"}[o.check],
        "floats": "must be a list of finite numbers" + (" >= 0" if o.check else ""),
        "int": "must be a whole number" + (" > 0" if o.check else ""),
        "strs": "must be a list of strings",
        "events": "must be a list of tables {t = time >= 0, name = parameter, set = value} "
                  "or {t, name, add = delta}",
        "bool": "must be true or false",
        "str": "must be a string",
    }[o.kind]


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _as_float(v: Any) -> float:
    """float(v), with integers beyond the float range read as infinite (then rejected)."""
    try:
        return float(v)
    except OverflowError:
        return math.inf


def _within(o: Option, v):
    """Whether v (a float, or element-wise an array of them) is in the option's range."""
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(v)
        if o.check == "positive":
            ok = ok & (v > 0)
        elif o.check == "nonnegative":
            ok = ok & (v >= 0)
        elif o.check == "fraction":
            ok = ok & (v > 0) & (v <= 1)
    return ok


def _check_number(o: Option, v: float) -> bool:
    return bool(_within(o, v))


def check_value(key: str, value: Any) -> Any:
    """Return ``value`` converted to the option's type, or raise ConfigError."""
    o = BY_KEY.get(key)
    if o is None:
        raise unknown_key(key, value)
    if o.kind == "float":
        if not _is_number(value) or not _check_number(o, _as_float(value)):
            raise ConfigError(key, value, _allowed(o))
        return float(value)
    if o.kind == "floats":
        if (not isinstance(value, list | tuple)
                or not all(_is_number(x) and _check_number(o, _as_float(x)) for x in value)):
            raise ConfigError(key, value, _allowed(o))
        return [float(x) for x in value]
    if o.kind == "strs":
        if not isinstance(value, list | tuple) or not all(isinstance(x, str) for x in value):
            raise ConfigError(key, value, _allowed(o))
        return list(value)
    if o.kind == "int":
        if (not isinstance(value, int) or isinstance(value, bool)
                or (o.check and value <= 0) or (o.choices and str(value) not in o.choices)):
            raise ConfigError(key, value, _allowed(o))
        return value
    if o.kind == "events":
        if not isinstance(value, list | tuple) or not all(_is_event(e) for e in value):
            raise ConfigError(key, value, _allowed(o))
        return [dict(e) for e in value]
    if o.kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(key, value, _allowed(o))
        return value
    if not isinstance(value, str) or (o.choices and value not in o.choices):
        raise ConfigError(key, value, _allowed(o))
    return value


def _is_event(e: Any) -> bool:
    if not isinstance(e, Mapping) or set(e) not in ({"t", "name", "set"}, {"t", "name", "add"}):
        return False
    t = e["t"]
    v = e["set"] if "set" in e else e["add"]
    return (_is_number(t) and math.isfinite(_as_float(t)) and t >= 0
            and isinstance(e["name"], str) and _is_number(v) and math.isfinite(_as_float(v)))


def unknown_key(key: str, value: Any) -> ConfigError:
    close = difflib.get_close_matches(key, BY_KEY, n=1)
    hint = f"did you mean {close[0]}?" if close else "see `mfcontrol show` for the known keys"
    return ConfigError(key, value, f"unknown key; {hint}")


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested TOML tables to dotted keys."""
    flat: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            flat.update(flatten(v, key + "."))
        else:
            flat[key] = v
    return flat


def parse_assignment(text: str) -> tuple[str, Any]:
    """``key=value`` from the command line; the value is read as a TOML value when it is one
    (numbers, true/false, lists), else taken as a bare string."""
    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep or not key:
        raise ConfigError(text, text, "expected key=value")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


@dataclass(frozen=True)
class Config(Mapping[str, Any]):
    """A resolved, validated configuration (read-only mapping of dotted keys)."""

    values: Mapping[str, Any]

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def __iter__(self):
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def with_overrides(self, overrides: Mapping[str, Any]) -> Config:
        """A new resolved configuration with these keys set (fidelity presets re-applied
        to keys that were never set explicitly)."""
        return resolve({**self.explicit, **dict(overrides)})

    @property
    def explicit(self) -> dict[str, Any]:
        return dict(self.values.get("_explicit", {}))

    def public(self) -> dict[str, Any]:
        return {k: v for k, v in self.values.items() if not k.startswith("_")}

    def nested(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, v in self.public().items():
            if v is None:
                continue
            *heads, last = key.split(".")
            d = out
            for hkey in heads:
                d = d.setdefault(hkey, {})
            d[last] = v
        return out

    def to_toml(self) -> str:
        return to_toml(self.nested())


def resolve(settings: Mapping[str, Any]) -> Config:
    """Validate ``settings`` (dotted keys) and fill every other option. A value of None
    unsets the key (its default or fidelity preset applies)."""
    for key, value in settings.items():
        if key not in BY_KEY:
            raise unknown_key(key, value)
    explicit = {key: check_value(key, v) for key, v in settings.items() if v is not None}
    fidelity = explicit.get("fidelity", BY_KEY["fidelity"].default)
    values: dict[str, Any] = {}
    for o in OPTIONS:
        if o.key in explicit:
            values[o.key] = explicit[o.key]
        elif o.preset:
            values[o.key] = o.preset[fidelity]
        else:
            values[o.key] = o.default
    _check_consistency(values)
    values["_explicit"] = explicit
    return Config(values)


#: most samples one run may have (its trajectory alone would need 9 x 8 bytes a sample)
MAX_STEPS = 100_000_000


#: options whose value the checks across options read (:func:`_check_consistency`)
_CROSS_KEYS = ("sim.h", "sim.t_end", "controller.duty_min", "controller.duty_max",
               "plant.R", "plant.C", "plant.dR", "plant.dC", "controller.window")


def check_axis(base: Config, key: str, values: Any) -> None:
    """Validate every value of a swept numeric option against ``base``, as
    ``base.with_overrides({key: v})`` would for each v, at array speed: the option's
    own check on the whole axis, the checks across options once per value only for the
    options they read."""
    o = BY_KEY.get(key)
    if o is None:
        raise unknown_key(key, values)
    arr = np.asarray(values, dtype=float)
    ok = _within(o, arr)
    if o.kind != "float" or not ok.all():
        bad = values if o.kind != "float" else float(arr[np.flatnonzero(~ok)[0]])
        check_value(key, bad)  # raises with the option's message
    if key in _CROSS_KEYS:
        for v in np.unique(arr):
            _check_consistency({**base.values, key: float(v)})
    elif key.startswith("sweep."):
        base.with_overrides({key: float(arr[0])})


def _check_consistency(v: dict[str, Any]) -> None:
    n = v["sim.t_end"] / v["sim.h"]
    if not n <= MAX_STEPS:  # also catches an overflow to inf
        raise ConfigError("sim.t_end", v["sim.t_end"],
                          f"must be at most {MAX_STEPS:,} steps of sim.h = {v['sim.h']!r}")
    if abs(n - round(n)) > 1e-9 * n or round(n) < 2:
        raise ConfigError("sim.t_end", v["sim.t_end"],
                          f"must be a whole number (>= 2) of sim.h = {v['sim.h']!r} steps")
    if v["controller.duty_min"] > v["controller.duty_max"]:
        raise ConfigError("controller.duty_min", v["controller.duty_min"],
                          f"must not exceed controller.duty_max = {v['controller.duty_max']!r}")
    n_changes = len(v["plant.change_times"])
    for name, delta in (("R", v["plant.dR"]), ("C", v["plant.dC"])):
        lowest = min(v[f"plant.{name}"], v[f"plant.{name}"] + n_changes * delta)
        if lowest <= 0:
            raise ConfigError(f"plant.d{name}", delta,
                              f"must keep plant.{name} > 0 after {n_changes} load changes")
    names = PLANT_PARAMETERS[v["plant.model"]]
    for e in v["plant.schedule"]:
        if e["name"] not in names:
            raise ConfigError("plant.schedule", e, f"name must be a parameter of the "
                              f"{v['plant.model']} plant: {', '.join(names)}")
    if (v["controller.law"] in POSITIONAL and v["controller.estimator"] == "algebraic"
            and v["controller.order"] == 2 and v["controller.window"] % 2):
        raise ConfigError("controller.window", v["controller.window"],
                          "must be even for order 2 (Simpson's rule)")
    if v["controller.law"] in ("ip", "variational") and v["plant.model"] == "first-order":
        raise ConfigError("controller.law", v["controller.law"], "the paper's recursive law "
                          "drives a converter's duty cycle: use i-P .. i-PID for first-order")
    if (v["sweep.key"] is None) != (v["sweep.values"] is None):
        raise ConfigError("sweep.values", v["sweep.values"],
                          "sweep.key and sweep.values go together")
    if v["sweep.key"] is not None:
        o = BY_KEY.get(v["sweep.key"])
        if (o is None or o.kind != "float" or o.key.startswith("sweep.")
                or o.key in _GRID_KEYS):
            raise ConfigError("sweep.key", v["sweep.key"], "must name a numeric option that "
                              "keeps the time grid (not sim.h or sim.t_end)")
        for x in v["sweep.values"]:
            check_value(o.key, x)
            _check_consistency({**v, o.key: x, "sweep.key": None, "sweep.values": None})


_TOML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n",
                 "\f": "\\f", "\r": "\\r"}


def _toml_char(ch: str) -> str:
    """One character of a TOML basic string: control characters must be escaped."""
    if ch in _TOML_ESCAPES:
        return _TOML_ESCAPES[ch]
    return f"\\u{ord(ch):04x}" if ord(ch) < 0x20 or ord(ch) == 0x7F else ch


#: parameters a schedule may change, per plant model
PLANT_PARAMETERS = {"buck": ("E", "L", "R", "C"), "boost": ("E", "L", "R", "C"),
                    "first-order": ("a", "b", "w")}
#: the positional intelligent laws (the others are the paper's recursive law)
POSITIONAL = ("i-P", "i-PI", "i-PD", "i-PID")

#: options every member of one scenario shares: they set the time grid
_GRID_KEYS = ("sim.h", "sim.t_end")


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + "".join(_toml_char(ch) for ch in v) + '"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(nested: Mapping[str, Any]) -> str:
    """Write a two-level mapping (top keys, then tables) as TOML."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in nested.items() if not isinstance(v, dict)]
    for k, v in nested.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            lines.extend(f"{kk} = {_toml_value(vv)}" for kk, vv in v.items())
    return "\n".join(lines) + "\n"


def options_markdown() -> str:
    """The option table of the README, generated from :data:`OPTIONS`."""
    def default(o: Option) -> str:
        if o.preset:
            return " / ".join(f"{f}: `{_toml_value(v)}`" for f, v in o.preset.items())
        return "none" if o.default is None else f"`{_toml_value(o.default)}`"

    rows = ["| key | default | allowed | meaning |", "|---|---|---|---|"]
    for o in OPTIONS:
        allowed = _allowed(o).removeprefix("must be ").replace("|", "\\|")
        rows.append(f"| `{o.key}` | {default(o)} | {allowed} | {o.doc.replace('|', '/')} |")
    return "\n".join(rows)
