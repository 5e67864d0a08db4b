"""A closed loop of any plant object and any controller: compiled, or in Python.

The plant is a :class:`mfcontrol.api.model.plants.Plant` (converters, a first-order plant, an
LTI model, python-control systems, your own ODE), the controller one of
:mod:`mfcontrol.api.model.controllers`. Each sample: scheduled parameter changes due at t_k, the
measurement ``y_k`` (before the plant step), ``u_k`` from the law, the plant advanced
over [t_k, t_k + h] with ``u_k`` held.

Whenever the plant compiles (every built-in plant, and an ODE whose f and g numba can
compile) and the controller is one of the library's, the loop runs in the compiled engine
(:mod:`mfcontrol.engine.compose`), running the same law functions as the live controller:
bit for bit its outputs. Otherwise (a :class:`Plant` subclass written in Python, a
controller of your own, an f numba cannot compile) it runs through the
Python driver, one call per sample, and the result's ``engine`` says ``"python"``.
"""

from __future__ import annotations

import functools
import inspect
import math
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...config.resolve import check_elements, check_value
from ...elements import disturbance as disturbance_law
from ...elements import layout
from ...engine import compose, trajectory
from ...engine import metrics as engine_metrics
from ...errors import ConfigError
from ...laws import adrc, intelligent, pid, reference, variational_gain
from ...laws import reference as reference_law
from ...numerics import grid
from ..model.controllers import ADRC, PID, IntelligentController, RecursiveIP, _Controller
from ..model.elements import Actuator, Disturbance, Sensor, column
from ..model.plants import LTI
from ..model.schedule import Change, _check_changes, restored
from ..results import metrics as _metrics
from ..results.result import SIGNALS, Result

Reference = float | Callable[[float], float] | Sequence[float] | np.ndarray


#: the result of :func:`simulate_loop`: :class:`mfcontrol.Result`, the one result type
LoopResult = Result


def _series(name: str, value: Reference, t: np.ndarray, positive: bool = False) -> np.ndarray:
    """``value`` at every sample time (a number, a function of t or one value per sample),
    checked: finite (and, with ``positive``, > 0 with a finite reciprocal) at every
    sample. Errors name ``name``, the first bad value and its time."""
    allowed = "a number, a function of t or one value per sample"
    try:
        if callable(value):
            arr = np.array([float(value(tk)) for tk in t])
        else:
            if isinstance(value, bool | str | bytes):
                raise TypeError
            arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        shown = value if isinstance(value, bool | str | bytes) else type(value).__name__
        raise ConfigError(name, shown, allowed) from None
    if arr.ndim == 0:  # one value for every sample: checked once, on a float
        v = float(arr)
        arr = np.full(t.size, v)
        if math.isfinite(v) and (not positive or v > 0 and math.isfinite(1.0 / v)):
            return arr
        ok = np.zeros(t.size, dtype=bool)  # bad at every sample: told at the first
    elif arr.shape != t.shape:
        raise ConfigError(name, f"an array of shape {arr.shape}",
                          f"{allowed} ({t.size} samples)")
    else:
        with np.errstate(divide="ignore", over="ignore"):
            ok = np.isfinite(arr) & ((arr > 0) & np.isfinite(1.0 / arr) if positive else True)
    if not ok.all():
        k = int(np.flatnonzero(~ok)[0])
        what = "finite and > 0 (with a finite 1/value)" if positive else "finite"
        raise ConfigError(name, float(arr[k]), f"must be {what} at every sample "
                                               f"(t = {float(t[k])!r})")
    return arr


def _as_plant(plant):
    if type(plant).__module__.startswith("control."):  # a python-control system
        return LTI.from_control(plant)
    return plant


# ---------------------------------------------------------------------------------------------
# the controller as the engine runs it


@dataclass
class LawArrays:
    """A controller's law as engine columns: its parameters, its present memory, and which
    memory rows and trajectory rows become named signals."""

    kind: int
    CP: np.ndarray
    CS: np.ndarray
    dt: float
    components: tuple[str, ...]  # CS rows recorded per sample, by signal name
    rows: tuple[int, ...]


