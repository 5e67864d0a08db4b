"""The tuner's model, without any web code: a case, the settings changed on top of it, the
run they give, a frozen run to compare against, and the two longer jobs (a robustness
map, a tuning). The page (:mod:`mfcontrol.tuner.page`) only shows what this holds, so all
of it is tested without a browser.

A setting is given as text and read the way ``--set KEY=VALUE`` reads it on the command
line (:func:`mfcontrol.config.toml.parse_assignment`), so a bad entry gets the same
one-line message (the :class:`mfcontrol.errors.ConfigError` text) as the CLI.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..api.model.elements import unread
from ..api.results import metrics
from ..api.results.result import Result
from ..api.run import batch
from ..api.run.simulate import shown_keys, simulate
from ..config.options import BY_KEY, OPTIONS, POSITIONAL
from ..config.resolve import Config, keys_read, resolve
from ..config.toml import parse_assignment, toml_value
from ..errors import ConfigError
from ..experiments import cases
from ..numerics.grid import n_samples

#: the groups of the page, in order, and the key prefixes each holds
GROUPS: dict[str, tuple[str, ...]] = {
    "plant": ("plant.",),
    "controller": ("controller.",),
    "sensor, actuator, disturbance": ("sensor.", "actuator.", "disturbance."),
    "reference": ("reference.",),
    "simulation": ("sim.", "metrics.", "fidelity"),
}

#: choices shown whatever the run reads: they select the model and the law
ALWAYS = ("plant.model", "controller.law", "fidelity")

#: option kinds a field can edit (an event list, plant.schedule, stays in the case file)
_EDITABLE = ("float", "int", "str", "bool", "floats")

#: the keys a sweep case carries; the tuner runs the case once, as a single run
_SWEEP_KEYS = ("sweep.key", "sweep.values", "sweep.grid")

#: the metrics of the page's table, in order (the loop metrics only where defined)
TABLE_METRICS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "stable", "iae_load",
                 "overshoot", "rise_time", "settling_time", "final_gamma")

#: the metrics' short names: one table for the library (api/results/metrics.py)
SHORT = metrics.SHORT

#: metrics a map or a tuning can be asked for
MAP_METRICS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "iae_load", "energy_u",
               "overshoot", "settling_time")


#: samples of one run at most: every change runs on the server's event loop, and a run of
#: 10^7 samples took 3 s and 1.2 GB there, freezing every open page
MAX_SAMPLES = 1_000_000


def _check_size(cfg: Config, key: str) -> None:
    n = n_samples(cfg["sim.t_end"], cfg["sim.h"], "sim.t_end", "sim.h")
    if n > MAX_SAMPLES:
        raise ConfigError(key, cfg[key], f"{n:,} samples: the tuner runs at most "
                          f"{MAX_SAMPLES:,} a change (mfcontrol run takes longer horizons)")


@dataclass(frozen=True)
class Field:
    """One option shown on the page.

    Attributes
    ----------
    key : str
        The dotted option key.
    kind : str
        ``"number"`` (a float), ``"whole"`` (an int), ``"choice"`` (a menu), or
        ``"list"`` (a list of numbers, typed as ``[a, b]``).
    group : str
        Its group (:data:`GROUPS`).
    doc : str
        What it means (the option's documentation).
    choices : tuple of str
        A menu's entries.
    log : bool
        A number edited on a log scale: its value is positive and so is every value
        its check allows, or it is a controller gain.
    """

    key: str
    kind: str
    group: str
    doc: str
    choices: tuple[str, ...] = ()
    log: bool = False

    @property
    def numeric(self) -> bool:
        return self.kind in ("number", "whole")


def group_of(key: str) -> str:
    """The page group of an option key."""
    for name, prefixes in GROUPS.items():
        if any(key.startswith(p) for p in prefixes):
            return name
    return "simulation"


def text_of(value: Any) -> str:
    """A value as a field shows it, and as :meth:`Session.set` reads it back exactly
    (floats by their shortest repr; an unset option as the empty text)."""
    if value is None:
        return ""
    if isinstance(value, bool | list | tuple):
        return toml_value(value)
    if isinstance(value, float):
        return repr(value)
    return str(value)


def log_scale(key: str, value: Any) -> bool:
    """A positive number whose option refuses 0 and below (alpha, L, h) or a controller
    gain: a slider over log10 of it spans decades, as gains are tuned."""
    o = BY_KEY[key]
    if o.kind != "float" or not isinstance(value, float) or not value > 0:
        return False
    return o.check == "positive" or key.startswith("controller.")


def span(key: str, value: Any, factor: float) -> tuple[float, float, bool]:
    """(low, high, log) around an option's value: value / factor .. value * factor on a
    log scale for a positive value, value * factor .. value / factor for a negative one,
    within what the option allows. A whole-number option at 0 spans 0 .. 2 factor; any
    other 0 has no scale, and is refused with a message saying so."""
    o = BY_KEY[key]
    if value is None or isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(key, value, "must be set to a number first (a map and a tuning "
                          "span the value)")
    v = float(value)
    if v > 0:
        low, high, log = v / factor, v * factor, True
        if o.check == "fraction":
            high = min(high, 1.0)
        if o.kind == "int":
            low = max(math.floor(low), 1 if o.check == "positive" else 0)
            high = max(math.ceil(high), low + 1)
            log = low > 0
        return float(low), float(high), log
    if v < 0:
        return v * factor, v / factor, False
    if o.kind == "int":
        return 0.0, float(round(2 * factor)), False
    raise ConfigError(key, value, f"is 0: a map or a tuning spans value/{factor:g} .. "
                      f"value*{factor:g}; type a nonzero value first")


def axis_values(key: str, value: Any, n: int = 9, factor: float = 3.0) -> tuple[np.ndarray,
                                                                                 bool]:
    """n values spanning value / factor .. value * factor (:func:`span`), log-spaced for a
    positive value, the value itself exactly in the middle (n odd), whole numbers for a
    whole-number option (repeats dropped); and whether they are log-spaced."""
    low, high, log = span(key, value, factor)
    if log:
        values = np.logspace(math.log10(low), math.log10(high), n)
    else:
        values = np.linspace(low, high, n)
    if n % 2 and low <= float(value) <= high:
        values[n // 2] = float(value)  # the current setting exactly, not 10**log10(v)
    if BY_KEY[key].kind == "int":
        values = np.unique(np.round(values))
    return values, log


def _first(keys: list[str], preferred: tuple[str, ...]) -> str:
    found = next((k for k in preferred if k in keys), keys[0] if keys else None)
    if found is None:
        raise ConfigError("map", "", "this case shows no option a map can sweep")
    return found


@dataclass
class RobustnessMap:
    """A metric over two options around the current setting.

    Attributes
    ----------
    x, y, metric : str
        The two keys and the metric.
    xs, ys : ndarray
        The values of each axis.
    log_x, log_y : bool
        Whether each axis is log-spaced.
    z : ndarray
        ``z[i_y, i_x]``, the metric of member (xs[i_x], ys[i_y]).
    stable, diverged : ndarray of bool
        The same shape: each member's verdict.
    at : tuple of float
        The current setting (x, y), the map's centre.
    seconds : float
        The time the batch took.
    """

    x: str
    y: str
    metric: str
    xs: np.ndarray
    ys: np.ndarray
    log_x: bool
    log_y: bool
    z: np.ndarray
    stable: np.ndarray
    diverged: np.ndarray
    at: tuple[float, float]
    seconds: float

    @property
    def n_unstable(self) -> int:
        return int((~self.stable).sum())


class Session:
    """A case being tuned: the settings changed on it, their run, a frozen run.

    Parameters
    ----------
    case : str or Path
        A built-in case name or a case file, as ``mfcontrol run`` takes it.
    overrides : mapping, optional
        Dotted keys set on top (as ``--set``); they count as changed.

    Raises
    ------
    CaseError, ConfigError
        An unknown case or file, a bad setting: the CLI's one-line messages.

    Examples
    --------
    >>> from mfcontrol.tuner.session import Session
    >>> s = Session("voltage-stable-standard", {"sim.t_end": 1e-3})
    >>> s.set("controller.kp", "1.5")  # None: accepted
    >>> s.set("controller.alpha", "-1")
    'controller.alpha = -1: must be a finite number > 0'
    >>> s.run().metrics["stable"], s.changed()
    (True, {'sim.t_end': 0.001, 'controller.kp': 1.5})
    """

    def __init__(self, case: str | Path, overrides: Mapping[str, Any] | None = None) -> None:
        self.name, settings = cases.load(case)
        # a sweep or map case is tuned as its single run (the map is the page's own)
        self._settings = {k: v for k, v in settings.items() if k not in _SWEEP_KEYS}
        self.overrides: dict[str, Any] = {}
        self.cfg: Config = resolve({**self._settings, **dict(overrides or {})})
        _check_size(self.cfg, "sim.t_end")
        self.overrides.update(overrides or {})
        self.result: Result | None = None
        self.frozen: Result | None = None
        self.seconds = math.nan  # the last run's time
        self._shown: list[Field] | None = None

    @property
    def description(self) -> str:
        return str(self.cfg["description"])

    # --- settings ---------------------------------------------------------------------

    def value(self, key: str) -> Any:
        """The current value of an option."""
        return self.cfg[key]

    def set(self, key: str, text: str) -> str | None:
        """Set an option from its text as ``--set KEY=TEXT`` reads it (the empty text
        unsets it: its default applies). Returns None when accepted, else the one-line
        message of the CLI, and then nothing changes."""
        try:
            key, value = parse_assignment(f"{key}={text}")
            if text.strip() == "":
                value = None
            self.apply({key: value})
        except ConfigError as exc:
            return str(exc)
        return None

    def apply(self, values: Mapping[str, Any]) -> None:
        """Set several options at once (values as the options take them; None unsets);
        raises ConfigError, and then nothing changes."""
        cfg = self.cfg.with_overrides(dict(values))
        _check_size(cfg, next((k for k in values if k in ("sim.h", "sim.t_end")), "sim.t_end"))
        # a choice, or a number set or unset, can change what the run reads
        if any(BY_KEY[k].kind not in ("float", "int") or BY_KEY[k].choices
               or (self.cfg[k] is None) != (cfg[k] is None) for k in values):
            self._shown = None
        self.cfg = cfg
        self.overrides.update(values)

    def snapshot(self) -> tuple[Config, dict[str, Any], list[Field] | None]:
        """The settings as they are, for :meth:`restore`."""
        return self.cfg, dict(self.overrides), self._shown

    def restore(self, state: tuple[Config, dict[str, Any], list[Field] | None]) -> None:
        """Go back to a :meth:`snapshot` (a setting the run then refused)."""
        self.cfg, overrides, self._shown = state
        self.overrides = dict(overrides)

    def changed(self) -> dict[str, Any]:
        """The options whose value differs from the case's own."""
        own = resolve(self._settings)
        return {k: self.cfg[k] for k in self.overrides if self.cfg[k] != own[k]}

    # --- what the page shows ----------------------------------------------------------

    def fields(self) -> list[Field]:
        """The options shown: those the case's run reads (found by running it,
        :func:`mfcontrol.config.resolve.keys_read`), less those that it reads but that
        change nothing under the other settings (the noise's seed without noise, a
        variational gain's options under a constant gain), plus the model and law
        choices; in the order of the option table."""
        if self._shown is None:
            read = keys_read(simulate, self.cfg) | set(ALWAYS)
            self._shown = [self._field(o.key) for o in OPTIONS
                           if o.key in read and o.kind in _EDITABLE
                           and not self._without_effect(o.key)]
        return self._shown

    def groups(self) -> dict[str, list[Field]]:
        """:meth:`fields` by group, every group of :data:`GROUPS` (perhaps empty)."""
        out: dict[str, list[Field]] = {g: [] for g in GROUPS}
        for f in self.fields():
            out[f.group].append(f)
        return out

    def numeric_keys(self) -> list[str]:
        """Shown numbers that members of a batch may differ in: a map's axes, tuned
        keys (not the time grid nor the settings every member shares)."""
        out = []
        for f in self.fields():
            if not f.numeric:
                continue
            try:
                batch.check_member_key(f.key)
            except ConfigError:
                continue
            out.append(f.key)
        return out

    def map_axes(self) -> tuple[str, str]:
        """The robustness map's default axes: the law's key gain against the plant's
        parameter a load or a process change moves (else the first numbers shown)."""
        keys = self.numeric_keys()
        x = _first(keys, ("controller.alpha", "controller.kp"))
        y = _first([k for k in keys if k != x], ("plant.dR", "plant.J", "plant.a",
                                                  "plant.gain", "plant.R", "controller.kp"))
        return x, y

    def tuned_keys(self) -> list[str]:
        """The tuning's default keys: the law's gains that are shown and not 0 (a gain at
        0 has no decade around it)."""
        keys = self.numeric_keys()
        return [k for k in ("controller.alpha", "controller.kp", "controller.ki",
                            "controller.kd") if k in keys and self.value(k)]

    def _field(self, key: str) -> Field:
        o = BY_KEY[key]
        value = self.cfg[key]
        if o.choices or o.kind in ("str", "bool"):
            choices = o.choices or (("true", "false") if o.kind == "bool" else ())
            return Field(key, "choice", group_of(key), o.doc, tuple(choices))
        kind = {"float": "number", "int": "whole", "floats": "list"}[o.kind]
        return Field(key, kind, group_of(key), o.doc, log=log_scale(key, value))

    def _without_effect(self, key: str) -> bool:
        cfg = self.cfg
        if key in ALWAYS:
            return False
        if unread(key, cfg):
            return True
        if key in ("disturbance.times", "disturbance.values"):
            return cfg["disturbance.kind"] != "table"
        # the law's arrays carry the variational options whatever the gain: they act only
        # when the gain adapts
        if BY_KEY[key].doc.startswith("variational:") and not self.adapts():
            return True
        return key == "controller.k_aw" and cfg["controller.anti_windup"] != "back-calculation"

    def adapts(self) -> bool:
        """Whether the gain adapts (the variational law, or a positional law's
        variational adaptation): the page then plots gamma."""
        c = self.cfg
        return c["controller.law"] == "variational" or (
            c["controller.law"] in POSITIONAL and c["controller.adapt"] == "variational")

    # --- runs -------------------------------------------------------------------------

    def run(self) -> Result:
        """Simulate the current configuration (as ``mfcontrol run`` does) and keep it."""
        t0 = time.perf_counter()
        self.result = simulate(self.cfg, name=self.name)
        self.seconds = time.perf_counter() - t0
        return self.result

    def freeze(self) -> Result:
        """Keep the current run as the reference to compare against (runs it first if
        it has not run)."""
        self.frozen = self.result if self.result is not None else self.run()
        return self.frozen

    def clear(self) -> None:
        """Drop the frozen run."""
        self.frozen = None

    def toml(self) -> str:
        """The current configuration as a case file: ``mfcontrol run`` on it reproduces
        this session's run bit for bit (every option it sets or its run reads, floats by
        their repr: :func:`mfcontrol.api.run.simulate.shown_keys`)."""
        changed = ", ".join(f"{k} = {text_of(v)}" for k, v in self.changed().items())
        head = (f"# {self.name} as set in the mfcontrol tuner (mfcontrol {__version__})\n"
                f"# changed: {changed or 'nothing'}\n")
        return head + self.cfg.to_toml(shown_keys(self.cfg))

    # --- the longer jobs --------------------------------------------------------------

    def robustness_map(self, x: str, y: str, metric: str = "iae", n: int = 9,
                       progress: Callable[[int, int], None] | None = None,
                       factor: float = 3.0) -> RobustnessMap:
        """A metric over two options, each over n values spanning its current value
        / factor .. * factor (:func:`axis_values`), every member run in a batch
        (:func:`mfcontrol.api.run.batch.run_grid`), a row of the map per progress call.

        Raises ConfigError for an option that is not a member key, the same key twice,
        an unknown metric or values the case refuses.
        """
        if x == y:
            raise ConfigError("map", y, f"must differ from the other axis ({x})")
        if metric not in MAP_METRICS:
            raise ConfigError("metric", metric, "must be one of " + ", ".join(MAP_METRICS))
        cfg = self.cfg  # the setting when asked: later changes do not reach the batch
        axes = {}
        logs = []
        for key in (x, y):
            batch.check_member_key(key, "map")
            axes[key], log = axis_values(key, cfg[key], n, factor)
            logs.append(log)
        t0 = time.perf_counter()
        grid = batch.make_grid(cfg, axes)
        cols = batch.run_grid(grid, chunk=max(1, axes[y].size), progress=progress)
        shape = (axes[x].size, axes[y].size)  # C order: y, the last key, varies fastest

        def arranged(col: str) -> np.ndarray:
            return np.asarray(cols[col]).reshape(shape).T

        return RobustnessMap(
            x=x, y=y, metric=metric, xs=axes[x], ys=axes[y], log_x=logs[0], log_y=logs[1],
            z=arranged(metric).astype(float), stable=arranged("stable").astype(bool),
            diverged=arranged("diverged").astype(bool), at=(float(cfg[x]), float(cfg[y])),
            seconds=time.perf_counter() - t0)

    def tune(self, keys: Sequence[str], budget: int = 200,
             progress: Callable[[int, int, float], None] | None = None, *,
             objective: str = "iae", seed: int = 0):
        """Tune ``keys`` by simulation (:func:`mfcontrol.tune`) within current / 10 ..
        current * 10 (:func:`span`; on a log scale for positive values), from the
        current values. Returns the :class:`~mfcontrol.experiments.tune.TuneResult`;
        nothing changes here until its ``best`` is applied (:meth:`apply`)."""
        from ..experiments.tune import tune

        if not keys:
            raise ConfigError("tune", "", "choose at least one option to tune")
        cfg = self.cfg
        bounds, log = {}, []
        for key in keys:
            batch.check_member_key(key, "tune")
            low, high, is_log = span(key, cfg[key], 10.0)
            bounds[key] = (low, high)
            if is_log:
                log.append(key)
        return tune(cfg, bounds, objective=objective, budget=budget, seed=seed, log=log,
                    progress=progress)
