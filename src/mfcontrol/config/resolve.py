"""Resolve and validate a configuration, once, at the edge.

A configuration is a flat mapping of dotted keys (``controller.alpha``) to values. It is
resolved in this order: option defaults, then the fidelity preset for the keys it governs,
then the case file, then explicit overrides; explicit keys always beat the preset. Every
error names the key, the value and what is allowed; kernels assume valid input.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..elements import noise
from ..errors import ConfigError, as_float
from ..laws import adrc, estimators, intelligent, variational_gain
from ..numerics import grid
from .options import (
    BY_KEY,
    MAX_CHANGE_TIMES,
    MAX_DESCRIPTION,
    MAX_TF_DEGREE,
    OPTIONS,
    PLANT_PARAMETERS,
    POSITIONAL,
    Option,
    allowed,
)
from .toml import to_toml


def _is_number(v: Any) -> bool:
    """A real number: Python's, or NumPy's (np.int64, np.float32, ...); not a bool."""
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(
        v, bool | np.bool_)


#: each range check as a test on a float or, element-wise, an array of them
_RANGES = {"positive": lambda v: v > 0, "nonnegative": lambda v: v >= 0,
           "fraction": lambda v: (v > 0) & (v <= 1)}


def _within(o: Option, v):
    """Whether v (a float, or element-wise an array of them) is in the option's range."""
    test = _RANGES.get(o.check)
    if isinstance(v, float):  # one number (every checked value): no numpy machinery, 10x
        return math.isfinite(v) and (test is None or test(v))
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(v)
        return ok & test(v) if test is not None else ok


def _check_number(o: Option, v: float) -> bool:
    return bool(_within(o, v))


def check_value(key: str, value: Any) -> Any:
    """Return ``value`` converted to the option's type, or raise ConfigError."""
    o = BY_KEY.get(key)
    if o is None:
        raise unknown_key(key, value)
    if o.kind == "float":
        if not _is_number(value) or not _check_number(o, as_float(value)):
            raise ConfigError(key, value, allowed(o))
        return float(value)
    if o.kind == "floats":
        if isinstance(value, np.ndarray) and value.ndim == 1:  # as numpy users hold lists
            value = value.tolist()
        _check_size(key, value)  # before each element's check (seconds per million)
        if (not isinstance(value, list | tuple)
                or not all(_is_number(x) and _check_number(o, as_float(x)) for x in value)):
            raise ConfigError(key, value, allowed(o))
        return [float(x) for x in value]
    if o.kind == "strs":
        if not isinstance(value, list | tuple) or not all(isinstance(x, str) for x in value):
            raise ConfigError(key, value, allowed(o))
        return list(value)
    if o.kind == "int":
        if isinstance(value, np.integer):
            value = int(value)
        if (not isinstance(value, int) or isinstance(value, bool)
                or (o.check == "positive" and value <= 0)
                or (o.check == "nonnegative" and value < 0)
                or (o.choices and str(value) not in o.choices)):
            raise ConfigError(key, value, allowed(o))
        if key == "sensor.seed" and value >= noise.MAX_SEED:  # the noise hash's range
            raise ConfigError(key, value, f"must be a whole number from 0 to "
                              f"{noise.MAX_SEED - 1:,}")
        return value
    if o.kind == "events":
        if not isinstance(value, list | tuple) or not all(_is_event(e) for e in value):
            raise ConfigError(key, value, allowed(o))
        return [dict(e) for e in value]
    if o.kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(key, value, allowed(o))
        return value
    if not isinstance(value, str) or (o.choices and value not in o.choices):
        raise ConfigError(key, value, allowed(o))
    _check_size(key, value)
    return value


#: characters of a value a refusal of its size shows: the point is that it is too long
_SIZE_SHOWN = 60