#: a reference step (t0, from, to) as the step metrics measure it: the same for every
#: member, or each of the three an array over the members
ReferenceStep = tuple[float, float, float] | tuple[np.ndarray, ...]


#: each law's recorded components: (signal names, CS rows)
_COMPONENTS = {law: (tuple(name for name, _ in law.COMPONENTS),
                     tuple(row for _, row in law.COMPONENTS)) for law in (pid, intelligent, adrc)}


def law_arrays(controller) -> LawArrays | None:
    """The engine's view of ``controller``; None when only the Python driver can run it
    (not a library controller, in manual mode, or with ``input_limits``: the engine's laws
    take every sample, so the live controller's rejections run in Python)."""
    if (not getattr(controller, "auto_mode", False)
            or getattr(controller, "input_limits", (None, None)) != (None, None)):
        return None
    if isinstance(controller, PID):
        return LawArrays(compose.PID, controller._CP.copy(), controller._CS.copy(),
                         controller.sample_time, *_COMPONENTS[pid])
    if isinstance(controller, ADRC):
        return LawArrays(compose.ADRC, controller._CP.copy(), controller._CS.copy(),
                         controller.sample_time, *_COMPONENTS[adrc])
    if isinstance(controller, IntelligentController):
        return LawArrays(compose.INTELLIGENT, controller._CP.copy(), controller._CS.copy(),
                         controller.sample_time, *_COMPONENTS[intelligent])
    if isinstance(controller, RecursiveIP):
        return LawArrays(compose.RECURSIVE_IP, controller._CP.copy(), controller._CS.copy(),
                         1.0, (), ())
    return None


def _hand_back(controller, CS: np.ndarray, traj: np.ndarray, k_end: int) -> None:
    """Leave the controller as the Python driver would: its memory and last output."""
    if k_end == 0:
        return
    controller._CS[:, 0] = CS[:, 0]
    last = traj[:, k_end - 1].tolist()
    controller._last_output = last[trajectory.T_APPLIED]
    # the reference was checked finite before the run: no setter's check again
    controller._setpoint = last[trajectory.T_REF]
    if isinstance(controller, RecursiveIP):
        controller._components = tuple(last[row] for row in (
            trajectory.T_U, trajectory.T_GAIN, trajectory.T_GAMMA))


def _settings(settle_time: float, t_end: float, final_window: float,
              diverge_above: float, settled_tol: float = 0.1) -> np.ndarray:
    """The kernels' metric settings, each checked as its option is (one-line errors)."""
    values = (settle_time, final_window, settled_tol, diverge_above)
    if all(type(v) is float or type(v) is int for v in values):
        _check_settings(*values)  # numbers seen before are not checked again
    else:
        _check_settings.__wrapped__(*values)  # numpy's (unhashable ones, too): each time
    return engine_metrics.settings(settle_time, t_end, final_window, diverge_above)


@functools.lru_cache(maxsize=256)
def _check_settings(settle_time, final_window, settled_tol, diverge_above) -> None:
    """Each metric setting checked as its option is; what passed is remembered (a failure
    raises, and is not)."""
    for name, key, value in (("settle_time", "metrics.settle_time", settle_time),
                             ("final_window", "metrics.final_window", final_window),
                             ("settled_tol", "metrics.settled_tol", settled_tol),
                             ("diverge_above", "sim.diverge_above", diverge_above)):
        try:
            check_value(key, value)
        except ConfigError as exc:
            raise ConfigError(name, value, exc.allowed) from None


