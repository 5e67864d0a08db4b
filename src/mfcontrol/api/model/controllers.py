"""Controllers for a user's own sampling loop, shaped like simple-pid.

>>> import mfcontrol
>>> ctrl = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=0.01, output_limits=(-10, 10))
>>> u = ctrl(0.0, setpoint=1.0)      # first sample: no derivative yet, holds the start
>>> u = ctrl(0.02, setpoint=1.0)
>>> sorted(ctrl.components)
['D', 'F_hat', 'I', 'P', 'feedforward', 'gamma', 'unlimited']

Each call runs the same compiled law as the simulators (:mod:`mfcontrol.laws`). A NaN or
infinite measurement, or one outside ``input_limits`` (the sensor's range, if given), never
reaches the law: the controller returns its last output and counts the event in
``nan_count``. So does a finite measurement whose step would overflow (its output or any
value of the law's memory not finite): the memory stays as it was, so the outlier never
enters it. Should :data:`RESTART_AFTER` taken samples in a row overflow all the same, the
memory itself is what overflows: the law restarts from its last output (bumpless, as on a
return to automatic) and ``restarts`` counts it. A controller thus recovers from any
single finite outlier. ``snapshot()`` returns plain data (JSON and pickle safe);
``restore()`` makes a controller continue bit for bit from it.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping
from typing import Any, Literal, Self, cast, overload

import numpy as np

from ..._version import __version__
from ...analysis import filters
from ...config import options
from ...engine import live
from ...engine import metrics as engine_metrics
from ...errors import as_float, shown
from ...laws import adrc, estimators, intelligent, pid, recursive_ip
from ...laws import variational_gain as gain_law
from ..params import recursive_law_column

_INF = math.inf
#: taken samples in a row whose step overflowed after which the law restarts from its last
#: output (the exported C does the same): one overflow is the sample's fault and is
#: rejected; a second in a row, on the next measurement, is the memory's
RESTART_AFTER = 2
# a tuple, built once: ``int | float | ...`` in a call builds a union type every time
_REAL = (int, float, np.integer, np.floating)


@overload
def _number(name: str, value: Any, *, positive: bool = ..., nonneg: bool = ...,
            allow_none: Literal[False] = ...) -> float: ...
@overload
def _number(name: str, value: Any, *, positive: bool = ..., nonneg: bool = ...,
            allow_none: bool) -> float | None: ...
def _number(name: str, value: Any, *, positive: bool = False, nonneg: bool = False,
            allow_none: bool = False) -> float | None:
    if value is None and allow_none:
        return None
    ok = isinstance(value, _REAL) and not isinstance(value, bool)
    real = ok
    number = as_float(value) if real else math.nan  # an int beyond the float range: inf
    ok = ok and math.isfinite(number) and (not positive or number > 0) \
        and (not nonneg or number >= 0)
    if not ok:
        what = "> 0" if positive else (">= 0" if nonneg else "")
        # a number as the float it was read as; an int beyond the float range as given
        overflow = isinstance(value, int) and math.isinf(number)
        bad = number if real and not overflow else value
        raise ValueError(f"{name} = {shown(bad)}: must be a finite number {what}".rstrip())
    return number


def _choice(name: str, value: Any, allowed) -> Any:
    # True == 1: a bool is not a choice among numbers
    if isinstance(value, bool) or value not in allowed:
        raise ValueError(f"{name} = {shown(value)}: must be one of {', '.join(map(str, allowed))}")
    return value


#: the state rows' layout a snapshot records: 2 since the gain adaptation's multi-rate rows
#: (a snapshot without it is older; :func:`_with_multi_rate_rows`), 3 since the intelligent
#: laws' rls rows, 4 since the gain adaptation's adaptation-error row
STATE_LAYOUT = 4
#: the gain adaptation's state rows up to layout 3 (4 adds ADAPT after them): the older
#: layouts' offsets of the rows after them are this many fewer
_GAIN_ROWS_3 = gain_law.ADAPT
_SHIFT_4 = gain_law.N_STATE - _GAIN_ROWS_3


def _with_multi_rate_rows(snap: Any) -> Any:
    """A snapshot of a law on the gain adaptation's rows (intelligent, recursive) taken
    before the multi-rate sum and count existed, with them put in as a reset leaves them
    (zero: an update at each sample never reads them), so that it continues bit for bit."""
    if not isinstance(snap, Mapping) or not isinstance(snap.get("state"), list) \
            or snap.get("layout", 1) >= 2:
        return snap
    state = list(snap["state"])
    state[gain_law.ACC:gain_law.ACC] = [0.0, 0.0]
    return {**snap, "state": state, "layout": 2}


def _with_rls_rows(snap: Mapping[str, Any]) -> Mapping[str, Any]:
    """An intelligent law's snapshot of layout 2, with the rls gain's rows put in (zeros:
    only that gain reads them, and it did not exist), as layout 3."""
    if snap.get("layout", 1) >= 3:
        return snap
    state = list(snap["state"])
    at = intelligent.RLS_F - _SHIFT_4  # layout 3's offset
    state[at:at] = [0.0] * (intelligent.EST_BASE - intelligent.RLS_F)
    return {**snap, "state": state, "layout": 3}


def _with_adaptation_row(snap: Any) -> Any:
    """A snapshot of a law on the gain adaptation's rows of layout 3 (or older, carried
    to 3 first), with the adaptation error's row put in as a reset leaves it (zero: the
    error is then counted from the snapshot on), as layout 4."""
    if not isinstance(snap, Mapping) or not isinstance(snap.get("state"), list) \
            or snap.get("layout", 1) >= 4:
        return snap
    state = list(snap["state"])
    state[_GAIN_ROWS_3:_GAIN_ROWS_3] = [0.0] * _SHIFT_4
    return {**snap, "state": state, "layout": 4}


def _adaptation_error(CP: np.ndarray, CS: np.ndarray) -> float:
    """A live law's adaptation error from its state (the gain adaptation's rows)."""
    return float(engine_metrics.adaptation_of(CS[gain_law.ADAPT, 0], CP[gain_law.MODE, 0]))


def _samples(name: str, value: Any, most: int) -> int:
    """A whole number of samples from 0 to ``most`` (a delay)."""
    if (not isinstance(value, int | np.integer) or isinstance(value, bool)
            or not 0 <= value <= most):
        raise ValueError(f"{name} = {shown(value)}: must be a whole number of samples from "
                         f"0 to {most:,}")
    return int(value)


def _whole(name: str, value: Any) -> int:
    """A whole number >= 1 (a count of samples)."""
    if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 1:
        raise ValueError(f"{name} = {shown(value)}: must be a whole number >= 1")
    return int(value)


def _limits(value: Any, name: str = "output_limits") -> tuple[float | None, float | None]:
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {shown(value)}: must be a pair (low, high), "
                         "None for no limit") from None
    lo = _number(f"{name}[0]", lo, allow_none=True)
    hi = _number(f"{name}[1]", hi, allow_none=True)
    if lo is not None and hi is not None and lo > hi:
        raise ValueError(f"{name} = {shown(value)}: low must not exceed high")
    return lo, hi


class _Controller:
    """What every live controller shares: call protocol, NaN guard, modes, snapshots."""

    def __init__(self, params: dict[str, Any], n_cp: int, n_cs: int):
        self._params = params
        self._CP = np.zeros((n_cp, 1))
        self._CS = np.zeros((n_cs, 1))
        self._backup = np.zeros(n_cs)
        self.nan_count = 0
        #: times the law restarted because its memory overflowed (see RESTART_AFTER)
        self.restarts = 0
        self._overflows = 0  # taken samples in a row whose step overflowed
        self.auto_mode = True
        self._setpoint = float(params.get("setpoint", 0.0))
        self._last_output = 0.0
        self._in_lo, self._in_hi = -_INF, _INF
        # time of the samples the law did not take since the last one it took (a rejected
        # measurement or output): the next call's derivatives span it
        self._skipped = 0.0

    #: the compiled step in :mod:`mfcontrol.engine.live` and how many floats follow its
    #: three arrays
    _KERNEL: tuple[str, int]

    #: restart the law from an output applied in manual (set_auto_mode): subclasses define it
    _bumpless_start: Callable[[float], None]

    def _bind(self) -> None:
        """Bind the compiled step to this controller's arrays as ``self._step``, on its
        first use (:meth:`__getattr__`): a controller that a sweep or a single run only
        reads the parameters of never looks its step up (about a third of building
        one). It is called without numba's type checks: the arrays must never be
        replaced, only written."""
        self.__dict__.pop("_step", None)

    def __getattr__(self, name: str) -> Any:
        # only for an attribute not set: _step before its first use
        if name != "_step" or "_CP" not in self.__dict__:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        kernel, n_scalars = self._KERNEL
        self._step = live.entry_point(getattr(live, kernel), self._CP, self._CS,
                                      self._backup, *(0.0,) * n_scalars)
        return self._step

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state.pop("_step", None)  # compiled code: bound again on its first use
        return state

    @classmethod
    def _refuse_older_layout(cls, state: Mapping[str, Any], n_params: int,
                             n_state: int) -> None:
        """Refuse a pickle whose parameter or state rows are not this version's: the
        compiled step would read past a shorter column, or rows at other offsets."""
        cp, cs = state.get("_CP"), state.get("_CS")
        if (cp is not None and cp.shape[0] != n_params) or (
                cs is not None and cs.shape[0] != n_state):
            raise ValueError(f"this {cls.__name__} was pickled by an older mfcontrol (its "
                             "parameter or state layout changed): rebuild it from a "
                             f"snapshot, {cls.__name__}.from_snapshot(snap), which carries "
                             "older snapshots over")

    def __setstate__(self, state: dict[str, Any]) -> None:
        state.pop("_kernel", None)  # pickles of 0.1.0 before the class held it
        if "setpoint" in state:
            state["_setpoint"] = state.pop("setpoint")
        if isinstance(state.get("_components"), dict):
            state["_components"] = tuple(state["_components"].values())
        self.__dict__.update(state)
        self._bind()

    # subclasses set _KERNEL, fill the parameter column, _bind(), define _reset_state
    def _reset_state(self) -> None:  # pragma: no cover
        raise NotImplementedError

    def _take_input_limits(self, value: Any) -> None:
        """Check ``input_limits`` and keep them; they join the parameters only when set, so
        that snapshots of controllers without them stay as they were."""
        lo, hi = _limits(value, "input_limits")
        self._in_lo = -_INF if lo is None else lo
        self._in_hi = _INF if hi is None else hi
        if (lo, hi) != (None, None):
            self._params["input_limits"] = [lo, hi]

    @property
    def input_limits(self) -> tuple[float | None, float | None]:
        """The measurement range the law takes; a sample outside is rejected as a NaN is."""
        lo, hi = self._params.get("input_limits", (None, None))
        return lo, hi

    def reset(self) -> None:
        """Forget all history (derivatives, integral, estimator window, adapted gain)."""
        self._reset_state()
        self.nan_count = 0
        self.restarts = 0
        self._overflows = 0
        self._skipped = 0.0

    def _overflowed(self, dt: float) -> None:
        """A taken sample whose step overflowed (the compiled step left the memory as it
        was): counted, its period spanned by the next sample; the law restarts from its
        last output at the RESTART_AFTER-th such sample in a row."""
        self.nan_count += 1
        self._overflows += 1
        if self._overflows < RESTART_AFTER:
            self._skipped += dt
            return
        try:
            self._bumpless_start(self._last_output)
        except ValueError:  # a start the law cannot continue from: a plain restart
            self._reset_state()
        self._overflows = 0
        self._skipped = 0.0
        self.restarts += 1

    @property
    def setpoint(self) -> float:
        """The setpoint the next calls use (a call's ``setpoint=`` replaces it)."""
        return self._setpoint

    @setpoint.setter
    def setpoint(self, value: float) -> None:
        self._setpoint = _number("setpoint", value)

    @property
    def last_output(self) -> float:
        return self._last_output

    def set_auto_mode(self, enabled: bool, last_output: float | None = None) -> None:
        """Switch between automatic and manual. Turning automatic on restarts the law from
        ``last_output`` (the output applied in manual), so the output does not jump.
        ``last_output`` is clamped to the output limits, as every output is."""
        if enabled and not self.auto_mode:
            start = self._last_output if last_output is None else self._limited(_number(
                "last_output", last_output))
            self._bumpless_start(start)
            self._skipped = 0.0
            self._overflows = 0
        elif not enabled and last_output is not None:
            self._last_output = self._limited(_number("last_output", last_output))
        self.auto_mode = bool(enabled)

    #: the law's module in :mod:`mfcontrol.laws` (its tunable rows: :meth:`retune`)
    _LAW: Any

    #: keywords :meth:`retune` refuses: what is not a parameter of the law, or is built in
    _NOT_RETUNED = {"sample_time": "the period is built in", "setpoint":
                    "set the setpoint attribute, or pass it with a sample",
                    "input_limits": "the measurement's range is built in"}

    def retune(self, **changes: Any) -> None:
        """Change parameters while the controller runs: gains, output limits and the
        other tunable ones (:mod:`mfcontrol.laws.tunable`), by the constructor's keywords
        and checked as it checks them (a refused value changes nothing). In automatic
        mode the law then restarts from the last output clamped to the new limits,
        bumpless, as :meth:`set_auto_mode` does (before any sample it starts as a
        controller built with them would; a retune that changes nothing the law reads
        changes nothing); in manual mode the held output is clamped to the new limits. The
        counters stay.

        A retune is a restart: the derivative's and the estimator's histories start again
        and the sample after it integrates nothing (its output is the last one). It suits
        an operator's or a tuning tool's change, not a gain schedule that retunes every
        sample, which would hold the output. A keyword that fixes the law's structure (its order,
        estimator, window, kernel, anti-windup kind, gain mode, delay, the period) is
        refused: build a new controller. The exported C's ``PREFIX_set_params`` does the
        same (:mod:`mfcontrol.cexport`).

        Examples
        --------
        >>> import mfcontrol
        >>> ctrl = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1)
        >>> ctrl(0.0, setpoint=1.0)
        2.0
        >>> ctrl.retune(kp=1.0)
        >>> ctrl(0.0, setpoint=1.0), round(ctrl(0.0, setpoint=1.0), 6)
        (2.0, 2.1)

        The output does not jump: the integral takes up what P gave up, then integrates.
        """
        for key in changes:
            if key in self._NOT_RETUNED:
                raise ValueError(f"{key}: not retuned ({self._NOT_RETUNED[key]})")
        cls = type(self)
        new = cls(**{**self._params, **changes})  # every check the constructor makes
        # the rows as built (a bumpless start rewrites the recursive law's start row)
        built = cls(**self._params)
        before, after = built._CP[:, 0], new._CP[:, 0]
        tunable = [row for _, row, _ in self._LAW.tunable(after)]
        fixed = np.ones(len(after), bool)
        fixed[tunable] = False

        def fixed_rows_differ(cp) -> bool:
            return not np.array_equal(cp[fixed], before[fixed], equal_nan=True)

        if fixed_rows_differ(after) or new._CS.shape != self._CS.shape:
            at_fault = []
            for key, value in changes.items():
                try:
                    alone = cls(**{**self._params, key: value})
                except (TypeError, ValueError):
                    continue
                if fixed_rows_differ(alone._CP[:, 0]) or alone._CS.shape != self._CS.shape:
                    at_fault.append(key)
            keys = ", ".join(f"{k} = {shown(changes[k])}" for k in at_fault or changes)
            raise ValueError(f"{keys}: not retuned, it fixes the law's structure (its state "
                             "or its branches) or its gain mode does not adapt it: build a "
                             f"new {cls.__name__}")
        same = np.array_equal(after[tunable], self._CP[tunable, 0])
        # no sample taken since the start (the memory as built)
        fresh = np.array_equal(self._CS, built._CS, equal_nan=True)
        self._params = new._params
        if same:  # nothing the law reads changes: no restart
            return
        self._CP[:, 0] = after  # in place: the compiled step holds the array
        self._adopt(new)
        # the output held (in manual mode, or after a rejected sample) within the new limits
        self._last_output = self._limited(self._last_output)
        if not self.auto_mode:
            return
        if fresh:  # before any sample: start as a controller built with them would
            self._reset_state()
        else:  # from the last output
            self._bumpless_start(self._last_output)
            self._skipped = 0.0
            self._overflows = 0

    def _adopt(self, new: Self) -> None:
        """Take what ``new``, built with the retuned parameters, holds beside its rows."""

    #: the parameter rows of the output limits (every law has them; +-inf when not set)
    _OUT_ROWS: tuple[int, int]

    def _limited(self, u: float) -> float:
        """``u`` clamped to the output limits (a manual output, as the law clamps its own;
        the C export clamps it the same way)."""
        lo, hi = self._OUT_ROWS
        return float(min(max(u, self._CP[lo, 0]), self._CP[hi, 0]))

    def _plain(self, y: Any, setpoint: Any) -> bool:
        """True for the common call, finite Python floats in automatic mode (and takes the
        setpoint): the caller skips the general checks of :meth:`_measurement_ok`, which
        cost as much again as the law; anything else takes the general path."""
        if (type(y) is float and y - y == 0.0 and self._in_lo <= y <= self._in_hi
                and self.auto_mode
                and (setpoint is None or type(setpoint) is float and setpoint - setpoint == 0.0)):
            if setpoint is not None:
                self._setpoint = setpoint
            return True
        return False

    def _measurement_ok(self, y: float, setpoint: float | None, dt: float = 0.0) -> bool:
        """Take the setpoint (a finite number, or None to keep it); False when the law must
        not run (manual mode, or a NaN/inf measurement or one outside ``input_limits``,
        which is counted and whose period ``dt`` the next sample's derivatives span): the
        caller returns the last output."""
        # both checked before either is taken: a refused call changes nothing
        if not isinstance(y, _REAL) or isinstance(y, bool):
            raise ValueError(f"y = {shown(y)}: the measurement must be a number (NaN and inf are "
                             "counted in nan_count and hold the output)")
        if setpoint is not None:
            self.setpoint = setpoint  # the property checks it
        if not self.auto_mode:
            return False
        y = as_float(y)
        # (NaN fails both comparisons; the infinities are outside any range)
        if not self._in_lo <= y <= self._in_hi or not math.isfinite(y):
            self.nan_count += 1
            self._skipped += dt
            return False
        return True

    def snapshot(self) -> dict[str, Any]:
        """Everything needed to continue bit for bit, as plain data."""
        return {
            "controller": type(self).__name__, "mfcontrol": __version__,
            "params": dict(self._params), "state": self._CS[:, 0].tolist(),
            "last_output": self._last_output, "nan_count": self.nan_count,
            "auto_mode": self.auto_mode, "setpoint": self.setpoint, "skipped": self._skipped,
            "overflows": self._overflows, "restarts": self.restarts,
            "layout": STATE_LAYOUT, **self._snapshot_extra(),
        }

    def _snapshot_extra(self) -> dict[str, Any]:
        return {}

    _SNAPSHOT_KEYS = ("controller", "params", "state", "last_output", "nan_count",
                      "auto_mode", "setpoint")

    def restore(self, snap: dict[str, Any]) -> None:
        """Continue from a snapshot taken of a controller with the same parameters. A
        snapshot that is not one (missing keys, wrong types) is refused with a ValueError
        and leaves the controller exactly as it was."""
        if not isinstance(snap, Mapping):
            raise ValueError(f"snapshot = {shown(snap)}: must be the dict snapshot() returns")
        snap = self._migrated(snap)
        missing = [k for k in self._SNAPSHOT_KEYS if k not in snap]
        if missing:
            raise ValueError(f"snapshot lacks {', '.join(missing)}: must be the dict "
                             "snapshot() returns")
        if snap["controller"] != type(self).__name__:
            raise ValueError(f"snapshot is of a {snap['controller']!r} controller, "
                             f"not {type(self).__name__!r}")
        if not isinstance(snap["params"], Mapping) or dict(snap["params"]) != self._params:
            raise ValueError("snapshot parameters differ from this controller's: build it "
                             f"with {type(self).__name__}.from_snapshot(snap) instead")
        try:
            state = np.asarray(snap["state"], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"snapshot state = {snap['state']!r:.60}: must be a list of "
                             "numbers") from None
        if state.shape != (self._CS.shape[0],):
            raise ValueError(f"snapshot state has {state.size} values, expected "
                             f"{self._CS.shape[0]}")
        # (snapshots older than the restart rule have no overflows nor restarts: 0)
        counts = {key: snap.get(key, 0) for key in ("nan_count", "overflows", "restarts")}
        for key, count in counts.items():
            if not isinstance(count, int | np.integer) or isinstance(count, bool) or count < 0:
                raise ValueError(f"snapshot {key} = {shown(count)}: must be a whole number "
                                 ">= 0")
        if not isinstance(snap["auto_mode"], bool | np.bool_):
            raise ValueError(f"snapshot auto_mode = {snap['auto_mode']!r}: must be True or "
                             "False")
        last = _number("snapshot last_output", snap["last_output"])
        setpoint = _number("snapshot setpoint", snap["setpoint"])
        skipped = _number("snapshot skipped", snap.get("skipped", 0.0), nonneg=True)
        extra = self._checked_extra(snap)
        # everything checked: now write
        self._CS[:, 0] = state
        self._last_output, self.nan_count = last, int(counts["nan_count"])
        self._overflows, self.restarts = int(counts["overflows"]), int(counts["restarts"])
        self.auto_mode, self._setpoint, self._skipped = bool(snap["auto_mode"]), setpoint, skipped
        self._restore_extra(extra)

    def _checked_extra(self, snap: Mapping[str, Any]) -> Any:
        return None

    def _restore_extra(self, extra: Any) -> None:
        pass

    @classmethod
    def from_snapshot(cls, snap: dict[str, Any]) -> Self:
        snap = cls._migrated(snap)
        ctrl = cls(**snap["params"])
        ctrl.restore(snap)
        return ctrl

    @classmethod
    def _migrated(cls, snap: Any) -> Any:
        """A snapshot of an older layout as this version's (subclasses that changed it)."""
        return snap

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._params.items())
        return f"{type(self).__name__}({args})"


