"""The tuner's model, without any web code: a case, the settings changed on top of it (and
the steps back through them), the run they give, frozen runs to compare against, and the
two longer jobs (a robustness map, a tuning). The page (:mod:`mfcontrol.tuner.page`) only
shows what this holds, so all of it is tested without a browser.

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
from ..api.results.plotting import plain_labels, units
from ..api.results.result import Result
from ..api.run import batch
from ..api.run.simulate import keys_read_by_run, shown_keys, simulate
from ..config import options
from ..config.options import BY_KEY, OPTIONS, PLANT_PARAMETERS, gain_adapts
from ..config.resolve import Config, resolve
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

#: option kinds a field can edit (an event list, plant.schedule, as its TOML text)
_EDITABLE = ("float", "int", "str", "bool", "floats", "events")

#: numbers the run reads that are no axis of a map nor a tuned key: a seed picks one noise
#: sequence among equals (a map over it shows chance, not robustness) and an initial
#: state is where the run starts, not a property of the plant or the law
NOT_SPANNED = ("sensor.seed", "plant.i0", "plant.v0", "plant.y0", "controller.u0")

#: a law's gains: what a switch of controller.law loads anew (those the new law reads)
GAINS = ("controller.alpha", "controller.kp", "controller.ki", "controller.kd",
         "controller.gamma0", "controller.Gamma", "controller.eps_M", "controller.k_gamma",
         "controller.b0", "controller.wc", "controller.wo")

#: the output limits, named by the plant's input (a motor's volts, a converter's duty)
LIMITS = {"controller.duty_min": "lower limit", "controller.duty_max": "upper limit"}

#: significant digits of a value the tuner sets itself (a slider's, a tuning's): the
#: entry shows 2.042, not 2.0417379446695296, and the run and the saved case use it
DIGITS = 4

#: frozen runs kept at most (the oldest goes first)
MAX_FROZEN = 3

#: the keys a sweep case carries; the tuner runs the case once, as a single run
_SWEEP_KEYS = ("sweep.key", "sweep.values", "sweep.grid")

#: the metrics of the page's table, in order (the loop metrics only where defined);
#: ``u_at_limit`` is the tuner's own (:func:`control_figures`), beside TV(u)
TABLE_METRICS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "u_at_limit", "settled",
                 "iae_load", "overshoot", "rise_time", "settling_time", "final_gamma",
                 "adaptation_error")

#: the metrics' short names: one table for the library (api/results/metrics.py), and the
#: tuner's figure of the control
SHORT = {**metrics.SHORT, "u_at_limit": "u at a limit"}
#: the tuner's figure in words and its unit, as metrics.LABELS
LABELS = {**metrics.LABELS, "u_at_limit": ("share of the samples with u at an output "
                                           "limit", "%")}

#: metrics a map or a tuning can be asked for
MAP_METRICS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "iae_load", "energy_u",
               "overshoot", "settling_time")


#: the linear loop's margins the page shows (:func:`mfcontrol.analyze`), in order, in words
#: and with their unit ("" for a ratio)
LINEAR_SHOWN = (("spectral_radius", "spectral radius", ""), ("Ms", "Ms, peak |S|", ""),
                ("Mt", "Mt, peak |T|", ""), ("gain_margin", "gain margin", ""),
                ("phase_margin_deg", "phase margin", "deg"),
                ("delay_margin_samples", "delay margin", "samples"),
                ("bandwidth_rad_s", "bandwidth", "rad/s"),
                ("noise_gain_h2", "noise gain (H2)", ""),
                ("steady_state_error", "steady-state error", "per unit step"))

#: analyses kept (the current settings' and the frozen runs')
_ANALYSES_KEPT = 8

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
        ``"list"`` (a list of numbers, typed as ``[a, b]``, or the schedule's events,
        typed as in a case file: ``[{t = 5.0, name = "load", set = 0.05}]``).
    group : str
        Its group (:data:`GROUPS`).
    doc : str
        What it means (the option's documentation).
    choices : tuple of str
        A menu's entries.
    log : bool
        A number edited on a log scale: its value is positive and so is every value
        its check allows, or it is a controller gain.
    label : str
        Its title: the quantity in the plant's words (:meth:`Session.label`).
    """

    key: str
    kind: str
    group: str
    doc: str
    choices: tuple[str, ...] = ()
    log: bool = False
    label: str = ""

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


