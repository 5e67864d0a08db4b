"""Figures in the paper's layout: output and reference on top, duty cycle below; gamma on
its own axes; sweeps as gamma(t) and |y - y*| (log axis) per member.

Uses matplotlib's object API (no pyplot), so it works headless and never changes the
caller's backend.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from .result import Result, SweepResult

_OUTPUT = {
    "voltage": ("output voltage", "v", "V"),
    "power": ("output power", "p", "W"),
}


def _labels(result: Result) -> tuple[str, str, str]:
    return _OUTPUT[result.config["plant.output"]]


def _time_ms(result: Result) -> np.ndarray:
    return result.time * 1e3


def _mark_changes(ax, result: Result) -> None:
    t_end = result.config["sim.t_end"]
    for tc in result.config["plant.change_times"]:
        if tc < t_end:
            ax.axvline(tc * 1e3, color="0.6", lw=0.8, ls=":")


def _save(fig: Figure, path: str | Path | None) -> Figure:
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


def plot_run(result: Result, path: str | Path | None = None, title: str | None = None,
             with_gamma: bool | None = None) -> Figure:
    """Output and reference (top), duty cycle (middle/bottom), gamma (bottom, optional)."""
    if with_gamma is None:
        with_gamma = result.config["controller.law"] == "variational"
    n = 3 if with_gamma else 2
    fig = Figure(figsize=(8, 2.6 * n + 0.6), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True)
    quantity, sym, unit = _labels(result)
    t = _time_ms(result)
    ax = axes[0]
    ax.plot(t, result.signals["y"], color="tab:red", lw=1.4, label=f"output ${sym}$")
    ax.plot(t, result.signals["y_ref"], color="tab:blue", lw=1.2, ls="--",
            label=f"reference ${sym}^*$")
    ax.set_ylabel(f"{quantity} ${sym}$ ({unit})")
    ax.legend(loc="upper left")
    axes[1].plot(t, result.signals["duty"], color="tab:green", lw=1.0)
    axes[1].set_ylabel("duty cycle $d$ (1)")
    if with_gamma:
        _gamma_axes(axes[2], result)
    for a in axes:
        a.grid(True, alpha=0.3)
        _mark_changes(a, result)
    axes[-1].set_xlabel("time $t$ (ms)")
    if result.metrics.get("diverged"):
        axes[0].set_title(f"diverged at t = {result.metrics['t_diverge'] * 1e3:.3f} ms",
                          color="tab:red", fontsize=9, loc="right")
    fig.suptitle(title if title is not None else (result.label or result.name))
    return _save(fig, path)


def _gamma_axes(ax, result: Result) -> None:
    ax.plot(_time_ms(result), result.signals["gamma"], color="tab:purple", lw=1.2)
    ax.set_ylabel(r"gain $\gamma$ (1)")
    ax.ticklabel_format(axis="y", useOffset=False)


def plot_gamma(result: Result, path: str | Path | None = None,
               title: str | None = None) -> Figure:
    """gamma(t) on its own axes (the paper's Figs. 4 and 8)."""
    fig = Figure(figsize=(8, 3.2), layout="constrained")
    ax = fig.subplots()
    _gamma_axes(ax, result)
    _mark_changes(ax, result)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("time $t$ (ms)")
    fig.suptitle(title if title is not None else f"{result.name}: evolution of gamma")
    return _save(fig, path)


def plot_sweep(sweep: SweepResult, kind: str = "gamma", path: str | Path | None = None,
               title: str | None = None) -> Figure:
    """One curve per member: gamma(t) (``kind='gamma'``) or |y - y*| on a log axis
    (``kind='error'``)."""
    if kind not in ("gamma", "error"):
        raise ValueError(f"kind = {kind!r}: must be 'gamma' or 'error'")
    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.subplots()
    first = sweep.members[0]
    quantity, sym, unit = _labels(first)
    short = sweep.key.split(".")[-1]
    for v, m in zip(sweep.values, sweep.members, strict=True):
        t = _time_ms(m)
        label = f"{short} = {v:g}" + (" (unstable)" if not m.metrics["stable"] else "")
        if kind == "gamma":
            ax.plot(t, m.signals["gamma"], lw=1.2, label=label)
        else:
            err = np.abs(m.error)
            ax.semilogy(t, np.where(err > 0, err, np.nan), lw=0.9, label=label)
    if kind == "gamma":
        ax.set_ylabel(r"gain $\gamma$ (1)")
        ax.ticklabel_format(axis="y", useOffset=False)
    else:
        ax.set_ylabel(f"tracking error $|{sym} - {sym}^*|$ ({unit})")
    _mark_changes(ax, first)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_xlabel("time $t$ (ms)")
    ax.legend(fontsize=8)
    what = "gamma" if kind == "gamma" else "tracking error"
    fig.suptitle(title if title is not None else f"{sweep.name}: {what} for several {short}")
    return _save(fig, path)