class _Sampled(_Controller):
    """A controller with a sample time and output limits: the positional laws."""

    _dt: float

    @property
    def sample_time(self) -> float:
        return self._dt

    @property
    def output_limits(self) -> tuple[float | None, float | None]:
        lo, hi = self._params["output_limits"]
        return lo, hi

    def _period(self, dt: float | None) -> float:
        return self._dt if dt is None else _number("dt", dt, positive=True)

    def _output(self, u: float, dt: float) -> float:
        """The law's output, or the last one held when the law overflowed (NaN: the
        compiled step left its state untouched), counted in ``nan_count``."""
        if u != u:
            self._overflowed(dt)
            return self._last_output
        self._last_output = u
        self._skipped = 0.0
        self._overflows = 0
        return u


class IntelligentController(_Sampled):
    """Positional intelligent controller of order n: i-P, i-PI, i-PD or i-PID.

    ``u = -(F_hat - y*^(n) + kp e + ki int(e) + kd e') / alpha`` with ``e = y - y*``
    (see :mod:`mfcontrol.laws.intelligent`).

    Parameters
    ----------
    alpha : float
        Key gain of the ultra-local model ``y^(n) = F + alpha u`` (> 0; with
        ``gain="variational"`` its initial value is 1/gamma0).
    kp, ki, kd : float
        Proportional, integral and derivative gains on the error.
    sample_time : float
        Nominal sample period (s); a call may pass another ``dt``.
    order : {1, 2}
        Order n of the ultra-local model.
    output_limits : (low, high)
        Output limits, None for none.
    input_limits : (low, high)
        The measurement's valid range (the sensor's), None for none: a sample outside is
        rejected as a NaN is (the output holds, ``nan_count`` counts it, the law never sees
        it). Set it to keep a finite outlier out of the law's memory.
    estimator : {"backward-difference", "algebraic"}
        How F is estimated; ``window`` (samples) for the algebraic one.
    kernel : {"held", "trapezoid", "delay-reduced"}, optional
        How the estimator is discretised (:mod:`mfcontrol.laws.estimators`), for the
        algebraic estimator and the order-2 backward difference (the order-1 backward
        difference has one, exact: giving it one is refused). ``"held"``
        (the default) is exact for a constant F under the held input the law applies:
        the algebraic estimator returns F to rounding, the i-P has no steady-state error,
        and the order-2 backward difference subtracts ``alpha (u_{k-1} + u_{k-2}) / 2``
        (stable for alpha down to about beta/3 on y'' = beta u). ``"trapezoid"`` is the
        literature's discretisation (trapezoid / Simpson rule, ``alpha u_{k-1}``): off by
        about ``0.8 alpha |du| / M`` under a moving input, and the order-1 i-P keeps a
        steady-state error ``-alpha u / (kp M^2)``; the algebraic order-2 window must then
        be even. ``"delay-reduced"`` (algebraic, order 1; Mboup, Join and Fliess's affine
        Jacobi estimator): the weighted least-squares line through the held relations,
        evaluated ``lag`` samples back, so F_hat = F(t_k - lag h) exactly for F affine in
        time under any held input; the noise it passes grows as lag shrinks.
    lag : float, optional
        The delay-reduced kernel's point, samples back from the newest: 0 (its default) to
        window, any point of the window (with kappa = mu = 1, window/2 gives the held
        kernel's weights, whose estimate belongs to the window's centre). Only that kernel
        has one.
    kappa, mu : int, optional
        The delay-reduced kernel's Jacobi weight ``w(x) = (M/2 - x)^kappa (M/2 + x)^mu``
        over the relations' centred positions x (+M/2 the newest end: kappa weighs down
        the newest samples, mu the oldest), whole numbers >= 0 with kappa + mu <= 2
        (the window's moments slide no higher degree in O(1)); 1 and 1 by default. With
        ``lag`` at the weight's mean (window (kappa + 1) / (kappa + mu + 2) for a long
        window) the line's slope drops out: the weighted mean of the relations, the
        minimal (q = 0) estimator. Only that kernel has them.
    startup : {"hold", "backward-difference"}, optional
        The algebraic estimator's start, until its window is full (only it has one):
        ``"hold"`` (the default) holds ``starting_output`` for the first ``window`` samples;
        ``"backward-difference"`` lets the backward difference stand in, which is stable
        only for alpha > beta (2 + kp h) / 4 on y' = beta u (n = 1) and can blow up a loop
        the full window holds.
    delay : int
        The loop's input delay the law compensates, in samples (the actuator's and the
        sensor's delays together, as far as they are known): the estimator of F pairs y
        with the input the plant received, ``u_{k-1-delay}``, instead of the one just
        sent. 0 (the default) for none. A rejected measurement holds the output without
        advancing the queue: for d samples after it, F_hat pairs y with an input one
        sample off.
    predict : bool
        With a delay (order 1 only): the error the law acts on is predicted over the
        delay by the ultra-local model, ``y_{k+d} = y_k + h (d F_hat + alpha
        (u_{k-d} + ... + u_{k-1}))``, as a Smith predictor does with a model.
    anti_windup : {"clamp", "back-calculation", "none"}
        Integral anti-windup when the output is limited; ``k_aw`` is the back-calculation
        gain (1/s), by default 1/sample_time: the integral sheds the whole excess of the
        unlimited output over the limit at each sample.
    gain : {"constant", "variational", "external", "rls"}
        Gain adaptation: constant alpha, the paper's variational update (``gamma0``,
        ``Gamma``, ``eps_M``, ``integrator``, ``adapt_every``), alpha estimated online by
        recursive least squares (``"rls"``: ``forgetting``, ``alpha_limits``), or alpha
        passed to every call
        (``simulate_loop`` and ``sweep`` take it as ``alpha=``). With an external alpha
        the constructor's ``alpha`` only shows as ``gamma`` before the first derivative
        exists, and the algebraic estimator weighs its window's past inputs by the
        present alpha.
    gamma0, Gamma, eps_M, integrator
        The variational update (:mod:`mfcontrol.laws.variational_gain`): initial gamma
        (default 1/alpha), its gain, the level eps_M, and ``"first-order"`` (the published
        code's) or ``"second-order"`` (eq. 32 as printed).
    forgetting : float, optional
        The rls gain's forgetting factor, in (0, 1]: 0.99 (the default) weighs the last
        hundred or so samples; 1 remembers them all. The gain fits y^(n)_k = F + alpha v
        (v the input the plant received: exact under the held input) for F and alpha at
        every sample, starting from ``alpha`` with a weak prior, and uses the estimated
        alpha. Without excitation (a constant input) it stops forgetting rather than wind
        up. In closed loop, sensor noise biases the estimate (the input depends on the
        noise through the law), and a step in F (a load step) is partly taken for a
        change of alpha: keep ``alpha_limits`` tight around what you know of the plant's
        gain (``docs/theory.md`` measures it).
    alpha_limits : (low, high), optional
        The rls estimate is clipped to this range; default (alpha / 10, 10 alpha). With a
        backward-difference estimator the constructor checks that an exact estimate,
        alpha = beta (the plant's own gain), lies inside the stable range of
        :func:`mfcontrol.backward_difference_bound` for these kp, kd and sample time.
    adapt_every : int
        Variational gain: gamma moves every m control samples and holds between (the
        multi-rate integrator the paper points to: macro step m h, the force averaged
        over it, Gamma scaled by m, or m^2 for the second-order integrator). 1, the
        default, updates it at each sample.
    setpoint, starting_output : float
        Initial setpoint and the output held until the first derivative exists.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.IPID(alpha=1.0, kp=4.0, ki=1.0, kd=2.0, sample_time=0.01)
    >>> [round(ctrl(y, setpoint=1.0), 4) for y in (0.0, 0.0, 0.01)]
    [0.0, 0.0, -98.0301]

    Order 2 (the i-PID's default) holds the start for two samples; at the third,
    F_hat = y'' - alpha (u_{k-1} + u_{k-2}) / 2 = 0.01 / 0.01**2 = 100, P = 4 (-0.99),
    I = 1 (-0.99 * 0.01), D = 2 (0.01 / 0.01), and u = -(100 - 3.96 - 0.0099 + 2) / 1:

    >>> {k: round(v, 4) for k, v in ctrl.components.items() if k in ("F_hat", "P", "I", "D")}
    {'F_hat': 100.0, 'P': -3.96, 'I': -0.0099, 'D': 2.0}
    """

    _OUT_ROWS = (intelligent.OUT_MIN, intelligent.OUT_MAX)
    _KERNEL = ("intelligent_step", 4)
    _LAW = intelligent

    def __init__(self, alpha: float, kp: float = 0.0, ki: float = 0.0, kd: float = 0.0, *,
                 sample_time: float, order: int = 1,
                 output_limits: tuple[float | None, float | None] = (None, None),
                 input_limits: tuple[float | None, float | None] = (None, None),
                 estimator: str = "backward-difference", window: int | None = None,
                 kernel: str | None = None, lag: float | None = None,
                 kappa: int | None = None, mu: int | None = None,
                 startup: str | None = None, delay: int = 0,
                 predict: bool = False, anti_windup: str = "clamp", k_aw: float | None = None,
                 gain: str = "constant",
                 gamma0: float | None = None, Gamma: float = 5e-8, eps_M: float = 0.1,
                 integrator: str = "first-order", adapt_every: int = 1,
                 forgetting: float | None = None,
                 alpha_limits: tuple[float | None, float | None] | None = None,
                 setpoint: float = 0.0, starting_output: float = 0.0):
        alpha = _number("alpha", alpha, positive=True)
        _choice("order", order, (1, 2))
        _choice("estimator", estimator, tuple(intelligent.ESTIMATORS))
        kernel_applies = estimator == "algebraic" or order == 2
        if kernel is not None:
            _choice("kernel", kernel, tuple(intelligent.KERNELS))
            if not kernel_applies:
                raise ValueError(f"kernel = {shown(kernel)}: the order-1 backward difference "
                                 "has one discretisation (exact under a held input): set "
                                 "estimator='algebraic' or order=2, or remove it")
        if startup is not None:
            _choice("startup", startup, tuple(intelligent.STARTUPS))
            if estimator != "algebraic":
                raise ValueError(f"startup = {shown(startup)}: only the algebraic estimator "
                                 "has a start-up: set estimator='algebraic', or remove it")
        _choice("anti_windup", anti_windup, tuple(intelligent.ANTI_WINDUP))
        _choice("gain", gain, tuple(gain_law.MODES))
        _choice("integrator", integrator, ("first-order", "second-order"))
        lo, hi = _limits(output_limits)
        delay = _samples("delay", delay, intelligent.MAX_DELAY)
        if not isinstance(predict, bool | np.bool_):
            raise ValueError(f"predict = {shown(predict)}: must be True or False")
        if predict and delay == 0:
            raise ValueError("predict = True: only a delay > 0 is predicted over: set "
                             "delay, or remove it")
        problem = intelligent.delay_problem(int(delay), bool(predict), int(order))
        if problem:
            key, allowed = problem
            value = delay if key == "delay" else predict
            raise ValueError(f"{key} = {shown(value)}: {allowed.format(order='order=')}")
        if estimator == "algebraic":
            if (not isinstance(window, int) or isinstance(window, bool) or window < 2
                    or window > estimators.MAX_WINDOW):
                raise ValueError(f"window = {shown(window)}: must be a whole number of samples "
                                 f"from 2 to {estimators.MAX_WINDOW:,} for the algebraic "
                                 "estimator")
            if estimators.parity_problem(order, window, kernel or "held"):
                raise ValueError(f"window = {shown(window)}: {estimators.EVEN_FOR_SIMPSON}")
        elif window is not None:
            raise ValueError(f"window = {shown(window)}: only the algebraic estimator has one")
        if kernel == "delay-reduced" and estimator != "algebraic":
            raise ValueError("kernel = 'delay-reduced': weighs the algebraic estimator's "
                             "window: set estimator='algebraic'")
        if lag is not None:
            lag = _number("lag", lag)
        if kernel == "delay-reduced" and lag is None:
            lag = 0.0  # the default: no delay for F affine in time
        problem = estimators.kernel_problem(order, window or 0, kernel or "held", lag,
                                            kappa, mu)
        if problem:
            key, allowed = problem
            at_fault = {"kernel": kernel, "lag": lag, "kappa": kappa, "mu": mu}[key]
            raise ValueError(f"{key} = {shown(at_fault)}: {allowed}")
        if kernel == "delay-reduced":  # the defaults: the held kernel's weight
            kappa, mu = int(1 if kappa is None else kappa), int(1 if mu is None else mu)
        # the options of a choice not taken would be dropped in silence: refused
        if k_aw is not None and anti_windup != "back-calculation":
            raise ValueError(f"k_aw = {shown(k_aw)}: only back-calculation anti-windup reads it: "
                             "set anti_windup='back-calculation', or remove it")
        if gain != "variational":
            unread: tuple[tuple[str, Any, Any], ...] = (
                ("gamma0", gamma0, None), ("Gamma", Gamma, 5e-8), ("eps_M", eps_M, 0.1),
                ("integrator", integrator, "first-order"), ("adapt_every", adapt_every, 1))
            for name, value, default in unread:
                if value != default:
                    raise ValueError(f"{name} = {shown(value)}: only the variational gain reads "
                                     "it: set gain='variational', or remove it")
        rls = gain == "rls"
        if not rls:
            rls_options: tuple[tuple[str, Any], ...] = (("forgetting", forgetting),
                                                        ("alpha_limits", alpha_limits))
            for name, value in rls_options:
                if value is not None:
                    raise ValueError(f"{name} = {shown(value)}: only the rls gain reads it: "
                                     "set gain='rls', or remove it")
        else:
            forgetting = _number("forgetting", 0.99 if forgetting is None else forgetting)
            a_lo, a_hi = _limits((None, None) if alpha_limits is None else alpha_limits,
                                 "alpha_limits")
            a_lo, a_hi = gain_law.rls_limits(alpha, a_lo, a_hi)
            problem = gain_law.rls_problem(alpha, forgetting, a_lo, a_hi)
            if problem:
                key, allowed = problem
                shown_value = forgetting if key == "forgetting" else [a_lo, a_hi]
                name = "forgetting" if key == "forgetting" else "alpha_limits"
                raise ValueError(f"{name} = {shown(shown_value)}: {allowed}")
            alpha_limits = (a_lo, a_hi)
            from ...analysis.alpha import rls_bound_problem

            problem_text = rls_bound_problem(kp, kd, sample_time, order, estimator, startup,
                                             kernel or "held")
            if problem_text:
                raise ValueError(f"gain = 'rls': {problem_text}")
        params: dict[str, Any] = {
            "alpha": alpha, "kp": _number("kp", kp), "ki": _number("ki", ki),
            "kd": _number("kd", kd), "sample_time": _number("sample_time", sample_time,
                                                            positive=True),
            "order": int(order), "output_limits": [lo, hi], "estimator": estimator,
            "window": window, "kernel": (kernel or "held") if kernel_applies else None,
            "lag": lag, "kappa": kappa, "mu": mu,
            "delay": int(delay),
            "predict": bool(predict),
            "startup": (startup or "hold") if estimator == "algebraic" else None,
            "anti_windup": anti_windup,
            "k_aw": None if k_aw is None else _number("k_aw", k_aw, nonneg=True),
            "gain": gain,
            # None (1/alpha) stays None: a controller rebuilt with another alpha (a sweep,
            # from_snapshot) starts from its own 1/alpha
            "gamma0": _number("gamma0", gamma0, allow_none=True),
            "Gamma": _number("Gamma", Gamma), "eps_M": _number("eps_M", eps_M),
            "integrator": integrator, "adapt_every": _whole("adapt_every", adapt_every),
            "forgetting": forgetting,
            "alpha_limits": None if alpha_limits is None else list(alpha_limits),
            "setpoint": _number("setpoint", setpoint),
            "starting_output": _number("starting_output", starting_output),
        }
        # (the algebraic estimator's window is a whole number: checked above)
        m = window if estimator == "algebraic" and window is not None else 0
        super().__init__(params, intelligent.N_PARAMS, intelligent.n_state(m, int(delay)))
        cp = self._CP[:, 0]
        cp[gain_law.MODE] = gain_law.MODES[gain]
        cp[gain_law.INV_ALPHA] = 1 / alpha
        if gain == "variational":  # its start (default 1/alpha): no other gain reads it,
            # so that a retune of alpha moves no row the law does not retune
            cp[gain_law.GAMMA0] = 1 / alpha if params["gamma0"] is None else params["gamma0"]
        cp[gain_law.GAMMA_RATE] = params["Gamma"]
        cp[gain_law.EPS_M] = params["eps_M"]
        cp[gain_law.ORDER] = 2.0 if integrator == "second-order" else 1.0
        cp[gain_law.EVERY] = params["adapt_every"]
        if rls:
            cp[gain_law.FORGET] = params["forgetting"]
            cp[gain_law.ALPHA_LO], cp[gain_law.ALPHA_HI] = params["alpha_limits"]
        cp[intelligent.N_ORDER] = order
        cp[intelligent.KP] = params["kp"]
        cp[intelligent.KI] = params["ki"]
        cp[intelligent.KD] = params["kd"]
        cp[intelligent.EST] = intelligent.ESTIMATORS[estimator]
        cp[intelligent.M_WIN] = m
        cp[intelligent.KERNEL] = intelligent.KERNELS[params["kernel"] or "held"]
        cp[intelligent.LAG] = 0.0 if lag is None else lag
        if kappa is not None and mu is not None and lag is not None:  # delay-reduced
            cp[intelligent.KAPPA], cp[intelligent.MU] = kappa, mu
            rows = slice(intelligent.JACOBI, intelligent.JACOBI + estimators.N_JACOBI)
            cp[rows] = estimators.jacobi_rows(m, kappa, mu, lag)
        cp[intelligent.STARTUP] = intelligent.STARTUPS[params["startup"] or "hold"]
        cp[intelligent.DELAY] = params["delay"]
        cp[intelligent.PREDICT] = 1.0 if params["predict"] else 0.0
        cp[intelligent.OUT_MIN] = -_INF if lo is None else lo
        cp[intelligent.OUT_MAX] = _INF if hi is None else hi
        cp[intelligent.AW] = intelligent.ANTI_WINDUP[anti_windup]
        # default: remove the whole excess over the limit each sample (tracking)
        cp[intelligent.K_AW] = 1 / params["sample_time"] if k_aw is None else params["k_aw"]
        cp[intelligent.U_INIT] = min(max(params["starting_output"], cp[intelligent.OUT_MIN]),
                                     cp[intelligent.OUT_MAX])
        self._take_input_limits(input_limits)
        self._dt = params["sample_time"]
        self._external = gain == "external"
        self._bind()
        self._check_law(params)  # drops the terms this law does not have from _params
        self._reset_state()

    def _check_law(self, params: dict[str, Any]) -> None:
        """Subclasses restrict which terms exist."""

    @classmethod
    def _migrated(cls, snap: Any) -> Any:
        """An older snapshot as this version's, so that it continues bit for bit: taken
        before the multi-rate gain update, with its rows (:func:`_with_multi_rate_rows`)
        and ``adapt_every=1``; taken before the estimators' kernel and start-up existed,
        with the discretisation and start it ran (``kernel="trapezoid"``,
        ``startup="backward-difference"``, no delay) and the row of u_{k-2} put in (read
        by the held kernel only)."""
        snap = _with_multi_rate_rows(snap)
        if not isinstance(snap, Mapping) or not isinstance(snap.get("params"), Mapping) \
                or not isinstance(snap.get("state"), list):
            return snap
        params = dict(snap["params"])
        params.setdefault("adapt_every", 1)
        params.setdefault("lag", None)  # (before the delay-reduced kernel)
        # (before its Jacobi weights: the kernel had kappa = mu = 1)
        delay_reduced = params.get("kernel") == "delay-reduced"
        params.setdefault("kappa", 1 if delay_reduced else None)
        params.setdefault("mu", 1 if delay_reduced else None)
        params.setdefault("forgetting", None)  # (before the rls gain)
        params.setdefault("alpha_limits", None)
        snap = {**snap, "params": params}
        if "kernel" in params:
            return _with_adaptation_row(_with_rls_rows(snap))
        algebraic = params.get("estimator") == "algebraic"
        params["kernel"] = "trapezoid" if algebraic or params.get("order") == 2 else None
        params["startup"] = "backward-difference" if algebraic else None
        params["delay"], params["predict"] = 0, False
        state = list(snap["state"])
        u1, u2 = intelligent.U1 - _SHIFT_4, intelligent.U2 - _SHIFT_4  # layout 2's
        state.insert(u2, state[u1] if len(state) > u1 else 0.0)
        return _with_adaptation_row(_with_rls_rows({**snap, "params": params,
                                                    "state": state}))

    def __setstate__(self, state: dict[str, Any]) -> None:
        # the state rows its parameters give (layout 4 put a row in after the gain
        # adaptation's and kept the parameter count: only the state rows tell)
        params = state.get("_params") or {}
        window = params.get("window") if params.get("estimator") == "algebraic" else 0
        self._refuse_older_layout(state, intelligent.N_PARAMS, intelligent.n_state(
            window or 0, int(params.get("delay") or 0)))
        super().__setstate__(state)

    def _reset_state(self) -> None:
        live.intelligent_reset(self._CP, self._CS)
        self._last_output = float(self._CP[intelligent.U_INIT, 0])

    def _bumpless_start(self, start: float) -> None:
        # the C export writes these steps out in C (mfcontrol/cexport/source.py), held
        # equal by tests/cexport
        lo, hi = self._CP[intelligent.OUT_MIN, 0], self._CP[intelligent.OUT_MAX, 0]
        self._reset_state()
        start = min(max(start, lo), hi)
        self._CS[intelligent.U1, 0] = start
        self._CS[intelligent.U2, 0] = start
        intelligent.fill_queue(self._CP, self._CS, 0, start)
        self._last_output = start

    def __call__(self, y: float, setpoint: float | None = None, dt: float | None = None,
                 alpha: float | None = None) -> float:
        """One sample: the measurement in, the (limited) control out. ``dt`` (s): the time
        since the previous call, by default ``sample_time``; after a rejected sample the
        law's derivatives span both periods."""
        if dt is None and alpha is None and not self._external and self._plain(y, setpoint):
            return self._output(self._step(self._CP, self._CS, self._backup, y, self._setpoint,
                                           self._dt + self._skipped, 1.0), self._dt)
        dt = self._period(dt)
        if alpha is not None and not self._external:
            raise ValueError(f"alpha = {shown(alpha)}: only a controller built with "
                             "gain='external' takes alpha at each call")
        if self._external:
            if alpha is None:
                raise ValueError("alpha = None: gain='external' needs a finite alpha > 0 "
                                 "at every call")
            alpha = _number("alpha", alpha, positive=True)
        if not self._measurement_ok(y, setpoint, dt):
            return self._last_output
        u = self._step(self._CP, self._CS, self._backup, float(y), self._setpoint,
                       dt + self._skipped, 1.0 if alpha is None else float(alpha))
        return self._output(u, dt)

    @property
    def components(self) -> dict[str, float]:
        """The terms of the last output: F_hat, feed-forward y*^(n), P, I, D (as they enter
        the bracket), the output before limiting, and gamma = 1/alpha used."""
        s = self._CS[:, 0]
        return {**{name: float(s[row]) for name, row in intelligent.COMPONENTS},
                "unlimited": float(s[intelligent.C_UNLIM]), "gamma": float(s[gain_law.G1])}

    @property
    def gamma(self) -> float:
        """The gain 1/alpha used at the last sample."""
        return float(self._CS[gain_law.G1, 0])

    @property
    def adaptation_error(self) -> float:
        """The variational gain's adaptation error since the reset: ``sum |e_dot - eps_M|
        h`` over the adapting samples, the integral of the force that drives gamma (zero
        where the online optimisation is stationary; :mod:`mfcontrol.laws.variational_gain`),
        in y's unit. NaN for another gain, where it does not apply."""
        return _adaptation_error(self._CP, self._CS)

    def linear_filter(self, gamma: float | None = None) -> filters.LinearFilter:
        """The law as the linear filter it is within its output limits:
        ``A(q) u = B_y(q) y + B_r(q) r`` (:mod:`mfcontrol.analysis.filters`), at its
        sample time; ``.transfer_functions()`` gives u's transfer functions from y and r.

        ``gamma``: the gain to hold, required for a variational or external gain
        (default 1/alpha for a constant gain).

        Examples
        --------
        With backward differences the i-P is a PI in velocity form:

        >>> import mfcontrol
        >>> f = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=0.1).linear_filter()
        >>> f.a.tolist(), f.b_y.tolist(), f.b_r.tolist()
        ([1.0, -1.0], [-7.5, 5.0], [7.5, -5.0])
        """
        return filters.intelligent_filter(self._CP[:, 0], self.sample_time, gamma)