def _check_size(key: str, value: Any) -> None:
    """Refuse, up front and in one line, a list or text whose size would cost minutes
    (each load change is an event and a mark on the figures, a transfer function's
    degree a compilation, a description a title to lay out); see the bounds' reasons in
    :mod:`.options`."""
    if not isinstance(value, list | tuple | str):
        return  # the option's own check refuses it
    n = len(value)
    if key == "description" and n > MAX_DESCRIPTION:
        raise ConfigError(key, value, f"must be at most {MAX_DESCRIPTION:,} characters "
                          f"({n:,} given)", limit=_SIZE_SHOWN)
    if key == "plant.change_times" and n > MAX_CHANGE_TIMES:
        raise ConfigError(key, value, f"must list at most {MAX_CHANGE_TIMES:,} times ({n:,} "
                          "given)", limit=_SIZE_SHOWN)
    if key == "plant.den" and n > MAX_TF_DEGREE + 1:
        raise ConfigError(key, value, f"must have degree at most {MAX_TF_DEGREE} (at most "
                          f"{MAX_TF_DEGREE + 1} coefficients; {n:,} given): beyond, "
                          "double-precision coefficients no longer fix the poles",
                          limit=_SIZE_SHOWN)
    if key == "plant.num" and n > MAX_TF_DEGREE + 1:
        raise ConfigError(key, value, f"must have at most {MAX_TF_DEGREE + 1} coefficients "
                          f"({n:,} given; plant.den's degree is at most {MAX_TF_DEGREE})",
                          limit=_SIZE_SHOWN)


def _is_event(e: Any) -> bool:
    if not isinstance(e, Mapping) or set(e) not in ({"t", "name", "set"}, {"t", "name", "add"}):
        return False
    t = e["t"]
    v = e["set"] if "set" in e else e["add"]
    return (_is_number(t) and math.isfinite(as_float(t)) and t >= 0
            and isinstance(e["name"], str) and _is_number(v) and math.isfinite(as_float(v)))


#: keys that were renamed, and their new names: an old case file is told, not guessed at
RENAMED = {
    # a tracking test, not a stability test: the linear loop's stability is the analysis's
    "metrics.stable_tol": "metrics.settled_tol",
}


def unknown_key(key: str, value: Any) -> ConfigError:
    if key in RENAMED:
        return ConfigError(key, value, f"renamed {RENAMED[key]} (the same tolerance)")
    close = difflib.get_close_matches(key, BY_KEY, n=1)
    hint = f"did you mean {close[0]}?" if close else "see `mfcontrol show` for the known keys"
    return ConfigError(key, value, f"unknown key; {hint}")


@dataclass(frozen=True)
class Config(Mapping[str, Any]):
    """A resolved, validated configuration (read-only mapping of dotted keys).

    Made by :func:`resolve`; every option has a value (``None`` for those unset).

    Parameters
    ----------
    values : mapping of str to value
        Every option's resolved value, by dotted key.

    Examples
    --------
    >>> import mfcontrol
    >>> cfg = mfcontrol.resolve({"controller.kp": 5.0})
    >>> cfg["controller.kp"], cfg["plant.model"]
    (5.0, 'buck')
    >>> cfg.with_overrides({"plant.dR": 5.0})["plant.dR"]
    5.0
    """

    # the field shadows Mapping.values() (config.values is this mapping, not a method):
    # renaming it would change the public attribute, so the override is declared. It is a
    # field() so that it is required: dataclass took the inherited Mapping.values as its
    # default (Config() was accepted, and its signature said values=<function ...>)
    values: Mapping[str, Any] = field()  # type: ignore[assignment]

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def __iter__(self):
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def with_overrides(self, overrides: Mapping[str, Any]) -> Config:
        """A new resolved configuration with these keys set (fidelity presets re-applied
        to keys that were never set explicitly)."""
        overrides = dict(overrides)
        for key, value in overrides.items():
            if key not in BY_KEY:
                raise unknown_key(key, value)
        # this configuration's own values were checked when it was resolved: only the
        # new ones are (a sweep resolves one configuration per distinct setting of its
        # keys, each of which checked every key again); the lists are copied, so that no
        # two configurations share one
        merged = {**self.explicit, **overrides}
        return _filled({key: check_value(key, v) if key in overrides
                        else (_copied(v) if isinstance(v, list) else v)
                        for key, v in merged.items() if v is not None})

    @property
    def explicit(self) -> dict[str, Any]:
        return dict(self.values.get("_explicit", {}))

    def public(self) -> dict[str, Any]:
        return {k: v for k, v in self.values.items() if not k.startswith("_")}

    def nested(self, keys: Collection[str] | None = None) -> dict[str, Any]:
        """The options as nested tables (``{"plant": {"R": 10.0, ...}, ...}``), unset ones
        left out; with ``keys``, only those."""
        out: dict[str, Any] = {}
        for key, v in self.public().items():
            if v is None or (keys is not None and key not in keys):
                continue
            *heads, last = key.split(".")
            d = out
            for hkey in heads:
                d = d.setdefault(hkey, {})
            d[last] = v
        return out

    def to_toml(self, keys: Collection[str] | None = None) -> str:
        """The configuration as a case file: every option, or only ``keys`` (what a run
        reads, say: :func:`mfcontrol.api.run.simulate.shown_keys`)."""
        return to_toml(self.nested(keys))


