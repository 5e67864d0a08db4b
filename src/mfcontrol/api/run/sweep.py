"""Sweeps of a loop built from Python objects: a grid over plant and controller parameters,
every member in the compiled engine (:func:`sweep`)."""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._version import __version__
from ...config.options import BY_KEY, OPTIONS
from ...elements import layout
from ...engine.compose import T_COMP
from ...errors import ConfigError
from ...numerics.grid import check_members, check_recording
from ..model.controllers import RecursiveIP
from ..model.elements import Actuator, Disturbance, Sensor, unread
from ..model.schedule import Change, _check_changes, restored
from ..results import display
from ..results import metrics as _metrics
from ..results.result import Result
from .loop import (
    Reference,
    _alpha,
    _constant_step,
    _elements,
    _setup,
    law_arrays,
    run_members,
    simulate_loop,
    stacked,
)

if TYPE_CHECKING:
    import pandas as pd


@dataclass
class LoopSweepResult(display.Shown):
    """Every member's swept values and metrics (``table``: one column each), and the
    trajectories of the members kept (``kept``: member index to Result).

    Attributes
    ----------
    axes : dict of ndarray
        The swept keys and their values (``controller.kp``, ``plant.J``, ...); members
        are their product, the last key fastest.
    table : dict of ndarray
        One column per swept key and per metric, one row per member.
    kept : dict of int to Result
        The trajectories of the members asked for with ``keep``.
    arithmetic : str
        ``"exact"`` or ``"fast"``.
    version : str
        mfcontrol version that produced it."""

    axes: dict[str, np.ndarray]
    table: dict[str, np.ndarray]
    kept: dict[int, Result] = field(default_factory=dict)
    arithmetic: str = "exact"
    version: str = __version__

    @property
    def n_members(self) -> int:
        return int(self.table["member"].size)

    def to_pandas(self) -> pd.DataFrame:
        """One row per member: ``member``, the swept values, the metrics."""
        import pandas as pd  # here: about 0.5 s of import, for to_pandas only

        return pd.DataFrame(self.table)

    def to_parquet(self, path: str | Path) -> Path:
        path = Path(path)
        self.to_pandas().to_parquet(path, index=False)
        return path

    def _summary(self) -> list[tuple[str, str]]:
        axes = ", ".join(f"{k} = {display.fmt(v.min())}..{display.fmt(v.max())} ({v.size})"
                         for k, v in self.axes.items())
        return [("members", f"{self.n_members:,} members over {axes}"),
                ("verdicts", f"{int(np.sum(self.table['settled'])):,} settled, "
                             f"{int(np.sum(self.table['diverged'])):,} diverged"),
                ("metric ranges", display.metric_ranges(self.table)),
                ("kept", display.names([f"member {m}" for m in self.kept]) or "none")]

    def __repr__(self) -> str:
        rows = dict(self._summary())
        return (f"<LoopSweepResult {rows['members']}: {rows['verdicts']}\n"
                f" {rows['metric ranges']}; kept {rows['kept']}>")



#: the loop elements a grid key may name, by section
_ELEMENTS = {"sensor": Sensor, "actuator": Actuator, "disturbance": Disturbance}