def _first_line(exc: BaseException) -> str:
    """An exception's message in one line, as the page shows it (its class's name when it
    has none)."""
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _kept(cache: dict[int, tuple[Config, Any]], cfg: Config,
          make: Callable[[Config], Any], size: int) -> Any:
    """``make(cfg)``, kept in ``cache`` by the id of ``cfg`` for the ``size`` settings
    seen last (the oldest dropped first). The Config is kept alive with its value, so that
    no id is reused while cached."""
    hit = cache.get(id(cfg))
    if hit is not None and hit[0] is cfg:
        return hit[1]
    value = make(cfg)
    cache[id(cfg)] = (cfg, value)
    while len(cache) > size:
        del cache[next(iter(cache))]
    return value


class RunRefused(ValueError):
    """The run refused settings the options let through: a law or plant checks what the
    option table cannot (the algebraic estimator's window of at least 2 samples) and
    says so with a ValueError in its own words (``window = 1: must be ...``), or the
    arithmetic failed on them (an OverflowError). The message is its first line; the
    exception raised is the ``__cause__``."""


def refusal(key: str, value: Any, reason: str) -> str:
    """The one line of ``key = value`` refused by its run for ``reason`` (a
    :class:`RunRefused`'s message), in the words of :class:`~mfcontrol.errors.ConfigError`:
    the key, the value, what is allowed.

    A law names its own parameter (``window = 1: must be ...``): that name becomes the
    option's (``controller.window = 1: must be ...``); any other reason follows the
    option (``sim.h = 0.1: the run refuses it: window = 1: must be ...``).
    """
    name = key.rpartition(".")[2]
    if reason.startswith(f"{name} = "):
        return key + reason[len(name):]
    return str(ConfigError(key, value, f"the run refuses it: {reason}"))


def rounded(key: str, value: float) -> float | int:
    """A value the tuner sets itself, to :data:`DIGITS` significant digits (a whole number
    for a whole-number option)."""
    if BY_KEY[key].kind == "int":
        return int(round(value))
    return float(f"{value:.{DIGITS}g}")


def _short(key: str) -> str:
    """A key without its section (alpha, dR): a map's axes in a subtitle."""
    return key.partition(".")[2] or key


def brief(value: Any) -> str:
    """A value in a sentence: a number to :data:`DIGITS` significant digits, anything
    else as a field shows it."""
    if isinstance(value, float):
        return f"{value:.{DIGITS}g}"
    return text_of(value) or "unset"


def log_scale(key: str, value: Any) -> bool:
    """A positive number whose option refuses 0 and below (alpha, L, h) or a controller
    gain: a slider over log10 of it spans decades, as gains are tuned (not an output
    limit: a limit is a level, edited linearly)."""
    o = BY_KEY[key]
    if o.kind != "float" or not isinstance(value, float) or not value > 0:
        return False
    return o.check == "positive" or (key.startswith("controller.") and key not in LIMITS)