def _event_arrays(changes_per_member: Sequence[Sequence[Change]], columns: Mapping[str, int],
                  t_end: float, n: int):
    """(ev_k, ev_col, ev_add, ev_val) for members that share the list of changed names.
    A list that several members hold (a sweep's one schedule) is read once."""
    first = list(changes_per_member[0])
    names = [(c.name, c.add) for c in first]
    if not first:  # no member changes anything (most runs): nothing to read
        if any(changes_per_member):
            raise ValueError("members of one run must change the same parameters in order")
        m = len(changes_per_member)
        return (np.zeros((0, m), dtype=np.int64), np.zeros(0, dtype=np.int64),
                np.zeros(0, dtype=np.bool_), np.zeros((0, m)))
    lists, at = distinct(changes_per_member)  # each list read once, then spread
    ev_k = np.zeros((len(first), len(lists)), dtype=np.int64)
    ev_val = np.zeros((len(first), len(lists)))
    for j, changes in enumerate(lists):
        if j and [(c.name, c.add) for c in changes] != names:
            raise ValueError("members of one run must change the same parameters in order")
        for e, c in enumerate(changes):
            ev_k[e, j] = grid.first_sample_at(c.time, t_end, n)
            ev_val[e, j] = c.value
    ev_k, ev_val = np.take(ev_k, at, axis=1), np.take(ev_val, at, axis=1)
    ev_col = np.array([columns[name] for name, _ in names], dtype=np.int64)
    ev_add = np.array([add for _, add in names], dtype=np.bool_)
    return ev_k, ev_col, ev_add, ev_val


def distinct(items: Iterable[Any]) -> tuple[list[Any], np.ndarray]:
    """The distinct objects of ``items`` (by identity, in the order of their first
    appearance) and where each item is among them: ``items[j] is objs[at[j]]``.

    Examples
    --------
    >>> a, b = [1.0], [2.0]
    >>> objs, at = distinct([a, b, a, a])
    >>> objs == [a, b], at.tolist()
    (True, [0, 1, 0, 0])
    """
    first: dict[int, int] = {}
    objs: list[Any] = []  # holds each object seen, so that no id is reused meanwhile
    at = []
    for item in items:
        i = first.get(id(item))
        if i is None:
            i = first[id(item)] = len(objs)
            objs.append(item)
        at.append(i)
    return objs, np.array(at, dtype=np.int64)


def stacked(columns: Sequence[np.ndarray],
            stack: Callable[[list[np.ndarray]], np.ndarray] = np.hstack) -> np.ndarray:
    """``stack(columns)`` (members' columns side by side), each distinct column object
    stacked once (:func:`distinct`) and then taken for every member that holds it: a
    sweep's members hold a few columns many times."""
    objs, at = distinct(columns)
    return np.take(stack(objs), at, axis=1)