class IP(IntelligentController):
    """Intelligent proportional controller (i-P), ``u = -(F_hat - y*' + kp e)/alpha``.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.IP(alpha=1.0, kp=10.0, sample_time=0.01, output_limits=(-5, 5))
    >>> y, out = 0.0, []
    >>> for _ in range(3):
    ...     u = ctrl(y, setpoint=1.0)
    ...     y += 0.01 * (-y + u)             # the plant y' = -y + u, Euler
    ...     out.append(round(u, 3))
    >>> out
    [0.0, 5.0, 5.0]
    """

    _drop: tuple[str, ...] = ("ki", "kd")

    def __init__(self, alpha: float, kp: float, **options: Any):
        self._refuse_terms(options)
        super().__init__(alpha, kp, 0.0, 0.0, **options)

    def _check_law(self, params):
        for key in self._drop:
            params.pop(key)

    @classmethod
    def _refuse_terms(cls, options: Mapping[str, Any]) -> None:
        """A gain of a term this law does not have (ki for an i-P) is refused by name:
        Python's own error said 'got multiple values for argument'."""
        for key in cls._drop:
            if key in options:
                term, laws = {"ki": ("integral", "IPI and IPID"),
                              "kd": ("derivative", "IPD and IPID")}[key]
                raise TypeError(f"{cls.__name__}() got an unexpected keyword argument "
                                f"{key!r}: an {_LAW_NAMES[cls.__name__]} has no {term} term "
                                f"({laws} have one)")