def _axes(grid: Mapping[str, Sequence[float]], plant, controller,
          elements: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
    if not grid:
        raise ConfigError("grid", grid, "give at least one 'plant.NAME' or "
                          "'controller.NAME' with its values")
    params = getattr(controller, "_params", {})
    elements = elements or {}
    out = {}
    for key, values in grid.items():
        where, _, name = key.partition(".")
        if where == "plant":
            if name not in plant.params:
                raise ConfigError(key, values, "unknown plant parameter; allowed: "
                                  + ", ".join(f"plant.{k}" for k in plant.params))
        elif where == "controller":
            # sample_time sets the time grid, which every member shares
            numeric = [k for k, v in params.items() if k != "sample_time"
                       and isinstance(v, int | float) and not isinstance(v, bool)]
            if isinstance(controller, RecursiveIP):  # takes every option of the table
                numeric += [o.key.partition(".")[2] for o in OPTIONS
                            if o.key.startswith("controller.") and o.kind == "float"
                            and o.key.partition(".")[2] not in numeric]
            if name not in numeric:
                raise ConfigError(key, values, "not a numeric controller option; allowed: "
                                  + ", ".join(f"controller.{k}" for k in numeric))
            never = _unread(params, name, isinstance(controller, RecursiveIP))
            if never:
                raise ConfigError(key, values, f"this controller never reads it ({never}): "
                                  "every member would be the same")
        elif where in _ELEMENTS:
            kind = _ELEMENTS[where]
            numeric = [f.name for f in dataclasses.fields(kind)
                       if f.type in ("float", "int")]
            if name not in numeric:
                raise ConfigError(key, values, "not a numeric option of the "
                                  f"{kind.__name__}; allowed: "
                                  + ", ".join(f"{where}.{k}" for k in numeric))
            why = unread(key, {f"{sec}.{f.name}": getattr(elements.get(sec) or k(), f.name)
                               for sec, k in _ELEMENTS.items() for f in dataclasses.fields(k)})
            if why:
                raise ConfigError(key, values, f"has no effect here ({why}): every member "
                                  "would be the same")
        else:
            raise ConfigError(key, values, "must start with 'plant.', 'controller.', "
                              "'sensor.', 'actuator.' or 'disturbance.'")
        try:
            arr = np.atleast_1d(np.asarray(values, dtype=float))
        except (TypeError, ValueError):
            arr = np.array([np.nan])
        if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
            raise ConfigError(key, values, "must be a non-empty list of finite numbers")
        out[key] = arr
    return out


def keep_members(n_members: int, keep: int) -> np.ndarray:
    """``keep`` members spread evenly over a grid (first and last included)."""
    return np.unique(np.round(np.linspace(0, n_members - 1, min(keep, n_members))).astype(int))


def _unread(params: Mapping[str, Any], name: str, recursive: bool) -> str:
    """Why the law never reads the numeric option ``name`` with these options ("" when it
    does)."""
    if recursive:  # its own "gain" option is another thing (gamma or 1/alpha)
        variational = params.get("law", BY_KEY["controller.law"].default) == "variational"
    else:
        variational = params.get("gain") == "variational"
    if name in ("gamma0", "Gamma", "eps_M") and not variational:
        return "only the variational gain does"
    if name == "alpha" and params.get("gain") == "external":
        return "gain='external' takes alpha at every sample: sweep(..., alpha=)"
    if name == "k_aw" and params.get("anti_windup") != "back-calculation":
        return "only back-calculation anti-windup does"
    if name == "setpoint":
        return "the reference sets it"
    return ""


def sweep(plant, controller, reference: Reference = 0.0, *,
          grid: Mapping[str, Sequence[float]], t_end: float, h: float | None = None,
          changes: Sequence[Change] = (), fast: bool = False, keep: int = 0,
          settle_time: float = 0.0, final_window: float = 0.2, settled_tol: float = 0.1,
          diverge_above: float = 1e12, alpha: Reference | None = None,
          vectorise: bool | None = None, sensor=None, actuator=None, disturbance=None,
          substeps: int = 1) -> LoopSweepResult:
    """Run ``controller`` on ``plant`` for every combination of the grid's values.

    Parameters
    ----------
    plant, controller, reference, t_end, h, changes, settle_time, final_window,
    settled_tol, diverge_above, alpha, sensor, actuator, disturbance, substeps
        As for :func:`mfcontrol.simulate_loop` (``alpha``: one schedule, the same for
        every member; the elements the same for every member but for their swept
        options). Every member starts from the plant's ``x0`` and from a fresh
        controller (a controller's present memory is not used).
    grid : mapping
        ``{"plant.NAME": values, "controller.NAME": values, ...}``: plant parameters (as in
        ``plant.params``), numeric controller options (as its constructor takes them)
        and numeric options of the loop's elements (``sensor.seed``,
        ``actuator.delay``, ``disturbance.amplitude``, ...: the fields of
        :class:`~mfcontrol.Sensor`, :class:`~mfcontrol.Actuator`,
        :class:`~mfcontrol.Disturbance`).
        The axes combine as a product, member m the m-th combination, the last key
        fastest.
    fast : bool
        The engine's fast mode (about 1e-12 relative of the exact runs) where the
        members run in the member loop; in the vectorised loop (the default for
        sweeps that pay for it) they run in exact arithmetic either way, which is
        never slower.
    keep : int
        Also run this many members, spread over the grid, with their trajectories
        (``result.kept``).
    vectorise : bool or None
        Run the members in the engine's vectorised loop (exact arithmetic, also with
        ``fast=True``): blocks of 64 members whose loop elements (sensor, actuator,
        disturbance), law (any, the algebraic estimator's window included) and
        metrics, past the first samples, run over the block as vector instructions,
        the plant too when it has block functions: the library's plants and LTI
        models (compiled once per machine) and your own ODE under RK4, whose f and g
        numba compiles over the block (about 1.5 s, once per machine when they are
        defined in a file); otherwise each member's f runs through its compiled
        function. Members with numbers of substeps of their own run in the member
        loop. The same bits
        either way; on the DC motor of the user guide's Speed page, about 1.6x faster
        than the member loop with f member by member and about 6x with f over the
        block. True: always, f over the block where it can; False: the member loop;
        None (default): when it pays (:func:`mfcontrol.engine.compose.loop_for`: once
        the vectorised loop is compiled on the machine, about 2 min the first time ever,
        then cached on disk; f over the block for large sweeps or once compiled so).

    Returns
    -------
    LoopSweepResult
        ``to_pandas()`` has one row per member: its swept values and its metrics. Each
        member's metrics are those of its single run, bit for bit.

    Examples
    --------
    A first-order plant y' = a y + u under an i-P, for three gains and a stable and an
    unstable pole:

    >>> import mfcontrol
    >>> from mfcontrol import FirstOrder
    >>> sw = mfcontrol.sweep(FirstOrder(a=-1.0, b=1.0),
    ...                      mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-3), 1.0,
    ...                      grid={"controller.kp": [2.0, 5.0, 10.0], "plant.a": [-1.0, 0.5]},
    ...                      t_end=2.0)
    >>> df = sw.to_pandas()
    >>> len(df), bool(df["settled"].all())
    (6, True)
    """
    if not isinstance(keep, int | np.integer) or isinstance(keep, bool) or keep < 0:
        raise ConfigError("keep", keep, "must be a whole number >= 0")
    plant, h, t, r, S = _setup(plant, controller, reference, t_end, h, changes, settle_time,
                               final_window, settled_tol, diverge_above)
    if law_arrays(controller) is None:
        raise ConfigError("controller", type(controller).__name__, "a sweep runs in the "
                          "compiled engine: a library controller (IP, IPI, IPD, IPID, "
                          "PID, ADRC, RecursiveIP) in automatic mode, without input_limits")
    given = {"sensor": sensor, "actuator": actuator, "disturbance": disturbance}
    axes = _axes(grid, plant, controller, given)
    R = r[None, :]
    al = _alpha(controller, alpha, t)
    base_ep = plant.engine() if hasattr(plant, "engine") else None
    if base_ep is None:
        raise ConfigError("plant", type(plant).__name__, "a sweep runs in the compiled "
                          "engine: the plant must compile (see simulate_loop's "
                          "engine_note)")
    keys = list(axes)
    check_members(math.prod(v.size for v in axes.values()), "grid",
                  {k: f"{v.size:,} values" for k, v in axes.items()})
    combos = list(itertools.product(*(range(v.size) for v in axes.values())))
    plant_keys = [k for k in keys if k.startswith("plant.")]
    ctrl_keys = [k for k in keys if k.startswith("controller.")]
    element_keys = [k for k in keys if k.partition(".")[0] in _ELEMENTS]
    base_lp = _elements(sensor, actuator, disturbance, substeps, n=t.size)
    params = dict(controller._params)
    # one engine plant per distinct plant setting and one law per distinct controller
    # setting: a grid of n x m values builds n + m of them, not n m
    engines: dict[tuple, Any] = {}
    steps: dict[tuple, Any] = {}
    laws: dict[tuple, Any] = {}
    columns: dict[tuple, tuple[np.ndarray, tuple]] = {}
    plants, member_laws, member_steps, member_lp = [], [], [], []
    members_elements = []
    with restored(plant):  # each member's values set in turn, the plant left as given
        for combo in combos:
            values = {k: float(axes[k][i]) for k, i in zip(keys, combo, strict=True)}
            pkey = tuple(values[k] for k in plant_keys)
            if pkey not in engines:
                for k in plant_keys:  # the plant's own checks (positivity, ...)
                    plant.set_param(k.partition(".")[2], values[k])
                if plant_keys:  # and the schedule on this member's parameters
                    _check_changes(plant, changes)
                engines[pkey] = plant.engine() if plant_keys else base_ep
                # the step the step metrics measure starts at this plant's initial output
                steps[pkey] = _constant_step(plant, reference)
            plants.append(engines[pkey])
            member_steps.append(steps[pkey])
            ckey = tuple(values[k] for k in ctrl_keys)
            if ckey not in laws:
                laws[ckey] = law_arrays(_controller(controller, params, ctrl_keys, values))
            member_laws.append(laws[ckey])
            ekey = tuple(values[k] for k in element_keys)
            if ekey not in columns:
                elements = _member_elements(given, element_keys, values)
                m_sensor, m_actuator, m_disturbance = elements
                columns[ekey] = (base_lp if not element_keys else _elements(
                    m_sensor, m_actuator, m_disturbance, substeps, n=t.size), elements)
            member_lp.append(columns[ekey][0])
            members_elements.append(columns[ekey][1])
    step = (None if member_steps[0] is None
            else tuple(np.array(v) for v in zip(*member_steps, strict=True)))
    if keep:  # the kept members are recorded after the sweep: refuse a size now, not then
        check_recording(t.size, T_COMP + len(member_laws[0].rows) + plants[0].x0.size, t_end)
    M, _, _, _ = run_members(plants, member_laws, R, [list(changes)] * len(combos),
                          t_end=t_end, h=h, S=S, fast=fast,
                          AL=None if al is None else al[None, :], vectorise=vectorise,
                          LP=stacked(member_lp, layout.stack), step=step)
    met = _metrics.table(M, settled_tol)
    table: dict[str, np.ndarray] = {"member": np.arange(len(combos), dtype=np.int64)}
    idx = np.array(combos, dtype=np.int64).reshape(len(combos), len(keys))
    for c, k in enumerate(keys):
        table[k] = axes[k][idx[:, c]]
    table.update({name: met[name] for name in _metrics.COLUMNS})
    kept = {}
    if keep:
        for m in keep_members(len(combos), keep):
            m = int(m)
            values = {k: float(table[k][m]) for k in keys}
            with restored(plant), warnings.catch_warnings():
                # the alpha check is a single run's: a sweep's kept members are members
                warnings.filterwarnings("ignore", r"alpha = .* (outside|opposite)",
                                        RuntimeWarning)
                for k in plant_keys:
                    plant.set_param(k.partition(".")[2], values[k])
                kept[m] = simulate_loop(
                    plant, _controller(controller, params, ctrl_keys, values), reference,
                    t_end=t_end, h=h, changes=changes, settle_time=settle_time,
                    final_window=final_window, settled_tol=settled_tol,
                    diverge_above=diverge_above, name=f"member {m}", fast=fast,
                    alpha=alpha, sensor=members_elements[m][0],
                    actuator=members_elements[m][1], disturbance=members_elements[m][2],
                    substeps=substeps)
    return LoopSweepResult(axes=axes, table=table, kept=kept,
                           arithmetic="fast" if fast else "exact")


def _member_elements(given: Mapping[str, Any], keys: Sequence[str],
                     values: Mapping[str, float]) -> tuple:
    """(sensor, actuator, disturbance) of a member: the ones given, with its values of the
    swept element options (each object checks them)."""
    out = []
    for where, kind in _ELEMENTS.items():
        mine = {k.partition(".")[2]: values[k] for k in keys if k.startswith(where + ".")}
        obj = given[where]
        if mine:
            base = obj if obj is not None else kind()
            fields = {f.name: f for f in dataclasses.fields(kind)}
            mine = {k: int(v) if fields[k].type == "int" and float(v).is_integer() else v
                    for k, v in mine.items()}
            try:
                obj = dataclasses.replace(base, **mine)
            except ConfigError as exc:
                raise ConfigError("grid", {f"{where}.{k}": v for k, v in mine.items()},
                                  str(exc)) from None
        out.append(obj)
    return tuple(out)


def _controller(controller, params, ctrl_keys, values):
    """A fresh controller of the same class with the member's options (its constructor
    checks them: one translator from options to law parameters)."""
    kw = dict(params)
    for k in ctrl_keys:
        name = k.partition(".")[2]
        v = values[k]
        kw[name] = (int(v) if isinstance(params.get(name), int) and float(v).is_integer()
                    else v)
    try:
        return type(controller)(**kw)
    except ValueError as exc:
        raise ConfigError("grid", {k: values[k] for k in ctrl_keys}, str(exc)) from None