def run_members(plants: Sequence[Any], laws: Sequence[LawArrays], R: np.ndarray,
                changes_per_member: Sequence[Sequence[Change]], *, t_end: float, h: float,
                S: np.ndarray, fast: bool = False, record: bool = False,
                RP: np.ndarray | None = None, AL: np.ndarray | None = None,
                LP: np.ndarray | None = None, step: ReferenceStep | None = None,
                vectorise: bool | None = None, t_end_key: str = "t_end"):
    """Members (engine plants and law arrays of one family) through the compiled engine.

    The reference is ``R[j]`` (``R[0]`` for all when R has one row) or, when R has no
    rows, the configured reference of each member, ``RP[:, j]`` (see
    :mod:`mfcontrol.laws.reference`). ``AL`` (one row, or one per member): the alpha of
    an external gain at every sample. ``LP`` (one column, or one per member): the loop's
    elements (:func:`mfcontrol.api.model.elements.column`; default none). ``step``: the
    reference step (t0, from, to) the step metrics measure, for a reference given as R
    (from RP, a smooth-step is one). ``vectorise``: run the members in the engine's
    vectorised loop (True, False, or None: when it pays,
    :func:`mfcontrol.engine.compose.loop_for`).

    Returns (M, traj, CS, DT): metrics of every member; with ``record`` (one member) its
    trajectory ``traj[row, k]``, else an empty array; the law memory of every member; the
    adaptive integrator's last step size of every member (negative: it collapsed there,
    :func:`mfcontrol.numerics.dopri45.integrate`; 0 for the other integrators).
    """
    n = grid.n_samples(t_end, h)
    m = len(plants)
    if len(laws) != m:
        raise ValueError(f"{m} plants and {len(laws)} laws: one of each per member")
    # a sweep's members hold a few objects many times (an n x m grid of a plant key and
    # a law key: n plants and m laws, each in many members): each is checked and
    # stacked once, then spread to its members
    plants, at_plant = distinct(plants)
    laws, at_law = distinct(laws)
    p0, l0 = plants[0], laws[0]
    for ep in plants:
        if ep.functions != p0.functions or ep.integrator != p0.integrator or \
                ep.p.size != p0.p.size or ep.x0.size != p0.x0.size:
            raise ValueError("members of one run must share the plant model and integrator")
    for law in laws:
        if law.kind != l0.kind or law.CP.shape != l0.CP.shape or law.dt != l0.dt:
            raise ValueError("members of one run must share the law and its sample time")
    # fresh arrays (the engine writes X, P and CS in place), C-ordered
    if m == 1:  # a single run: copies, without the stacking's per-call costs
        X, P = p0.x0.reshape(1, -1).copy(), p0.p.reshape(1, -1).copy()
        CP, CS = l0.CP.copy(), l0.CS.copy()
    else:
        X = np.array([ep.x0 for ep in plants])[at_plant]
        P = np.array([ep.p for ep in plants])[at_plant]
        CP = np.take(np.concatenate([law.CP for law in laws], axis=1), at_law, axis=1)
        CS = np.zeros((max(law.CS.shape[0] for law in laws), len(laws)))
        for j, law in enumerate(laws):
            CS[:law.CS.shape[0], j] = law.CS[:, 0]
        CS = np.take(CS, at_law, axis=1)
    events = _event_arrays(changes_per_member, p0.columns, t_end, n)
    RP = np.zeros((reference.N_PARAMS, m)) if RP is None else np.ascontiguousarray(RP)
    LP = layout.column() if LP is None else LP
    LP = np.ascontiguousarray(LP if LP.shape[1] == m else np.repeat(LP, m, axis=1))
    M = np.zeros((engine_metrics.N_METRICS, m))
    engine_metrics.start(M, *step_metrics_of(RP, step),
                         load_step_of(LP, changes_per_member, t_end, n))
    comp_rows = np.array(l0.rows, dtype=np.int64)
    if record:
        grid.check_recording(n, compose.T_COMP + comp_rows.size + X.shape[1], t_end,
                             t_end_key)
    traj = np.full((compose.T_COMP + comp_rows.size + X.shape[1], n if record else 0), np.nan)
    tol = np.array(p0.tol, dtype=np.float64)
    DT = np.zeros(m)  # <= 0: the adaptive integrator starts each member with a step of h
    has_gain = l0.kind not in (compose.PID, compose.ADRC)  # a law on the gain's rows
    adapt0 = CS[variational_gain.ADAPT].copy() if has_gain else None
    compose.run(l0.kind, compose.INTEGRATORS[p0.integrator], p0.functions, n, h, t_end,
                l0.dt, X, P, CP, CS, np.ascontiguousarray(R, dtype=np.float64),
                RP, np.zeros((0, n)) if AL is None else np.ascontiguousarray(AL, dtype=np.float64),
                LP, events, S, M, tol,
                DT, traj, comp_rows, fast=fast, block=p0.block, vectorise=vectorise,
                member=p0.member)
    if has_gain:  # the adaptation error of this run, from the law's state (as it stopped)
        M[engine_metrics.M_ADAPT] = CS[variational_gain.ADAPT] - adapt0
    engine_metrics.adaptation(M, CP, has_gain)
    return M, traj, CS, DT


def step_metrics_of(RP: np.ndarray, step: ReferenceStep | None = None
                    ) -> tuple[np.ndarray | float, np.ndarray | float, np.ndarray | float]:
    """(t0, from, to) of every member's reference step, as the step metrics take them:
    a smooth-step reference's, else ``step`` (the same for all), else none (to = NaN).
    One member (a single run): three floats, without numpy's per-call cost."""
    t0, y0, y1 = step if step is not None else (0.0, math.nan, math.nan)
    if RP.shape[1] == 1:
        col = RP[:, 0].tolist()
        if col[reference.KIND] == reference.SMOOTH_STEP:
            return col[reference.T0], col[reference.INITIAL], col[reference.FINAL]
        return t0, y0, y1
    smooth = RP[reference.KIND] == reference.SMOOTH_STEP
    return (np.where(smooth, RP[reference.T0], t0), np.where(smooth, RP[reference.INITIAL], y0),
            np.where(smooth, RP[reference.FINAL], y1))