class IPI(IP):
    """Intelligent PI controller: the i-P plus ``ki`` times the integral of the error.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.IPI(alpha=1.0, kp=10.0, ki=5.0, sample_time=0.01,
    ...                      output_limits=(-5, 5))
    >>> y, out = 0.0, []
    >>> for _ in range(4):
    ...     u = ctrl(y, setpoint=1.0)
    ...     y += 0.01 * (-y + u)             # the plant y' = -y + u, Euler
    ...     out.append(round(u, 3))
    >>> out                                  # the start held, then the limit
    [0.0, 5.0, 5.0, 5.0]
    """

    _drop = ("kd",)

    def __init__(self, alpha: float, kp: float, ki: float, **options: Any):
        self._refuse_terms(options)
        IntelligentController.__init__(self, alpha, kp, ki, 0.0, **options)


class IPD(IP):
    """Intelligent PD controller, ultra-local model of order 2 by default.

    Examples
    --------
    A double integrator y'' = u under the held output (stepped exactly): order 2 holds the
    start for two samples (y'' needs three measurements), then F_hat = y'' - alpha
    (u_{k-1} + u_{k-2}) / 2 is zero (the held kernel is exact) and u = kp (1 - y) - kd y'.

    >>> import mfcontrol
    >>> ctrl = mfcontrol.IPD(alpha=1.0, kp=25.0, kd=10.0, sample_time=0.01)
    >>> y = v = 0.0
    >>> out = []
    >>> for _ in range(4):
    ...     u = ctrl(y, setpoint=1.0)
    ...     y += 0.01 * v + 0.5 * 0.01**2 * u
    ...     v += 0.01 * u
    ...     out.append(round(u, 3))
    >>> out
    [0.0, 0.0, 25.0, 23.719]
    """

    _drop = ("ki",)

    def __init__(self, alpha: float, kp: float, kd: float, *, order: int = 2, **options: Any):
        self._refuse_terms(options)
        IntelligentController.__init__(self, alpha, kp, 0.0, kd, order=order, **options)


