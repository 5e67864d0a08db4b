"""A closed loop of any plant object and any live controller, driven sample by sample.

This is the general simulator: the plant is a :class:`mfcontrol.plants.models.Plant`
(built-in converters, a first-order plant, an LTI model, python-control systems, or your
own ODE), the controller one of :mod:`mfcontrol.controller`. Each sample: measure
``y_k`` (before the plant step), compute ``u_k = controller(y_k, setpoint=r_k)``, apply
scheduled parameter changes due at ``t_k``, advance the plant over [t_k, t_k + h] with
``u_k`` held. The compiled engine (:mod:`mfcontrol.engine`) is the fast path for the
built-in cases; this loop trades speed for generality.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import metrics as _metrics
from ._version import __version__
from .engine import kernel
from .result import _Trajectory

Reference = float | Callable[[float], float] | Sequence[float] | np.ndarray


@dataclass(frozen=True)
class Change:
    """At the first sample with t_k >= ``time``, set plant parameter ``name`` to ``value``
    (or add ``value`` to it when ``add`` is true)."""

    time: float
    name: str
    value: float
    add: bool = False


@dataclass
class LoopResult(_Trajectory):
    """A simulated loop: time, signals (``y_ref``, ``y``, ``u`` and the controller's
    components), plant states, metrics (as in :mod:`mfcontrol.metrics`); ``to_pandas``,
    ``to_csv``, ``metrics_json`` and ``plot`` as for :class:`mfcontrol.Result`."""

    time: np.ndarray
    signals: dict[str, np.ndarray]
    states: dict[str, np.ndarray]
    metrics: dict[str, Any]
    changes: tuple[Change, ...] = ()
    version: str = __version__
    name: str = field(default="")

    def plot(self, path: str | Path | None = None, title: str | None = None,
             output_label: str = "output y", input_label: str = "control u"):
        from .plotting import plot_loop

        return plot_loop(self, path=path, title=title, output_label=output_label,
                         input_label=input_label)


def _reference(reference: Reference, t: np.ndarray) -> np.ndarray:
    if callable(reference):
        return np.array([float(reference(tk)) for tk in t])
    arr = np.asarray(reference, dtype=float)
    if arr.ndim == 0:
        return np.full(t.size, float(arr))
    if arr.shape != t.shape:
        raise ValueError(f"reference has {arr.size} samples, the time grid {t.size}")
    return arr


def simulate_loop(plant, controller, reference: Reference = 0.0, *, t_end: float,
                  h: float | None = None, changes: Sequence[Change] = (),
                  settle_time: float = 0.0, final_window: float = 0.2,
                  stable_tol: float = 0.1, diverge_above: float = 1e12,
                  name: str = "") -> LoopResult:
    """Simulate ``controller`` on ``plant`` tracking ``reference`` for ``t_end`` seconds.

    Parameters
    ----------
    plant : Plant or control.LTI
        Any :class:`mfcontrol.plants.models.Plant`, or a continuous-time python-control
        ``StateSpace`` / ``TransferFunction`` (converted with ``LTI.from_control``).
    controller : callable
        A live controller (``u = controller(y, setpoint=r)``), e.g. :class:`mfcontrol.IP`.
    reference : float, callable or array
        Constant, a function of t, or one value per sample.
    t_end, h : float
        Horizon and sample period; ``h`` defaults to the controller's ``sample_time``.
    changes : sequence of Change
        Scheduled plant parameter changes.

    Returns
    -------
    LoopResult

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.plants.models import FirstOrder
    >>> ctrl = mfcontrol.IP(alpha=1.0, kp=20.0, sample_time=1e-3)
    >>> res = mfcontrol.simulate_loop(FirstOrder(a=-1.0, b=1.0), ctrl, 1.0, t_end=0.5)
    >>> bool(res.metrics["stable"]), round(float(res.signals["y"][-1]), 4)
    (True, 1.0)
    """
    if type(plant).__module__.startswith("control."):  # a python-control system
        from .plants.models import LTI

        plant = LTI.from_control(plant)
    h = float(controller.sample_time if h is None else h)
    if not (h > 0 and math.isfinite(h)):
        raise ValueError(f"h = {h!r}: must be a finite number > 0")
    if not (t_end > 0 and math.isfinite(t_end)):
        raise ValueError(f"t_end = {t_end!r}: must be a finite number > 0")
    n = round(t_end / h)
    if n < 2 or abs(n * h - t_end) > 1e-9 * t_end:
        raise ValueError(f"t_end = {t_end!r}: must be a whole number (>= 2) of h = {h!r}")
    pending = sorted(changes, key=lambda c: c.time)
    original = dict(plant.params)
    try:
        t, r, y, u, X, comps = _run(plant, controller, reference, pending, t_end, h, n,
                                    diverge_above)
    finally:
        # a schedule acts on this run only: the plant object is left as it was given
        for key in {c.name for c in changes}:
            plant.set_param(key, original[key])
    return _finish(plant, t, r, y, u, X, comps, h, t_end, changes, settle_time,
                   final_window, stable_tol, diverge_above, name)


def _run(plant, controller, reference, pending, t_end, h, n, diverge_above):
    t = (np.arange(n) * t_end) / n
    r = _reference(reference, t)
    x = np.array(plant.x0, dtype=float, copy=True)
    y = np.full(n, np.nan)
    u = np.full(n, np.nan)
    X = np.full((n, x.size), np.nan)
    comps: dict[str, np.ndarray] = {}
    has_components = hasattr(controller, "components")
    for k in range(n):
        yk = plant.output(x)
        if not (math.isfinite(yk) and abs(yk) <= diverge_above):
            y[k] = yk
            break
        uk = controller(yk, setpoint=r[k])
        y[k], u[k], X[k] = yk, uk, x
        if has_components:
            for key, value in controller.components.items():
                comps.setdefault(key, np.full(n, np.nan))[k] = value
        while pending and t[k] >= pending[0].time:
            c = pending.pop(0)
            plant.set_param(c.name, plant.params[c.name] + c.value if c.add else c.value)
        x = plant.step(t[k], x, uk, h)
    return t, r, y, u, X, comps


def _finish(plant, t, r, y, u, X, comps, h, t_end, changes, settle_time, final_window,
            stable_tol, diverge_above, name):
    n = t.size
    gamma = comps.get("gamma", np.full(n, np.nan))
    S = np.zeros(kernel.N_SETTINGS)
    S[kernel.S_SETTLE] = settle_time
    S[kernel.S_FINAL_START] = t_end * (1 - final_window)
    S[kernel.S_DIVERGE_ABOVE] = diverge_above
    M = np.zeros((kernel.N_METRICS, 1))
    kernel.trajectory_metrics(t, h, y, r, u, u, gamma, S, M)
    met = _metrics.from_kernel(M, 0, stable_tol)
    k_end = met["n_samples"]
    signals = {"y_ref": r[:k_end], "y": y[:k_end], "u": u[:k_end],
               **{key: v[:k_end] for key, v in comps.items()}}
    states = {s: X[:k_end, i] for i, s in enumerate(plant.state_names)}
    return LoopResult(time=t[:k_end], signals=signals, states=states, metrics=met,
                      changes=tuple(changes), name=name)