def load_step_of(LP: np.ndarray, changes_per_member, t_end: float, n: int) -> np.ndarray:
    """Every member's first load step, from which ``iae_load`` counts: a step
    disturbance's t0 or its first scheduled plant change, whichever comes first, if a
    sample of the n over t_end sees it (inf for neither)."""
    d = LP[layout.DISTURBANCE:]
    kinds = d[disturbance_law.KIND].tolist()
    starts = d[disturbance_law.T0].tolist()
    m = max(len(kinds), len(changes_per_member))  # one column or one list: for every member
    if len(kinds) == 1:
        kinds, starts = kinds * m, starts * m
    if len(changes_per_member) == 1:
        changes_per_member = list(changes_per_member) * m
    load = []
    # on Python floats: a loop over the members either way (their changes are objects),
    # each setting worked out once (a sweep's members mostly share theirs)
    known: dict[tuple[float, float, int], float] = {}
    for kind, t0, changes in zip(kinds, starts, changes_per_member, strict=True):
        key = (kind, t0, id(changes))
        at = known.get(key)
        if at is None:
            first = min(t0 if kind == disturbance_law.STEP else math.inf,
                        min((c.time for c in changes), default=math.inf))
            seen = math.isfinite(first) and grid.first_sample_at(first, t_end, n) < n
            at = known[key] = first if seen else math.inf
        load.append(at)
    return np.array(load)


def _setup(plant, controller, reference, t_end, h, changes, settle_time, final_window,
           settled_tol, diverge_above):
    """What a run of objects starts from, checked: (plant, h, t, r, S)."""
    plant = _as_plant(plant)
    if h is None:
        h = getattr(controller, "sample_time", None)
        if h is None:
            raise ConfigError("h", None, f"required: the {type(controller).__name__} has no "
                              f"sample_time to default to")
    h = float(h)
    n = grid.n_samples(t_end, h)
    _check_changes(plant, changes)
    t = grid.times(n, t_end)
    S = _settings(settle_time, t_end, final_window, diverge_above, settled_tol)
    return plant, h, t, _series("reference", reference, t), S


def _alpha(controller, alpha, t: np.ndarray) -> np.ndarray | None:
    """The alpha of every sample for a controller that is given one (None for any other
    controller), checked: finite and > 0 everywhere. A library controller takes it when
    its gain is external; a controller of your own when it has an ``alpha`` parameter."""
    external = getattr(controller, "_external", False)
    if alpha is None:
        if external:
            raise ConfigError("alpha", None, "gain='external' needs alpha: a number, a "
                              "function of t or one value per sample")
        return None
    if not isinstance(controller, _Controller):  # yours
        if not _takes_alpha(controller):
            raise ConfigError("alpha", alpha, "your controller must take it: "
                              "u = controller(y, setpoint=r, alpha=a)")
        return _series("alpha", alpha, t, positive=True)
    if not external:
        raise ConfigError("alpha", alpha, "only for a controller with gain='external' "
                          "(the others set their own gain)")
    return _series("alpha", alpha, t, positive=True)


def _takes_alpha(controller) -> bool:
    """Whether ``controller(y, setpoint=r, alpha=a)`` binds (an ``alpha`` parameter or
    ``**kwargs``); True when its signature cannot be read (a call will tell)."""
    try:
        signature = inspect.signature(controller)
    except (TypeError, ValueError):
        return True
    try:
        signature.bind(0.0, setpoint=0.0, alpha=1.0)
    except TypeError:
        return False
    return True


# ---------------------------------------------------------------------------------------------
# one run


def warn_alpha(controller: Any, plant: Any) -> None:
    """A RuntimeWarning when an intelligent controller's alpha breaks the
    backward-difference bound on the plant (:func:`mfcontrol.analysis.alpha.alpha_warning`):
    the run goes ahead, and is likely to diverge within a few samples."""
    from ...analysis.alpha import alpha_warning

    message = alpha_warning(controller, plant)
    if message is not None:
        warnings.warn(message, RuntimeWarning, stacklevel=3)