def control_figures(r: Result) -> dict[str, float]:
    """What the control u did, beside the output's verdict (a loop can track its
    reference while u chatters from one limit to the other): ``u_at_limit``, the share of
    samples (in %) with u at an output limit; ``step_share``, the mean |u_k - u_{k-1}|
    (TV(u) per sample) in % of the limits' span; ``low``, ``high``, the limits. A
    description of the run, not a verdict: the verdict is the library's ``settled``."""
    cfg = r.config
    assert cfg is not None  # a case's run
    low, high = cfg["controller.duty_min"], cfg["controller.duty_max"]
    u = np.asarray(r.signals["u"], dtype=float)
    n = int(r.metrics.get("n_samples", u.size)) or u.size
    u = u[:n]
    at = np.count_nonzero((u <= low) | (u >= high)) if u.size else 0
    span_ = high - low
    step = (r.metrics["tv_u"] / (u.size - 1) / span_ * 100.0
            if u.size > 1 and span_ > 0 and math.isfinite(span_) else math.nan)
    return {"u_at_limit": 100.0 * at / u.size if u.size else math.nan,
            "step_share": step, "low": low, "high": high}


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
    settled, diverged : ndarray of bool
        The same shape: each member's verdict.
    at : tuple of float
        The setting (x, y) it was drawn around, the map's centre.
    seconds : float
        The time the batch took.
    cfg : Config
        The settings it was drawn under: a later change of any other option the run
        reads makes it stale (:meth:`Session.map_state`).
    """

    x: str
    y: str
    metric: str
    xs: np.ndarray
    ys: np.ndarray
    log_x: bool
    log_y: bool
    z: np.ndarray
    settled: np.ndarray
    diverged: np.ndarray
    at: tuple[float, float]
    seconds: float
    cfg: Config

    @property
    def n_unsettled(self) -> int:
        return int((~self.settled).sum())


@dataclass(frozen=True)
class MapState:
    """How a robustness map stands to the current settings.

    Attributes
    ----------
    kind : str
        ``"current"``, drawn around them; ``"moved"``, only its two axes changed since,
        to a point on the map (the map holds: its members differ from the current
        settings in those two options only); ``"outside"``, the same off the map;
        ``"stale"``, another option the run reads changed (the map is of other settings).
    here : tuple of float or None
        Where the current setting is on the map (None when it is not on it or the map is
        stale).
    differences : dict
        For a stale map, {key: (the map's value, the current one)}.
    title : str
        The map's subtitle: one short line.
    text : str
        What it means in a sentence or two ("" for a current map).
    """

    kind: str
    here: tuple[float, float] | None
    differences: dict[str, tuple]
    title: str
    text: str


class Session:
    """A case being tuned: the settings changed on it (each step can be undone), their run,
    frozen runs.

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
    >>> s.run().metrics["settled"], s.changed()
    (True, {'sim.t_end': 0.001, 'controller.kp': 1.5})
    >>> s.undo()
    'controller.kp = 1.5'
    """

    def __init__(self, case: str | Path, overrides: Mapping[str, Any] | None = None) -> None:
        self.name, settings = cases.load(case)
        # a sweep or map case is tuned as its single run (the map is the page's own)
        self._settings = {k: v for k, v in settings.items() if k not in _SWEEP_KEYS}
        self._own = resolve(self._settings)
        self.overrides: dict[str, Any] = {}
        self.cfg: Config = resolve({**self._settings, **dict(overrides or {})})
        _check_size(self.cfg, "sim.t_end")
        self.overrides.update(overrides or {})
        self.result: Result | None = None
        #: the frozen runs, oldest first (at most :data:`MAX_FROZEN`), and their numbers
        self.frozen: list[Result] = []
        self.frozen_numbers: list[int] = []
        self._freezes = 0
        self.seconds = math.nan  # the last run's time
        self._shown: list[Field] | None = None
        #: what the last accepted :meth:`set` did beyond the value typed, in words (a law
        #: switch's gains, an emptied entry's value), else ""
        self.note = ""
        # the steps back: (the settings before a change, the change in words, its key if
        # a slider's move: the next move of the same slider is the same step)
        self._history: list[tuple[tuple, str, str | None]] = []
        self._reads: dict[int, tuple[Config, frozenset[str]]] = {}
        self._analyses: dict[int, tuple[Config, Any]] = {}  # :func:`_kept`, by settings

    @property
    def description(self) -> str:
        return str(self.cfg["description"])

    # --- settings ---------------------------------------------------------------------

    def value(self, key: str) -> Any:
        """The current value of an option."""
        return self.cfg[key]

    def own(self, key: str) -> Any:
        """The case's own value of an option (its file's, without ``--set``), or None
        where the case does not set it (the option's default or preset applies)."""
        return self._settings.get(key)

    def set(self, key: str, text: str, *, slide: bool = False) -> str | None:
        """Set an option from its text as ``--set KEY=TEXT`` reads it. The empty text
        returns it to the case's own value (:meth:`own`); a new ``controller.law`` brings
        that law's gains (:meth:`law_gains`). Returns None when accepted (:attr:`note`
        then says what else changed), else the one-line message of the CLI, and then
        nothing changes. ``slide``: a slider's move, one undo step with the moves of the
        same slider just before it."""
        try:
            key, value = parse_assignment(f"{key}={text}")
            values = {key: value}
            note = ""
            if text.strip() == "":
                values[key] = own = self.own(key)
                note = (f"{key} back to the case's {text_of(own)}" if own is not None else
                        f"{key} back to the default (the case does not set it): "
                        f"{text_of(self._own[key]) or 'unset'}")
            elif key == "controller.law" and value != self.cfg[key]:
                gains, note = self.law_gains(value)
                values.update(gains)
            before = self.snapshot()
            self.apply(values)
        except ConfigError as exc:
            return str(exc)
        if values[key] is not None:  # the words of the change: the value it got
            what = f"{key} = {text_of(self.cfg[key])}"
        else:
            what = f"{key} unset"
        if any(before[0][k] != self.cfg[k] for k in values):  # else no step to undo
            self._record(before, what, key if slide else None)
        self.note = note
        return None

    def law_gains(self, law: str) -> tuple[dict[str, Any], str]:
        """The gains a switch to ``law`` loads, and what it says of them: the case's own
        where the case is of that law, else the library's defaults, for the gains the
        law's run reads (:data:`GAINS`, :func:`~mfcontrol.api.run.simulate.keys_read_by_run`);
        the others are unset (a saved case carries no gain of the law left). Raises
        ConfigError for a law the settings refuse."""
        case_law = self.own("controller.law") or BY_KEY["controller.law"].default
        from_case = law == case_law
        values = {k: self.own(k) if from_case else None for k in GAINS}
        probe = self.cfg.with_overrides({"controller.law": law, **values})
        read = [k for k in GAINS if k in keys_read_by_run(probe)]
        gains = {k: values[k] if k in read else None for k in GAINS}
        shown = ", ".join(f"{k.removeprefix('controller.')} = {text_of(probe[k])}"
                          for k in read)
        where = ("from the case" if from_case else
                 f"the library's defaults (the case's gains are for {case_law})")
        return gains, f"controller.law = {law}: its gains {shown}, {where}"

    def apply(self, values: Mapping[str, Any]) -> None:
        """Set several options at once (values as the options take them; None unsets);
        raises ConfigError, and then nothing changes. (Not an undo step of its own:
        :meth:`set` and :meth:`apply_tuned` record theirs.)"""
        cfg = self.cfg.with_overrides(dict(values))
        _check_size(cfg, next((k for k in values if k in ("sim.h", "sim.t_end")), "sim.t_end"))
        # a choice, or a number set or unset, can change what the run reads
        if any(BY_KEY[k].kind not in ("float", "int") or BY_KEY[k].choices
               or (self.cfg[k] is None) != (cfg[k] is None) for k in values):
            self._shown = None
        self.cfg = cfg
        self.overrides.update(values)

    def apply_tuned(self, best: Mapping[str, float]) -> dict[str, float | int]:
        """Apply a tuning's best values rounded to :data:`DIGITS` significant digits (what
        the entries show, the run and a saved case use), as one undo step; returns them.
        Raises ConfigError, and then nothing changes."""
        values = {k: rounded(k, v) for k, v in best.items()}
        before = self.snapshot()
        self.apply(values)
        self._record(before, "tuning: " + ", ".join(f"{k} = {text_of(v)}"
                                                    for k, v in values.items()))
        return values

    def snapshot(self) -> tuple:
        """The settings as they are (and the steps back to them), for :meth:`restore`."""
        return self.cfg, dict(self.overrides), self._shown, len(self._history)

    def restore(self, state: tuple) -> None:
        """Go back to a :meth:`snapshot` (a setting the run then refused): the steps
        recorded since are dropped with it."""
        self.cfg, overrides, self._shown, depth = state
        self.overrides = dict(overrides)
        del self._history[depth:]

    def _record(self, before: tuple, what: str, slide: str | None = None) -> None:
        if slide is not None and self._history and self._history[-1][2] == slide:
            # the same slider moved again: one step, back to before its first move
            self._history[-1] = (self._history[-1][0], what, slide)
            return
        self._history.append((before, what, slide))

    def can_undo(self) -> bool:
        return bool(self._history)

    def undo(self) -> str | None:
        """Go back one step: the settings before the last accepted change (a typed value,
        a slider's moves, a law switch with its gains, a tuning's values). Returns the
        change undone in words, None when there is none."""
        if not self._history:
            return None
        state, what, _ = self._history.pop()
        self.cfg, overrides, self._shown, _ = state
        self.overrides = dict(overrides)
        self.note = ""
        return what

    def reads(self, cfg: Config) -> frozenset[str]:
        """The options a run of ``cfg`` reads
        (:func:`~mfcontrol.api.run.simulate.keys_read_by_run`), kept for the settings
        seen last: every redraw asks it of the current settings, each frozen run's and a
        map's (about 0.6 ms a call)."""
        return _kept(self._reads, cfg, lambda c: frozenset(keys_read_by_run(c)), 32)

    def changed(self) -> dict[str, Any]:
        """The options the run reads whose value differs from the case's own (one the
        run does not read, such as another law's gain, changes nothing)."""
        read = self.reads(self.cfg) | set(ALWAYS)
        return {k: self.cfg[k] for k in self.overrides
                if k in read and self.cfg[k] != self._own[k]}

    def differences(self, then: Config, ignore: Sequence[str] = ()) -> dict[str, tuple]:
        """The options read by a run of ``then`` or of the current settings whose values
        differ between them, but ``ignore``: {key: (then's value, the current one)}, in
        the order of the option table."""
        now = self.cfg
        if then is now:
            return {}
        read = (self.reads(then) | self.reads(now)) - set(ignore)
        return {o.key: (then[o.key], now[o.key]) for o in OPTIONS
                if o.key in read and then[o.key] != now[o.key]}

    # --- what the page shows ----------------------------------------------------------

    def fields(self) -> list[Field]:
        """The options shown: those the case's run reads
        (:func:`mfcontrol.api.run.simulate.keys_read_by_run`), less those that it reads
        but that change nothing under the other settings (the noise's seed without noise,
        a variational gain's options under a constant gain), plus the model and law
        choices; in the order of the option table."""
        if self._shown is None:
            read = (self.reads(self.cfg) | set(ALWAYS)) - set(_SWEEP_KEYS)
            self._shown = [self._field(o.key) for o in OPTIONS
                           if o.key in read and o.kind in _EDITABLE
                           and not self._without_effect(o.key)]
        return self._shown

    def label(self, key: str) -> str:
        """An option's quantity in the plant's words, with its unit, for a title: the
        output limits named by the plant's input ("armature voltage u, lower limit (V)" on
        a motor, "duty cycle d, upper limit (1)" on a converter), the output's unit where
        the option table says "output unit", else the figures' label or the key."""
        y_unit, _ = units(self.cfg)
        if key == "plant.schedule":
            return "scheduled changes of the plant (t in s)"
        if key in LIMITS:
            quantity, _, unit = plain_labels(self.cfg)[1].rpartition(" (")
            return f"{quantity}, {LIMITS[key]} ({unit}"
        return options.label(key).replace("$^2$", "\u00b2").replace("output unit", y_unit)

    def events(self) -> list[tuple[float, str]]:
        """The scheduled changes inside the horizon, in time order, as (time in s, what
        in words): the plant's schedule, a converter's load changes, a disturbance's
        start."""
        c, out = self.cfg, []
        for e in c["plant.schedule"]:
            key = f"plant.{e['name']}"
            words = self.label(key).split(" (")[0] if key in BY_KEY else e["name"]
            unit = self.label(key).rpartition(" (")[2].rstrip(")") if key in BY_KEY else ""
            change = (f"set to {e['set']:.4g}" if "set" in e else f"{e['add']:+.4g}")
            out.append((e["t"], f"{words} {change} {unit}".strip()))
        if c["plant.model"] in ("buck", "boost"):
            out += [(t, f"R {c['plant.dR']:+.4g} ohm, C {c['plant.dC']:+.4g} F")
                    for t in c["plant.change_times"]]
        if c["disturbance.kind"] != "none":
            out.append((c["disturbance.t0"], f"{c['disturbance.kind']} disturbance at the "
                                             f"{c['disturbance.at']}"))
        return sorted((t, what) for t, what in out if t < c["sim.t_end"])

    def groups(self) -> dict[str, list[Field]]:
        """:meth:`fields` by group, every group of :data:`GROUPS` (perhaps empty)."""
        out: dict[str, list[Field]] = {g: [] for g in GROUPS}
        for f in self.fields():
            out[f.group].append(f)
        return out

    def numeric_keys(self) -> list[str]:
        """Shown numbers that members of a batch may differ in: a map's axes, tuned
        keys (not the time grid nor the settings every member shares, nor a seed or an
        initial state: :data:`NOT_SPANNED`)."""
        out = []
        for f in self.fields():
            if not f.numeric or f.key in NOT_SPANNED:
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
        label = self.label(key)
        if o.choices or o.kind in ("str", "bool"):
            choices = o.choices or (("true", "false") if o.kind == "bool" else ())
            return Field(key, "choice", group_of(key), o.doc, tuple(choices), label=label)
        kind = {"float": "number", "int": "whole", "floats": "list", "events": "list"}[o.kind]
        return Field(key, kind, group_of(key), o.doc, log=log_scale(key, value), label=label)

    def _without_effect(self, key: str) -> bool:
        cfg = self.cfg
        if key in ALWAYS:
            return False
        if unread(key, cfg):
            return True
        if key == "plant.schedule":  # a plant without named parameters has no schedule
            return not PLANT_PARAMETERS[cfg["plant.model"]]
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
        return gain_adapts(self.cfg)

    # --- runs -------------------------------------------------------------------------

    def run(self) -> Result:
        """Simulate the current configuration (as ``mfcontrol run`` does) and keep it.

        Raises
        ------
        ConfigError
            The settings refused by their own check.
        RunRefused
            The settings refused by the law or the plant they build (then the run kept
            is the one before).
        """
        t0 = time.perf_counter()
        try:
            self.result = simulate(self.cfg, name=self.name)
        except ConfigError:
            raise  # the settings' own check: it names the option already
        except (ValueError, ArithmeticError) as exc:
            # how the laws and plants refuse a value their option allows: shown on the
            # page as a refusal; any other exception is taken for a fault of the code
            # and keeps its traceback
            raise RunRefused(_first_line(exc)) from exc
        self.seconds = time.perf_counter() - t0
        return self.result

    def analysis(self, cfg: Config | None = None) -> Any:
        """The linear analysis of the current settings' loop, or of ``cfg`` (a frozen run's
        ``config``): what :func:`mfcontrol.analyze` gives, a
        :class:`~mfcontrol.experiments.analyze.Analysis`; or, where the loop has none
        (a gain given from outside, a plant without a steady state), the reason in one
        line. Kept for the last few settings: a frozen run is not analysed again."""
        from ..experiments.analyze import analyze

        def analysed(cfg: Config) -> Any:
            try:
                return analyze(cfg)
            except (ValueError, ArithmeticError) as exc:  # ConfigError, LinAlgError too
                return _first_line(exc)

        return _kept(self._analyses, self.cfg if cfg is None else cfg, analysed,
                     _ANALYSES_KEPT)

    def freeze(self) -> Result:
        """Keep the current run to compare against (runs it first if it has not run), as
        the newest of the frozen runs: the oldest goes beyond :data:`MAX_FROZEN`."""
        run = self.result if self.result is not None else self.run()
        self._freezes += 1
        self.frozen.append(run)
        self.frozen_numbers.append(self._freezes)
        del self.frozen[:-MAX_FROZEN], self.frozen_numbers[:-MAX_FROZEN]
        return run

    def clear(self) -> None:
        """Drop the frozen runs."""
        self.frozen.clear()
        self.frozen_numbers.clear()

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
            z=arranged(metric).astype(float), settled=arranged("settled").astype(bool),
            diverged=arranged("diverged").astype(bool), at=(float(cfg[x]), float(cfg[y])),
            seconds=time.perf_counter() - t0, cfg=cfg)

    def map_state(self, m: RobustnessMap) -> MapState:
        """How a map stands to the current settings (:class:`MapState`)."""
        stale = self.differences(m.cfg, ignore=(m.x, m.y))
        x, y = self.cfg[m.x], self.cfg[m.y]
        runs = f"{m.z.size} runs"
        around = (f"around {_short(m.x)} = {brief(m.at[0])}, {_short(m.y)} = "
                  f"{brief(m.at[1])} (+)")
        if stale:
            then = ", ".join(f"{k} = {brief(a)} (now {brief(b)})" for k, (a, b) in stale.items())
            return MapState("stale", None, stale, f"Stale: {runs} {around}, under settings "
                            "changed since", f"The map is stale: drawn with {then}. Press "
                            "the map's button to draw it around the current setting.")
        if (x, y) == m.at:
            return MapState("current", m.at, {}, f"{runs} around the current setting "
                            "(marked)", "")
        here = (x, y) if x is not None and y is not None else None
        inside = here is not None and all(
            min(v[0], v[-1]) <= float(c) <= max(v[0], v[-1])
            for v, c in ((m.xs, x), (m.ys, y)))
        now = f"{m.x} = {brief(x)}, {m.y} = {brief(y)}"
        if inside:
            return MapState("moved", here, {}, f"{runs} {around}; the current setting "
                            "marked", f"The current setting ({now}) differs from the map's "
                            "centre in its two axes only: the map holds, the marker moved.")
        return MapState("outside", None, {}, f"{runs} {around}; the current setting is off "
                        "the map", f"The current setting ({now}) is off the map. Press the "
                        "map's button to draw it around the current setting.")

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