class IPID(IP):
    """Intelligent PID controller, ultra-local model of order 2 by default.

    Examples
    --------
    A measurement held at 0 under a setpoint of 1: order 2 holds the start for two
    samples; at the third, F_hat = y'' - alpha (u_{k-1} + u_{k-2}) / 2 = 0 and
    u = -(kp e + ki int(e) + kd e') / alpha with e = -1, int(e) = -0.01 and e' = 0:

    >>> import mfcontrol
    >>> ctrl = mfcontrol.IPID(alpha=1.0, kp=25.0, ki=5.0, kd=10.0, sample_time=0.01)
    >>> [round(ctrl(y, setpoint=1.0), 3) for y in (0.0, 0.0, 0.0)]
    [0.0, 0.0, 25.05]
    """

    _drop = ()

    def __init__(self, alpha: float, kp: float, ki: float, kd: float, *, order: int = 2,
                 **options: Any):
        IntelligentController.__init__(self, alpha, kp, ki, kd, order=order, **options)


#: each positional law's name in words
_LAW_NAMES = {"IP": "i-P", "IPI": "i-PI", "IPD": "i-PD", "IPID": "i-PID"}


def _show_options(cls: type[IntelligentController]) -> None:
    """Give an i-P .. i-PID class its full signature and the options' documentation, which
    live once, on IntelligentController: ``help(mfcontrol.IP)`` showed ``IP(alpha, kp,
    **options)`` and no option."""
    own = inspect.signature(cls.__init__, eval_str=True).parameters
    shown = [p for name, p in own.items() if name != "self" and p.kind is not p.VAR_KEYWORD]
    taken = {p.name for p in shown}
    shown += [p for name, p in inspect.signature(IntelligentController.__init__, eval_str=True)
              .parameters.items() if p.kind is p.KEYWORD_ONLY and name not in taken]
    # inspect.signature reads a class's __signature__, which typeshed does not declare
    cast(Any, cls).__signature__ = inspect.Signature(shown)
    parent = inspect.cleandoc(IntelligentController.__doc__ or "")
    options = parent[parent.index("Parameters\n"):parent.index("Examples\n")].rstrip()
    doc = inspect.cleandoc(cls.__doc__ or "")
    head, sep, examples = doc.partition("Examples\n")
    cls.__doc__ = f"{head.rstrip()}\n\n{options}\n\n{sep}{examples}".rstrip() + "\n"