def resolve(settings: Mapping[str, Any]) -> Config:
    """Validate ``settings`` (dotted keys) and fill every other option. A value of None
    unsets the key (its default or fidelity preset applies). ``sensor.noise_std`` given
    without ``sensor.noise`` means gaussian noise. Whether the run reads every key given
    is checked where a case meets a command (:func:`mfcontrol.experiments.cases.check_reads`:
    ``run_case``, the command line), not here: a configuration may switch a law and
    keep the other law's gains.

    Parameters
    ----------
    settings : mapping of str to value
        Options by dotted key (``{"controller.kp": 5.0, "fidelity": "paper"}``), as a
        case file's tables flattened; the user guide's option table lists them.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        An unknown key, or a value its option refuses: one line naming the key, the value
        and what is allowed.

    Examples
    --------
    >>> import mfcontrol
    >>> mfcontrol.resolve({"fidelity": "paper"})["plant.coupling"]
    'textbook'
    >>> mfcontrol.resolve({"plant.L": -1.0})
    Traceback (most recent call last):
    ...
    mfcontrol.errors.ConfigError: plant.L = -1.0: ...
    """
    for key, value in settings.items():
        if key not in BY_KEY:
            raise unknown_key(key, value)
    return _filled({key: check_value(key, v) for key, v in settings.items() if v is not None})


def _copied(checked: list) -> list:
    """A checked list option's value copied: its elements are numbers, texts or events
    (flat dicts of them)."""
    return [dict(e) if isinstance(e, dict) else e for e in checked]


def _filled(explicit: dict[str, Any]) -> Config:
    """The configuration of these checked values (:func:`check_value`), every other
    option filled, and the checks across options run."""
    fidelity = explicit.get("fidelity", BY_KEY["fidelity"].default)
    values: dict[str, Any] = {}
    for o in OPTIONS:
        if o.key in explicit:
            values[o.key] = explicit[o.key]
        elif o.preset:
            values[o.key] = o.preset[fidelity]
        else:
            values[o.key] = o.default
    if "sensor.noise_std" in explicit and "sensor.noise" not in explicit:
        # a noise level given without a kind of noise means what it says: gaussian noise
        # (not a level the sensor would never read)
        values["sensor.noise"] = "gaussian"
    _check_consistency(values)
    values["_explicit"] = explicit
    return Config(values)


def axis_value(key: str, v: float) -> float | int:
    """One value of a swept axis (a float) as the option takes it: a whole number for an
    integer option (else the float, which its check refuses)."""
    if BY_KEY[key].kind == "int" and math.isfinite(v) and float(v).is_integer():
        return int(v)
    return float(v)


def keys_read(translate, cfg: Config, *args: Any) -> set[str]:
    """The keys of ``cfg`` that ``translate(cfg, *args)`` reads: what a translator depends
    on, found by running it (so a list of them is never written beside it)."""
    values = _Reads(cfg.values)
    translate(Config(values), *args)
    return values.read