def simulate_loop(plant, controller, reference: Reference = 0.0, *, t_end: float,
                  h: float | None = None, changes: Sequence[Change] = (),
                  settle_time: float = 0.0, final_window: float = 0.2,
                  settled_tol: float = 0.1, diverge_above: float = 1e12,
                  name: str = "", fast: bool = False, alpha: Reference | None = None,
                  sensor=None, actuator=None, disturbance=None, substeps: int = 1) -> Result:
    """Simulate ``controller`` on ``plant`` tracking ``reference`` for ``t_end`` seconds.

    Parameters
    ----------
    plant : Plant or control.LTI
        Any :class:`mfcontrol.api.model.plants.Plant`, or a continuous-time python-control
        ``StateSpace`` / ``TransferFunction`` (converted with ``LTI.from_control``).
    controller : callable
        A live controller (``u = controller(y, setpoint=r)``), e.g. :class:`mfcontrol.IP`.
        The run continues from its present memory and leaves it as a loop of calls would.
        A controller of your own may have ``components`` (a dict of floats, recorded as
        signals every sample) and ``adaptation_error`` (a float, its gain adaptation's
        error so far: the metric is its change over the run; NaN without it).
    reference : float, callable or array
        Constant, a function of t, or one value per sample.
    t_end, h : float
        Horizon and sample period; ``h`` defaults to the controller's ``sample_time``.
    changes : sequence of Change
        Scheduled plant parameter changes.
    settle_time, final_window, settled_tol, diverge_above : float
        Metric settings, as the ``metrics.*`` and ``sim.diverge_above`` options.
    fast : bool
        The compiled engine's fast mode (fused multiply-adds, reciprocals): within about
        1e-12 relative of the default. Refused for a loop the Python driver runs.
    alpha : float, callable or array, optional
        The alpha given at every sample, as a loop of live calls passes ``alpha=``:
        constant, a function of t, or one value per sample, each finite and > 0. For a
        library controller with ``gain="external"`` (the others set their own gain), or a
        controller of your own that takes it (``controller(y, setpoint=r, alpha=a)``).
    sensor, actuator, disturbance : Sensor, Actuator, Disturbance, optional
        The loop's elements (:mod:`mfcontrol.api.model.elements`): what the controller
        receives of y (noise, quantisation, delay), what reaches the plant of u (delay,
        rate limit) and a disturbance on the plant's input or output. The compiled
        engine runs them; ``y_meas`` and ``u_plant`` record what they made of y and u.
    substeps : int
        Plant integration steps of h / substeps per sample, the input held (the
        controller still runs every h).

    Returns
    -------
    Result
        ``engine`` says whether the compiled engine or the Python driver ran it. On a
        constant reference, the step metrics (overshoot, rise and settling time) take
        the run as a step from the plant's initial output to it at t = 0.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol import FirstOrder
    >>> ctrl = mfcontrol.IP(alpha=1.0, kp=20.0, sample_time=1e-3)
    >>> res = mfcontrol.simulate_loop(FirstOrder(a=-1.0, b=1.0), ctrl, 1.0, t_end=0.5)
    >>> bool(res.metrics["settled"]), round(float(res.signals["y"][-1]), 4), res.engine
    (True, 1.0, 'compiled')
    """
    plant, h, t, r, S = _setup(plant, controller, reference, t_end, h, changes, settle_time,
                               final_window, settled_tol, diverge_above)
    al = _alpha(controller, alpha, t)
    LP = _elements(sensor, actuator, disturbance, substeps, n=t.size)
    step = _constant_step(plant, reference)
    ep = plant.engine() if hasattr(plant, "engine") else None
    law = law_arrays(controller)
    warn_alpha(controller, plant)
    if ep is None or law is None:
        note = _python_reason(plant, ep, controller)
        if fast:
            raise ConfigError("fast", True, f"only the compiled engine has a fast mode; this "
                              f"loop runs in Python ({note})")
        acting = {k: v for k, v in (("sensor", sensor), ("actuator", actuator),
                                     ("disturbance", disturbance), ("substeps", substeps))
                  if not layout.plain(_elements(**{k: v}, n=t.size))}
        if acting:
            key, value = next(iter(acting.items()))
            raise ConfigError(key, value, "only the compiled engine runs the loop's "
                              f"elements and substeps; this loop runs in Python ({note})")
        return _python_driver(plant, controller, r, t, changes, h, t_end, S, settled_tol,
                              name, note, al, step)
    return compiled_run(plant, ep, controller, law, r[None, :], None, changes, t, h, t_end, S,
                        settled_tol, name, fast, None if al is None else al[None, :], LP, step)