for _cls in (IP, IPI, IPD, IPID):
    _show_options(_cls)


class RecursiveIP(_Controller):
    """The paper's recursive i-P (eq. 8) or its variational form (eq. 33), live.

    Takes the configuration keys of ``[controller]`` in a case file (see the user
    guide's option table), e.g. ``RecursiveIP(alpha=10, kp=2, law="variational", gamma0=1)``.
    Returns the applied output ``clip(output_gain * u_k)``; the raw u_k, the gain and gamma
    are in :attr:`components`. Samples are taken to be equally spaced (the law's
    derivative scale is ``deriv_scale``, not the sample time). ``sample_time`` (s) is the
    period of a simulated loop (``simulate_loop``'s default ``h``) and sets
    back-calculation's share k_aw h and the time step of :attr:`adaptation_error`; without
    it, both use the paper's 1e-6 s and ``simulate_loop`` needs ``h``.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0)
    >>> ctrl(0.0, setpoint=0.0), ctrl(2.0e-5, setpoint=1e-3)
    (0.001, 0.001)
    >>> round(ctrl.components["u_raw"], 6)  # 1 - 0.1 (0.02 - 1) + 2 (1e-3 - 0), published
    1.1
    """

    _OUT_ROWS = (recursive_ip.OUT_MIN, recursive_ip.OUT_MAX)
    _KERNEL = ("recursive_step", 2)
    _LAW = recursive_ip

    def __init__(self, alpha: float = 10.0, kp: float = 2.0, *, setpoint: float = 0.0,
                 sample_time: float | None = None,
                 input_limits: tuple[float | None, float | None] = (None, None),
                 **controller_keys: Any):
        from ...config.resolve import resolve
        from ...errors import ConfigError

        keys = {"controller.alpha": alpha, "controller.kp": kp}
        for name, value in controller_keys.items():
            keys[f"controller.{name}"] = value
        try:
            cfg = resolve(keys)
        except ConfigError as exc:
            if exc.key.startswith("controller.") and "unknown key" in str(exc):
                raise TypeError(f"RecursiveIP() got an unexpected keyword argument "
                                f"{exc.key.removeprefix('controller.')!r}") from None
            raise ValueError(str(exc).removeprefix("controller.")) from None
        if cfg["controller.law"] not in ("ip", "variational"):
            raise ValueError(f"law = {cfg['controller.law']!r}: RecursiveIP is the paper's law, "
                             "'ip' or 'variational' (the positional laws are IP, IPI, IPD, "
                             "IPID)")
        # a key its law would not read (gamma0 under the standard law, an estimator) is
        # refused as a case's is, in the keyword arguments' names
        from ...config.reads import CHOICES, refuse_unread
        from ...config.resolve import keys_read

        def reads(c) -> set[str]:  # (the period only scales k_aw)
            return keys_read(recursive_law_column, c, 1.0)

        try:
            refuse_unread(cfg, {f"controller.{k}" for k in controller_keys}, reads,
                          among=[k for k in CHOICES if k.startswith("controller.")],
                          name=lambda k: k.removeprefix("controller."), by="this law")
        except ConfigError as exc:
            raise ValueError(str(exc)) from None
        # the values as resolved (plain Python numbers): the snapshot is JSON
        params = {"alpha": cfg["controller.alpha"], "kp": cfg["controller.kp"],
                  "setpoint": _number("setpoint", setpoint),
                  **{name: cfg[f"controller.{name}"] for name in controller_keys}}
        if sample_time is not None:
            params["sample_time"] = _number("sample_time", sample_time, positive=True)
        self.sample_time: float | None = params.get("sample_time")
        super().__init__(params, recursive_ip.N_PARAMS, recursive_ip.N_STATE)
        self._take_input_limits(input_limits)
        self._CP[:, 0] = recursive_law_column(cfg, self.sample_time)[:, 0]
        self._u0 = float(self._CP[recursive_ip.U0, 0])  # the start as built
        self._bind()
        self._reset_state()

    def _adopt(self, new: Self) -> None:
        self._u0 = new._u0  # its start as built

    def _reset_state(self) -> None:
        # a bumpless start rewrites the law's u0 (its first raw output): a reset undoes it
        self._CP[recursive_ip.U0, 0] = self._u0
        live.recursive_reset(self._CP, self._CS)
        # held while no sample is taken: 0 within the output limits (as every output)
        self._last_output = self._limited(0.0)
        self._components: tuple[float, ...] = (math.nan, math.nan, math.nan)  # u_raw, gain, gamma

    def _bumpless_start(self, start: float) -> None:
        # continue from the raw control that produced the manual output
        raw = start / float(self._CP[recursive_ip.OUT_GAIN, 0])
        if not math.isfinite(raw):  # checked before anything changes
            raise ValueError(f"last_output = {shown(start)}: the raw control it needs, last_output "
                             f"/ output_gain = {raw!r}, is not a finite number")
        self._reset_state()
        self._CP[recursive_ip.U0, 0] = raw
        self._last_output = start

    @classmethod
    def _migrated(cls, snap: Any) -> Any:
        """A snapshot taken before the multi-rate gain update or the adaptation error,
        with their rows."""
        return _with_adaptation_row(_with_multi_rate_rows(snap))

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._refuse_older_layout(state, recursive_ip.N_PARAMS, recursive_ip.N_STATE)
        super().__setstate__(state)

    def _snapshot_extra(self) -> dict[str, Any]:
        # the first raw output after a bumpless start lives in the parameter column
        return {"start": float(self._CP[recursive_ip.U0, 0])}

    def _checked_extra(self, snap: Mapping[str, Any]) -> float:
        return _number("snapshot start", snap.get("start", self._u0))

    def _restore_extra(self, start: float) -> None:
        self._CP[recursive_ip.U0, 0] = start

    def __call__(self, y: float, setpoint: float | None = None) -> float:
        if not self._plain(y, setpoint) and not self._measurement_ok(y, setpoint):
            return self._last_output
        u, applied, g, gamma = self._step(self._CP, self._CS, self._backup, float(y),
                                          self._setpoint)
        if applied != applied:
            self._overflowed(0.0)  # (equally spaced samples: no period to span)
            return self._last_output
        self._components = (u, g, gamma)  # the dict is built when asked for
        self._last_output = applied
        self._overflows = 0
        return applied

    @property
    def components(self) -> dict[str, float]:
        return dict(zip(("u_raw", "gain", "gamma"), self._components, strict=True))

    @property
    def adaptation_error(self) -> float:
        """As :attr:`IntelligentController.adaptation_error`: the variational gain's
        adaptation error since the reset (NaN for a constant gain)."""
        return _adaptation_error(self._CP, self._CS)

    def linear_filter(self, gamma: float | None = None) -> filters.LinearFilter:
        """The law's applied output as the linear filter it is within its limits
        (:mod:`mfcontrol.analysis.filters`), at :attr:`sample_time` (required).

        ``gamma``: the gain to hold, required when the variational law's gamma is the
        gain; the rate term is then zero.

        Examples
        --------
        The standard law (alpha 10, kp 2; the published derivative scale 1e-3, output
        gain 1/2000 and y_{k-1} in the proportional term):

        >>> import mfcontrol
        >>> f = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0, sample_time=1e-6).linear_filter()
        >>> f.a.tolist(), [round(float(c), 6) for c in f.b_y]
        ([1.0, -1.0], [-0.05, 0.049])
        """
        if self.sample_time is None:
            raise ValueError("sample_time = None: the filter needs the period of the loop "
                             "it runs in; build the controller with sample_time")
        return filters.recursive_filter(self._CP[:, 0], self.sample_time, gamma)