class _Reads(dict):
    """A configuration that notes which keys are read."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.read: set[str] = set()

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.read.add(key)
        return super().get(key, default)


def check_axis(base: Config, key: str, values: Any) -> None:
    """Validate every value of a swept numeric option against ``base``, as
    ``base.with_overrides({key: v})`` would for each v, at array speed: the option's
    own check on the whole axis, the checks across options once per value only when
    they read the option (with the base and the first value: a check that never reads
    it cannot depend on it)."""
    o = BY_KEY.get(key)
    if o is None:
        raise unknown_key(key, values)
    arr = np.asarray(values, dtype=float)
    if o.kind == "int":  # few values: each through the option's own check
        for v in np.unique(arr):
            check_value(key, axis_value(key, v))
    elif o.kind != "float":
        check_value(key, values)  # raises with the option's message
    ok = _within(o, arr)
    if not ok.all():
        check_value(key, float(arr[np.flatnonzero(~ok)[0]]))  # raises
    if key.startswith("sweep."):
        base.with_overrides({key: float(arr[0])})
        return
    first = _Reads({**base.values, key: axis_value(key, arr[0])})
    _check_consistency(first)
    if key in first.read:
        for v in np.unique(arr):
            _check_consistency({**base.values, key: axis_value(key, v)})


def _check_consistency(v: dict[str, Any]) -> None:
    grid.n_samples(v["sim.t_end"], v["sim.h"], "sim.t_end", "sim.h")
    if v["controller.duty_min"] > v["controller.duty_max"]:
        raise ConfigError("controller.duty_min", v["controller.duty_min"],
                          f"must not exceed controller.duty_max = {v['controller.duty_max']!r}")
    # the converters' load changes (only they have them: another plant reads none of
    # these keys)
    n_changes = len(v["plant.change_times"]) if v["plant.model"] in ("buck", "boost") else 0
    for name, delta in (("R", v["plant.dR"]), ("C", v["plant.dC"])) if n_changes else ():
        lowest = min(v[f"plant.{name}"], v[f"plant.{name}"] + n_changes * delta)
        if lowest <= 0:
            raise ConfigError(f"plant.d{name}", delta,
                              f"must keep plant.{name} > 0 after {n_changes} load changes")
    names = PLANT_PARAMETERS[v["plant.model"]]
    for e in v["plant.schedule"]:
        if e["name"] not in names:
            raise ConfigError("plant.schedule", e, f"name must be a parameter of the "
                              f"{v['plant.model']} plant: {', '.join(names)}" if names else
                              f"must be empty: the {v['plant.model']} plant has no named "
                              "parameter (step a load with [disturbance])")
    if v["plant.model"] == "lti":
        _check_transfer_function(v["plant.num"], v["plant.den"])
    if v["sim.integrator"] == "exact" and v["plant.model"] not in ("lti", "first-order"):
        raise ConfigError("sim.integrator", "exact", "is the zero-order hold of a linear "
                          f"plant (lti, first-order), not of {v['plant.model']}: use rk4 or "
                          "rk45")
    positional = v["controller.law"] in POSITIONAL
    if positional:
        delay = v["controller.delay"]
        problem = intelligent.delay_problem(delay, delay > 0 and v["controller.predict"],
                                            v["controller.order"])
        if problem:
            key, allowed = problem
            raise ConfigError(f"controller.{key}", delay if key == "delay" else True,
                              allowed.format(order="controller.order = "))
    algebraic = v["controller.law"] in POSITIONAL and v["controller.estimator"] == "algebraic"
    if algebraic and v["controller.window"] < 2:
        # one interval fits no line through the window: the estimator needs two
        raise ConfigError("controller.window", v["controller.window"],
                          "must be at least 2 samples for the algebraic estimator")
    if algebraic and estimators.parity_problem(v["controller.order"], v["controller.window"],
                                               v["controller.kernel"]):
        raise ConfigError("controller.window", v["controller.window"],
                          estimators.EVEN_FOR_SIMPSON)
    if positional and v["controller.adapt"] == "rls":
        alpha = v["controller.alpha"]
        lo, hi = variational_gain.rls_limits(alpha, v["controller.alpha_min"],
                                             v["controller.alpha_max"])
        problem = variational_gain.rls_problem(alpha, v["controller.forgetting"], lo, hi)
        if problem:
            key, allowed = problem
            value = {"forgetting": v["controller.forgetting"], "alpha_min": lo,
                     "alpha_max": hi}[key]
            raise ConfigError(f"controller.{key}", value, allowed)
        from ..analysis.alpha import rls_bound_problem

        order = v["controller.order"]
        kernel = v["controller.kernel"] if algebraic or order == 2 else "held"
        # each key read only where the law reads it (a key read here counts as read)
        kd = v["controller.kd"] if v["controller.law"] in ("i-PD", "i-PID") else 0.0
        text = rls_bound_problem(v["controller.kp"], kd, v["sim.h"], order,
                                 v["controller.estimator"],
                                 v["controller.startup"] if algebraic else None, kernel)
        if text:
            raise ConfigError("controller.adapt", "rls", text)
    # (the kernel is read by the algebraic estimator and the order-2 backward difference;
    # elsewhere the reads refuse it as unread)
    # (read only where it is: a key read here counts as read by the run)
    if positional and (algebraic or v["controller.order"] == 2) \
            and v["controller.kernel"] == "delay-reduced":
        if not algebraic:
            raise ConfigError("controller.kernel", "delay-reduced", "weighs the algebraic "
                              "estimator's window: set controller.estimator = algebraic")
        lag = v["controller.lag"]
        kappa, mu = v["controller.kappa"], v["controller.mu"]
        problem = estimators.kernel_problem(v["controller.order"], v["controller.window"],
                                            "delay-reduced", 0.0 if lag is None else lag,
                                            kappa, mu)
        if problem:
            key, allowed = problem
            value = {"kernel": "delay-reduced", "lag": lag, "kappa": kappa, "mu": mu}[key]
            raise ConfigError(f"controller.{key}", value, allowed)
    n = round(v["sim.t_end"] / v["sim.h"])
    if algebraic and v["controller.window"] >= min(n, estimators.MAX_WINDOW + 1):
        # a window the run never fills estimates nothing (and would allocate its ring)
        raise ConfigError("controller.window", v["controller.window"],
                          f"must be fewer samples than the run's {n:,} (sim.t_end / sim.h) "
                          f"and at most {estimators.MAX_WINDOW:,}")
    if v["controller.law"] in ("ip", "variational") and v["plant.model"] not in ("buck",
                                                                                 "boost"):
        raise ConfigError("controller.law", v["controller.law"], "the paper's recursive law "
                          "drives a converter's duty cycle: use i-P .. i-PID or pid for "
                          f"{v['plant.model']}")
    check_elements(v, n)
    if v["controller.law"] == "adrc":
        problem = adrc.problem(v["controller.b0"], v["controller.delay"])
        if problem:
            key, allowed = problem
            raise ConfigError(f"controller.{key}", v[f"controller.{key}"], allowed)
    if v["controller.law"] == "pid":
        _check_pid(v["controller.kp"], v["controller.ki"], v["controller.kd"],
                   v["controller.Tt"], "controller.")
    if (v["sweep.key"] is None) != (v["sweep.values"] is None):
        raise ConfigError("sweep.values", v["sweep.values"],
                          "sweep.key and sweep.values go together")
    if v["sweep.key"] is not None:
        if not v["sweep.values"]:
            raise ConfigError("sweep.values", v["sweep.values"], "must list at least one value")
        o = BY_KEY.get(v["sweep.key"])
        if (o is None or o.kind not in ("float", "int") or o.key.startswith("sweep.")
                or o.key in _GRID_KEYS):
            raise ConfigError("sweep.key", v["sweep.key"], "must name a numeric option that "
                              "keeps the time grid (not sim.h or sim.t_end)")
        for x in v["sweep.values"]:
            x = axis_value(o.key, x)
            check_value(o.key, x)
            _check_consistency({**v, o.key: x, "sweep.key": None, "sweep.values": None})


def _check_transfer_function(num: list[float], den: list[float]) -> None:
    """G(s) = num / den must be strictly proper (a sampled loop measures y_k before it
    computes u_k, so a direct feedthrough would need u_k before it exists) and nonzero."""
    if not den or den[0] == 0:
        raise ConfigError("plant.den", den, "must be a nonempty list of coefficients in "
                          "descending powers of s whose first is nonzero")
    if len(den) < 2:
        raise ConfigError("plant.den", den, "must have degree >= 1 (at least two coefficients)")
    if not any(num):
        raise ConfigError("plant.num", num, "must have a nonzero coefficient")
    first = next(i for i, c in enumerate(num) if c != 0)
    if len(num) - first >= len(den):
        raise ConfigError("plant.num", num, f"must be of lower degree than plant.den = {den} "
                          "(strictly proper: a sampled loop has no direct feedthrough)")


#: integration steps per control period at most (the plant's grid stays within the
#: integers a float counts exactly for any run length the checks allow)
MAX_SUBSTEPS = 100_000


#: delays longer than this many samples are refused (their ring is allocated per thread)
MAX_DELAY = 1_000_000


def check_elements(v: Mapping[str, Any], n: int | None = None) -> None:
    """The checks across the loop elements' options, on whichever of their dotted keys
    ``v`` holds (a configuration, or what an element object sets): the delays and
    integration substeps against the run's n samples (when known), a table's
    times and values. The one place for a case file and the Python objects alike."""
    for key in ("sensor.delay", "actuator.delay"):
        if key not in v:
            continue
        if v[key] > MAX_DELAY:
            raise ConfigError(key, v[key], f"must be a whole number from 0 to {MAX_DELAY:,}")
        if n is not None and v[key] >= n:
            raise ConfigError(key, v[key], f"must be fewer samples than the run's {n:,} "
                              "(sim.t_end / sim.h)")
    if "sim.substeps" in v:
        most = MAX_SUBSTEPS if n is None else min(MAX_SUBSTEPS, grid.MAX_STEPS // n)
        if v["sim.substeps"] > most:
            raise ConfigError("sim.substeps", v["sim.substeps"], f"must be a whole number "
                              f"from 1 to {most:,} (at most {grid.MAX_STEPS:,} plant steps "
                              "in a run)")
    if v.get("disturbance.kind") == "table":
        times, values = v["disturbance.times"], v["disturbance.values"]
        if not times or len(times) != len(values):
            raise ConfigError("disturbance.values", values, "must have one value per time of "
                              f"disturbance.times ({len(times)}), at least one")
        if any(b < a for a, b in zip(times, times[1:], strict=False)):
            raise ConfigError("disturbance.times", times, "must be nondecreasing")


def _check_pid(kp: float, ki: float, kd: float, Tt: float | None, prefix: str = "") -> None:
    """The PID's gains define its time constants: Td = kd / kp needs kp != 0 and, for a
    filter that decays, Td >= 0; the default tracking time needs Ti = kp / ki > 0."""
    if kd != 0.0 and (kp == 0.0 or kd / kp < 0.0):
        raise ConfigError(f"{prefix}kd", kd, f"must have the sign of {prefix}kp (Td = kd / kp "
                          f">= 0; kp = {kp!r})")
    if ki != 0.0 and Tt is None and (kp == 0.0 or kp / ki < 0.0):
        raise ConfigError(f"{prefix}ki", ki, f"must have the sign of {prefix}kp (Ti = kp / ki "
                          f"> 0; kp = {kp!r}), or give {prefix}Tt")


#: options every member of one scenario shares: they set the time grid
_GRID_KEYS = ("sim.h", "sim.t_end")