def _elements(sensor=None, actuator=None, disturbance=None, substeps=1, *,
              n: int) -> np.ndarray:
    """The elements' LP column, checked: the objects' types, and their options against the
    run's n samples as a case file's (:func:`mfcontrol.config.resolve.check_elements`)."""
    if sensor is None and actuator is None and disturbance is None \
            and type(substeps) is int and substeps == 1:
        # none given (most runs): nothing to check, and the ideal loop's column is the same
        # every time (a copy: the engine's arrays are the run's own)
        return _ideal_loop().copy()
    for name, obj, kind in (("sensor", sensor, Sensor), ("actuator", actuator, Actuator),
                            ("disturbance", disturbance, Disturbance)):
        if obj is not None and not isinstance(obj, kind):
            raise ConfigError(name, type(obj).__name__, f"must be a mfcontrol.{kind.__name__}")
    try:
        substeps = check_value("sim.substeps", substeps)
        check_elements({"sim.substeps": substeps,
                        **({"sensor.delay": sensor.delay} if sensor else {}),
                        **({"actuator.delay": actuator.delay} if actuator else {})}, n)
    except ConfigError as exc:
        raise ConfigError(exc.key.replace("sim.", ""), exc.value, exc.allowed) from None
    return column(sensor, actuator, disturbance, substeps)


@functools.cache
def _ideal_loop() -> np.ndarray:
    """The LP column of a loop without elements (no sensor, actuator or disturbance, one
    integration step per sample)."""
    return column()


def _constant_step(plant, reference) -> tuple[float, float, float] | None:
    """A constant reference as the step the step metrics measure: from the plant's
    initial output to it at t = 0 (None for any other reference)."""
    if isinstance(reference, int | float | np.number) and not isinstance(reference, bool):
        return 0.0, float(plant.output(np.asarray(plant.x0, dtype=float))), float(reference)
    return None


def compiled_run(plant, ep, controller, law, R, RP, changes, t, h, t_end, S, settled_tol, name,
                 fast, AL=None, LP=None, step=None, t_end_key="t_end") -> Result:
    """One member through the compiled engine, its trajectory named as a Result; the
    reference, elements and step as for :func:`run_members`."""
    M, traj, CS, DT = run_members([ep], [law], R, [list(changes)], t_end=t_end, h=h, S=S,
                              fast=fast, record=True, RP=RP, AL=AL, LP=LP, step=step,
                              t_end_key=t_end_key)
    met = _metrics.from_kernel(M, 0, settled_tol)
    k_end = met["n_samples"]
    _hand_back(controller, CS, traj, k_end)
    signals, states = trajectory.named_rows(traj[:, :k_end], law.components, plant.state_names)
    if met["diverged"] and DT[0] < 0.0:
        key = "sim.integrator" if t_end_key == "sim.t_end" else "integrator"
        raise ConfigError(
            key, ep.integrator, f"the adaptive step collapsed to {-DT[0]:.3g} s at "
            f"t = {met['t_diverge']:.6g} s (step {h:.3g} s): the plant is too stiff for an "
            "explicit method at these tolerances; use the exact integrator (an LTI or "
            "first-order plant), or rk4 with a step the plant's fastest mode allows")
    if met["diverged"] and hasattr(plant, "replay_step"):
        # your f or g may have raised there (the engine made it NaN): told by name
        _replay_last_step(plant, t, signals, states, k_end, h, LP)
    return Result(name=name, time=t[:k_end], signals=signals, states=states, metrics=met,
                  changes=tuple(changes), engine="compiled",
                  arithmetic="fast" if fast else "exact")