#: the case keys the recursive law reads (tests/api/model/test_controllers.py holds this equal
#: to what api.params.recursive_law_column reads), documented from config/options.py
RECURSIVE_KEYS = ("controller.law", "controller.alpha", "controller.kp",
                  "controller.anti_windup", "controller.k_aw", "controller.gamma0",
                  "controller.Gamma", "controller.eps_M", "controller.k_gamma",
                  "controller.adapt_every", "controller.integrator", "controller.rate_term",
                  "controller.rate_sign",
                  "controller.gain", "controller.deriv_scale", "controller.output_gain",
                  "controller.duty_min", "controller.duty_max", "controller.p_sample",
                  "controller.p_error", "controller.u0")
RecursiveIP.__doc__ = options.with_parameters(
    RecursiveIP.__doc__, options.numpydoc_parameters(RECURSIVE_KEYS) + """
setpoint : float
    Initial setpoint.
sample_time : float, optional
    Period of a simulated loop (s), see above.
input_limits : (low, high)
    The measurement's valid range, None for none: a sample outside is rejected as a NaN
    is (see :class:`IntelligentController`).""")

class _TermsLaw(_Sampled):
    """A sampled law called with (y, setpoint, dt) whose memory records the terms of its
    last output (the PID, the ADRC): the call, the restarts and ``components`` (from its
    law's COMPONENTS and C_UNLIM rows), once."""

    def _restart(self, start: float) -> None:  # pragma: no cover
        """Reset the law's memory; ``start`` (NaN: none) is its first output."""
        raise NotImplementedError

    def _reset_state(self) -> None:
        self._restart(math.nan)
        # held while no sample is taken: 0 within the output limits (as every output)
        self._last_output = self._limited(0.0)

    def _bumpless_start(self, start: float) -> None:
        start = self._limited(start)
        self._restart(start)
        self._last_output = start

    def __call__(self, y: float, setpoint: float | None = None,
                 dt: float | None = None) -> float:
        """One sample: the measurement in, the (limited) control out. ``dt`` (s): the time
        since the previous call, by default ``sample_time``; after a rejected sample the
        law spans both periods (the PID's integral and derivative, the ADRC's
        prediction)."""
        if dt is None and self._plain(y, setpoint):
            return self._output(self._step(self._CP, self._CS, self._backup, y, self._setpoint,
                                           self._dt + self._skipped), self._dt)
        dt = self._period(dt)
        if not self._measurement_ok(y, setpoint, dt):
            return self._last_output
        u = self._step(self._CP, self._CS, self._backup, float(y), self._setpoint,
                       dt + self._skipped)
        return self._output(u, dt)

    @property
    def components(self) -> dict[str, float]:
        """The terms of the last output by name, and the output before limiting."""
        s = self._CS[:, 0]
        return {**{name: float(s[row]) for name, row in self._LAW.COMPONENTS},
                "unlimited": float(s[self._LAW.C_UNLIM])}