def _replay_last_step(plant, t, signals, states, k_end: int, h: float, LP) -> None:
    """PlantFunctionError if the plant's own Python f or g raises in the step that ended
    the run (from the last sample's state and input; g alone at x0 if it ended at once)."""
    if k_end == 0:
        plant.replay_step(0.0, np.asarray(plant.x0, dtype=float), 0.0, 0.0, 0)
        return
    k = k_end - 1
    x = np.array([states[name][k] for name in plant.state_names])
    if not np.all(np.isfinite(x)):
        return
    substeps = 1 if LP is None else int(LP[layout.SUBSTEPS, 0])
    plant.replay_step(float(t[k]), x, float(signals["u_plant"][k]), h, substeps)


def _python_reason(plant, ep, controller) -> str:
    if ep is None:
        return getattr(plant, "python_reason", None) or (
            f"{type(plant).__name__} is a Plant written in Python")
    if not getattr(controller, "auto_mode", True):
        return "the controller is in manual mode"
    return f"{type(controller).__name__} is not a library controller"


def _python_driver(plant, controller, r, t, changes, h, t_end, S, settled_tol, name,
                   note, al=None, step=None) -> Result:
    """The loop in Python, one plant step and one controller call per sample."""
    n = t.size
    # y, u, the states and a law's few components (at most 8) per sample
    grid.check_recording(n, 2 + len(plant.x0) + 8, t_end)
    # each change at its sample, in list order: the engine's rule
    due = [grid.first_sample_at(c.time, t_end, n) for c in changes]
    x = np.array(plant.x0, dtype=float, copy=True)
    y = np.full(n, np.nan)
    u = np.full(n, np.nan)
    X = np.full((n, x.size), np.nan)
    comps: dict[str, np.ndarray] = {}
    has_components = hasattr(controller, "components")
    bound = S[engine_metrics.S_DIVERGE_ABOVE]
    # a library law's adaptation error (NaN where it does not apply, or for your own
    # controller): this run's share of it
    adapt0 = getattr(controller, "adaptation_error", math.nan)
    with restored(plant):  # a schedule acts on this run only
        for k in range(n):
            for c, k_c in zip(changes, due, strict=True):
                if k_c == k:
                    plant.set_param(c.name, plant.params[c.name] + c.value if c.add else c.value)
            yk = plant.output(x)
            if not engine_metrics.measurement_ok(yk, r[k], bound):  # the engine's test
                y[k] = yk
                break
            uk = (controller(yk, setpoint=r[k]) if al is None
                  else controller(yk, setpoint=r[k], alpha=float(al[k])))
            y[k], u[k], X[k] = yk, uk, x
            if has_components:
                for key, value in controller.components.items():
                    if key not in comps:  # allocated once, not at every sample
                        comps[key] = np.full(n, np.nan)
                    comps[key][k] = value
            x = plant.step(t[k], x, uk, h)
    gamma = comps.get("gamma", np.full(n, np.nan))
    M = np.zeros((engine_metrics.N_METRICS, 1))
    engine_metrics.start(M, *step_metrics_of(np.zeros((reference_law.N_PARAMS, 1)), step),
                         load_step_of(layout.column(), [changes], t_end, n))
    engine_metrics.trajectory_metrics(t, h, y, r, u, u, gamma, S, M)
    M[engine_metrics.M_ADAPT] = getattr(controller, "adaptation_error", math.nan) - adapt0
    met = _metrics.from_kernel(M, 0, settled_tol)
    k_end = met["n_samples"]
    # the live controllers' component names, as every result names them
    comps["u_raw"] = comps.pop("unlimited", comps.get("u_raw", np.full(n, np.nan)))
    comps.setdefault("gamma", np.full(n, np.nan))
    comps.setdefault("gain", comps["gamma"])
    signals = {"y_ref": r, "y": y, "y_meas": y, "u": u, "u_plant": u,
               **{k: comps[k] for k in SIGNALS if k not in ("y_ref", "y", "y_meas", "u",
                                                             "u_plant")},
               **{k: v for k, v in comps.items() if k not in SIGNALS}}
    signals = {k: v[:k_end] for k, v in signals.items()}
    states = {s: X[:k_end, i] for i, s in enumerate(plant.state_names)}
    return Result(name=name, time=t[:k_end], signals=signals, states=states, metrics=met,
                  changes=tuple(changes), engine="python", engine_note=note)