class PID(_TermsLaw):
    """The discrete PID of Astrom and Hagglund, the baseline of every comparison
    (:mod:`mfcontrol.laws.pid`): ``P = kp (b r - y)``, a derivative on the measurement
    filtered with time constant Td / N, back-calculation anti-windup with tracking time
    Tt (``Ti = kp / ki``, ``Td = kd / kp``). Gains act on ``r - y``: positive for a plant
    whose output rises with its input, as in simple-pid.

    Parameters
    ----------
    kp, ki, kd : float
        Proportional, integral (1/s) and derivative (s) gains; kd needs kp of its sign,
        ki too unless ``Tt`` is given.
    sample_time : float
        Sample period h (s); a call may pass another ``dt``.
    N : float
        Derivative filter: time constant Td / N (default 10).
    b : float
        Setpoint weight of the proportional term (default 1).
    c : float
        Setpoint weight of the derivative (default 0: the derivative of the measurement
        alone, no kick from a setpoint step).
    Tf : float
        Time constant (s) of Astrom and Hagglund's second-order measurement filter
        ``1 / (1 + s Tf + (s Tf)^2 / 2)`` on y, which every term then sees (default 0:
        none); they suggest Tf about Td / N, or Ti / N for a PI.
    Tt : float, optional
        Tracking time (s); default sqrt(Ti Td) with an integral and a derivative, else Ti.
    output_limits : (low, high)
        Output limits, None for none.
    input_limits : (low, high)
        The measurement's valid range, None for none: a sample outside is rejected as a NaN
        is (see :class:`IntelligentController`).
    setpoint : float
        Initial setpoint.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1, output_limits=(0, 10))
    >>> ctrl(0.0, setpoint=1.0), round(ctrl(0.5, setpoint=1.0), 6)
    (2.0, 1.1)

    The first output is P = 2 (1 - 0); the integral then holds 1 * 0.1 * 1 = 0.1, and the
    second output is 2 (1 - 0.5) + 0.1.
    """

    _OUT_ROWS = (pid.OUT_MIN, pid.OUT_MAX)
    _KERNEL = ("pid_step", 3)
    _LAW = pid

    def __init__(self, kp: float, ki: float = 0.0, kd: float = 0.0, *, sample_time: float,
                 N: float = 10.0, b: float = 1.0, c: float = 0.0, Tf: float = 0.0,
                 Tt: float | None = None,
                 output_limits: tuple[float | None, float | None] = (None, None),
                 input_limits: tuple[float | None, float | None] = (None, None),
                 setpoint: float = 0.0):
        from ...config.resolve import _check_pid
        from ...errors import ConfigError

        lo, hi = _limits(output_limits)
        params: dict[str, Any] = {
            "kp": _number("kp", kp), "ki": _number("ki", ki), "kd": _number("kd", kd),
            "sample_time": _number("sample_time", sample_time, positive=True),
            "N": _number("N", N, positive=True), "b": _number("b", b),
            "Tt": _number("Tt", Tt, positive=True, allow_none=True),
            "output_limits": [lo, hi], "setpoint": _number("setpoint", setpoint)}
        # the measurement filter and the derivative's setpoint weight join the parameters
        # only when set, so that snapshots of PIDs without them stay as they were
        c, Tf = _number("c", c), _number("Tf", Tf, nonneg=True)
        if c != 0.0:
            params["c"] = c
        if Tf != 0.0:
            params["Tf"] = Tf
        try:
            _check_pid(params["kp"], params["ki"], params["kd"], params["Tt"])
        except ConfigError as exc:
            raise ValueError(str(exc)) from None
        super().__init__(params, pid.N_PARAMS, pid.N_STATE)
        self._take_input_limits(input_limits)
        cp = self._CP[:, 0]
        cp[pid.KP], cp[pid.KI], cp[pid.KD] = params["kp"], params["ki"], params["kd"]
        cp[pid.N], cp[pid.B] = params["N"], params["b"]
        cp[pid.C], cp[pid.TF] = c, Tf
        cp[pid.TT] = pid.tracking_time(params["kp"], params["ki"], params["kd"], params["Tt"])
        cp[pid.OUT_MIN] = -_INF if lo is None else lo
        cp[pid.OUT_MAX] = _INF if hi is None else hi
        self._dt = params["sample_time"]
        self._bind()
        self._reset_state()

    def _restart(self, start: float) -> None:
        live.pid_reset(self._CS, start)

    @classmethod
    def _migrated(cls, snap: Any) -> Any:
        """A snapshot taken before the measurement filter and the derivative's setpoint
        weight, with their state rows put in at the end as zeros: its PID has neither
        (Tf = c = 0), and reads none of them, so it continues bit for bit."""
        if isinstance(snap, Mapping) and isinstance(snap.get("state"), list) \
                and len(snap["state"]) == pid.YF:
            return {**snap, "state": [*snap["state"], *[0.0] * (pid.N_STATE - pid.YF)]}
        return snap

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._refuse_older_layout(state, pid.N_PARAMS, pid.N_STATE)
        super().__setstate__(state)

    @property
    def components(self) -> dict[str, float]:
        """The terms of the last output: P, I, D and the output before limiting."""
        return super().components

    def linear_filter(self) -> filters.LinearFilter:
        """The PID as the linear filter it is within its output limits:
        ``A(q) u = B_y(q) y + B_r(q) r`` (:mod:`mfcontrol.analysis.filters`), at its
        sample time; ``.transfer_functions()`` gives u's transfer functions from y and r.

        Examples
        --------
        >>> import mfcontrol
        >>> f = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1).linear_filter()
        >>> f.a.tolist(), f.b_y.tolist(), f.b_r.tolist()
        ([1.0, -1.0], [-2.0, 1.9], [2.0, -1.9])
        """
        return filters.pid_filter(self._CP[:, 0], self.sample_time)


class ADRC(_TermsLaw):
    """Linear active disturbance rejection control of order 1 or 2
    (:mod:`mfcontrol.laws.adrc`): an extended state observer estimates the plant's output,
    its derivative (order 2) and the "total disturbance" f of ``y^(n) = f + b0 u`` (the
    counterpart of the intelligent controllers' F, b0 of their alpha); the law cancels f
    and places the loop's n poles at -wc. The observer is the zero-order-hold discretised
    ESO run as a current observer (the sample's measurement corrects it before the output
    is computed), its n + 1 poles at -wo, fed the applied (limited) output.

    Parameters
    ----------
    order : {1, 2}
        The order n of the model y^(n) = f + b0 u.
    b0 : float
        The plant's input gain, roughly (nonzero, of the plant's sign: positive for a plant
        whose output rises with its input).
    wc : float
        The controller's bandwidth (rad/s): kp = wc (n = 1); kp = wc^2, kd = 2 wc (n = 2).
    wo : float
        The observer's bandwidth (rad/s); commonly 3 to 10 times wc.
    sample_time : float
        Sample period h (s); a call may pass another ``dt``.
    output_limits : (low, high)
        Output limits, None for none.
    delay : int
        The loop's input delay (samples) the observer is told of: it is fed the input the
        plant receives, u_{k-d} (default 0).
    input_limits : (low, high)
        The measurement's valid range, None for none: a sample outside is rejected as a NaN
        is (see :class:`IntelligentController`).
    setpoint : float
        Initial setpoint.

    Examples
    --------
    >>> import mfcontrol
    >>> ctrl = mfcontrol.ADRC(order=1, b0=2.0, wc=4.0, wo=20.0, sample_time=0.01,
    ...                       output_limits=(-5, 5))
    >>> ctrl(0.0, setpoint=1.0)
    2.0

    At rest on the first measurement the disturbance estimate is 0: the output is
    ``wc (r - y) / b0 = 4 (1 - 0) / 2``. On a plant ``y' = b0 u + f`` the loop follows
    the setpoint as ``1 / (1 + s / wc)`` once the observer has found f.
    """

    _OUT_ROWS = (adrc.OUT_MIN, adrc.OUT_MAX)
    _KERNEL = ("adrc_step", 3)
    _LAW = adrc

    def __init__(self, order: int = 1, b0: float = 1.0, wc: float = 1.0, wo: float = 10.0,
                 *, sample_time: float,
                 output_limits: tuple[float | None, float | None] = (None, None),
                 delay: int = 0,
                 input_limits: tuple[float | None, float | None] = (None, None),
                 setpoint: float = 0.0):
        lo, hi = _limits(output_limits)
        params: dict[str, Any] = {
            "order": _choice("order", order, (1, 2)), "b0": _number("b0", b0),
            "wc": _number("wc", wc, positive=True), "wo": _number("wo", wo, positive=True),
            "sample_time": _number("sample_time", sample_time, positive=True),
            "output_limits": [lo, hi], "delay": _samples("delay", delay, adrc.MAX_DELAY),
            "setpoint": _number("setpoint", setpoint)}
        found = adrc.problem(params["b0"], params["delay"])
        if found:
            key, allowed = found
            raise ValueError(f"{key} = {params[key]!r}: {allowed}")
        super().__init__(params, adrc.N_PARAMS, adrc.n_state(params["delay"]))
        self._take_input_limits(input_limits)
        cp = self._CP[:, 0]
        cp[adrc.ORDER], cp[adrc.B0] = params["order"], params["b0"]
        cp[adrc.WC], cp[adrc.WO] = params["wc"], params["wo"]
        cp[adrc.DELAY] = params["delay"]
        cp[adrc.OUT_MIN] = -_INF if lo is None else lo
        cp[adrc.OUT_MAX] = _INF if hi is None else hi
        self._dt = params["sample_time"]
        self._bind()
        self._reset_state()

    def _restart(self, start: float) -> None:
        live.adrc_reset(self._CP, self._CS, start)

    def __setstate__(self, state: dict[str, Any]) -> None:
        delay = state.get("_params", {}).get("delay", 0)
        self._refuse_older_layout(state, adrc.N_PARAMS, adrc.n_state(delay))
        super().__setstate__(state)

    @property
    def components(self) -> dict[str, float]:
        """The last output's terms: P = kp (r - y_hat) / b0, D = -kd y_hat' / b0 (order 2),
        F_hat (the total disturbance's estimate f; its term is -f / b0) and the output
        before limiting."""
        return super().components

    @property
    def estimate(self) -> np.ndarray:
        """The observer's present estimate of (y, .., y^(n-1), f), the prediction for the
        next sample (y_hat, y_hat' for order 2, f_hat)."""
        rows = (adrc.Z1, adrc.Z2) if self._params["order"] == 1 else (adrc.Z1, adrc.Z2,
                                                                         adrc.Z3)
        return np.array([self._CS[r, 0] for r in rows])

    def linear_filter(self) -> filters.LinearFilter:
        """The ADRC as the linear filter it is within its output limits:
        ``A(q) u = B_y(q) y + B_r(q) r`` (:mod:`mfcontrol.analysis.filters`), at its
        sample time; ``.transfer_functions()`` gives u's transfer functions from y and r
        (the two-degree-of-freedom form of the discrete ADRC).

        Examples
        --------
        >>> import mfcontrol
        >>> f = mfcontrol.ADRC(order=1, b0=1.0, wc=2.0, wo=10.0, sample_time=0.1
        ...                    ).linear_filter()
        >>> f.order, abs(float(sum(f.a))) < 1e-12   # an integrator: A(1) = 0
        (2, True)
        """
        return filters.adrc_filter(self._CP[:, 0], self.sample_time)
