"""Figures in the paper's layout: output and reference on top, duty cycle below; gamma on
its own axes; sweeps as gamma(t) and |y - y*| (log axis) per member.

Uses matplotlib's object API (no pyplot), so it works headless and never changes the
caller's backend.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.figure import Figure

from ...config import options
from ...config.resolve import Config


class Run(Protocol):
    """What a run's figures read: a :class:`~mfcontrol.Result` is one. The result types
    draw themselves through this module (``Result.plot``), so it names what it reads
    instead of importing them."""

    name: str
    label: str
    time: np.ndarray
    signals: dict[str, np.ndarray]
    metrics: dict[str, Any]
    config: Config | None
    changes: tuple

    @property
    def error(self) -> np.ndarray: ...


class Sweep(Protocol):
    """What a sweep's figure reads: a :class:`~mfcontrol.SweepResult` is one."""

    name: str
    key: str
    values: list[float]

    @property
    def members(self) -> Sequence[Run]: ...

_OUTPUT = {
    "voltage": ("output voltage", "v", "V"),
    "power": ("output power", "p", "W"),
}


#: (quantity, symbol, unit) of the output and the input's axis label, per plant model
_MODELS = {
    "first-order": (("output", "y", "1"), "control $u$ (1)"),
    "lti": (("output", "y", "1"), "control $u$ (1)"),
    "dc-motor": (("speed", r"\omega", "rad/s"), "armature voltage $u$ (V)"),
}


def _label_parts(cfg) -> tuple[tuple[str, str, str], str]:
    """A configuration's output as (quantity, symbol, unit) and its input's axis label:
    the one lookup every label and unit below is read from."""
    model = cfg["plant.model"]
    if model in _MODELS:
        return _MODELS[model]
    return _OUTPUT[cfg["plant.output"]], "duty cycle $d$ (1)"


def _labels(result: Run) -> tuple[str, str, str]:
    assert result.config is not None  # a case run's figure: it has a configuration
    return _label_parts(result.config)[0]


def units(cfg) -> tuple[str, str]:
    """The units of a configuration's output and input: ``("V", "1")`` for the buck's
    voltage under a duty cycle."""
    (_, _, y_unit), u_label = _label_parts(cfg)
    return y_unit, u_label.rpartition("(")[2].rstrip(")")


def plain_labels(cfg) -> tuple[str, str]:
    """The output's and the input's axis labels in plain text, for figures drawn outside
    matplotlib (no TeX): ``("output voltage v (V)", "duty cycle d (1)")`` for the buck."""
    (quantity, sym, unit), u_label = _label_parts(cfg)

    def plain(text: str) -> str:
        return text.replace("\\omega", "\u03c9").replace("$", "")

    return plain(f"{quantity} {sym} ({unit})"), plain(u_label)


def _input_label(result: Run) -> str:
    assert result.config is not None  # a case run's figure: it has a configuration
    return _label_parts(result.config)[1]


def _differs(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and not np.array_equal(a, b, equal_nan=True)


def _time_scale(t: np.ndarray) -> tuple[float, str]:
    """Milliseconds for runs shorter than a second, seconds otherwise."""
    return (1e3, "time $t$ (ms)") if t.size and t[-1] < 1.0 else (1.0, "time $t$ (s)")


def event_times(result: Run) -> list[tuple[float, str]]:
    """A case run's events inside its horizon: (time in s, what: "load change" or
    "disturbance"), in time order."""
    cfg = result.config
    assert cfg is not None  # a case run's figure: it has a configuration
    times = (list(cfg["plant.change_times"]) if cfg["plant.model"] in ("buck", "boost")
             else [])
    times += [e["t"] for e in cfg["plant.schedule"]]
    events = [(tc, "load change") for tc in times if tc < cfg["sim.t_end"]]
    if cfg["disturbance.kind"] != "none" and cfg["disturbance.t0"] < cfg["sim.t_end"]:
        events.append((cfg["disturbance.t0"], "disturbance"))
    return sorted(events)


def _mark_changes(ax, result: Run, scale: float = 1e3) -> None:
    events = event_times(result)
    for what, color in (("load change", "0.45"), ("disturbance", "tab:orange")):
        _events(ax, [(tc * scale, what) for tc, w in events if w == what], color,
                f"{what}s")


#: a transient smaller than this fraction of the output panel's span gets a zoom
ZOOM_BELOW = 0.04


def _transient_zoom(ax, t, y, y_ref, events, scale: float):
    """An inset magnifying the first event's transient when it is too small to see on the
    panel (the paper's figures zoom on the load change): the window starts just before
    the event and spans 6 % of the horizon. Placed in the panel's emptiest corner.
    Returns the inset, or None when no event needs one."""
    if not events or t.size < 10 or not np.all(np.isfinite(y)):
        return None
    tc = events[0][0] * scale
    width = 0.06 * (t[-1] - t[0])
    window = (t >= tc - 0.15 * width) & (t <= tc + width)
    if window.sum() < 5:
        return None
    span = float(np.ptp(np.concatenate([y, y_ref])))
    e = np.abs(y[window] - y_ref[window])
    wiggle = float(np.ptp(y[window] - y_ref[window]))
    if span == 0 or wiggle == 0 or e.max() >= ZOOM_BELOW * span:
        return None
    # the emptiest corner for the inset, the emptiest other one for the legend (whose
    # "best" place ignores insets), counted on the plotted samples in axes fractions
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    fx = np.tile((t - x0) / (x1 - x0), 2)
    fy = np.concatenate([(y - y0) / (y1 - y0), (y_ref - y0) / (y1 - y0)])

    def crowd(box):
        (a, b), (w, h) = box
        return int(np.sum((fx > a - 0.03) & (fx < a + w + 0.03)
                          & (fy > b - 0.05) & (fy < b + h + 0.05)))

    size = (0.4, 0.4)
    corners = {"lower right": (0.57, 0.07), "upper left": (0.07, 0.5),
               "upper right": (0.57, 0.5), "lower left": (0.07, 0.07)}
    place = min(corners, key=lambda k: crowd((corners[k], size)))
    corner = corners[place]
    legend_boxes = {"lower right": (0.7, 0.02), "upper left": (0.02, 0.76),
                    "upper right": (0.7, 0.76), "lower left": (0.02, 0.02)}
    others = [k for k in legend_boxes if k != place]
    legend_at = min(others, key=lambda k: crowd((legend_boxes[k], (0.28, 0.22))))
    if ax.get_legend() is not None:
        ax.legend(loc=legend_at)
    inset = ax.inset_axes([*corner, *size])
    inset.plot(t[window], y[window], color="tab:red", lw=1.2)
    inset.plot(t[window], y_ref[window], color="tab:blue", lw=1.0, ls="--")
    lo = min(y[window].min(), y_ref[window].min())
    hi = max(y[window].max(), y_ref[window].max())
    pad = 0.15 * (hi - lo)
    inset.set_xlim(t[window][0], t[window][-1])
    inset.set_ylim(lo - pad, hi + pad)
    inset.tick_params(labelsize=6)
    inset.grid(True, alpha=0.3)
    unit = "ms" if scale == 1e3 else "s"
    inset.set_title(f"zoom: {events[0][1]} at {tc:g} {unit}", fontsize=7, pad=2)
    ax.indicate_inset_zoom(inset, edgecolor="0.4")
    return inset


def _event(ax, x: float, text: str, color: str) -> None:
    """A dotted line at an event, named at the top of the panel."""
    ax.axvline(x, color=color, lw=0.8, ls=":")
    _event_name(ax, x, text, color)


def _event_name(ax, x: float, text: str, color: str, **style: Any) -> None:
    ax.annotate(text, xy=(x, 1.0), xycoords=("data", "axes fraction"), xytext=(-2, -3),
                textcoords="offset points", rotation=90, ha="right", va="top", fontsize=7,
                color=color, **style)


#: events of one kind named one by one on a panel at most; more are drawn as one
#: collection of ticks, named once
NAMED_EVENTS = 10


def _events(ax, events: Sequence[tuple[float, str]], color: str, plural: str) -> None:
    """Dotted lines at ``events`` (x, name), each named while they are few. Many (a case
    file may hold a thousand load changes) are one collection of ticks along the panel's
    top, named once, by their count, at the first: a line and a label each took half a
    minute of CPU for 1,000 (every label laid out and drawn, and unreadable at that),
    and dotted lines that close together read as horizontal stripes over the curves."""
    if len(events) <= NAMED_EVENTS:
        for x, text in events:
            _event(ax, x, text, color)
        return
    from matplotlib.collections import LineCollection

    xs = sorted(x for x, _ in events)
    # x in data, y in the panel's fraction (as axvline's), kept out of the data limits
    # above an inset (a child of the panel at zorder 5, as the paper's zoom is): the
    # count must stay readable wherever the changes fall
    ticks = LineCollection([[(x, 0.96), (x, 1.0)] for x in xs], colors=color,
                           linewidths=0.8, transform=ax.get_xaxis_transform(), zorder=6)
    ax.add_collection(ticks, autolim=False)
    _event_name(ax, xs[0], f"{len(xs):,} {plural}", color, zorder=6,
                bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none",
                      "alpha": 0.85})


#: resolution of every saved figure (dots per inch)
DPI = 120


def save_figure(fig: Figure, path: str | Path | None) -> Figure:
    """Write ``fig`` as ``path`` (its folder created) unless path is None; return fig.
    The format is the path's (PNG without a suffix), as ``Figure.savefig`` chooses it."""
    if path is None:
        return fig
    # a figure asked for in a folder that does not exist yet is the user's intent
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    if Path(path).suffix.lower() != ".png":
        fig.savefig(path, dpi=DPI)
        return fig
    # savefig draws a figure with a layout engine twice: once with rendering turned off,
    # to lay it out (every artist walked: a third of the figure's time), then for real.
    # The Agg canvas printing it itself draws it once, laying it out at the start of that
    # draw at the same resolution: the same bytes. The figure is left as savefig leaves
    # it: laid out, its canvas and resolution its own again
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas, dpi = fig.canvas, fig.dpi
    try:
        agg = FigureCanvasAgg(fig)
        fig.set_dpi(DPI)
        try:
            agg.print_png(path)
        finally:
            fig.set_dpi(dpi)
    finally:
        fig.set_canvas(canvas)
    return fig


def _tracking_panel(ax, t_ms, y, y_ref, ylabel: str, sym: str,
                    y_meas: np.ndarray | None = None) -> None:
    if y_meas is not None and _differs(y_meas, y):
        ax.plot(t_ms, y_meas, color="0.65", lw=0.6, label=f"measured ${sym}$ (sensor)")
    ax.plot(t_ms, y, color="tab:red", lw=1.4, label=f"output ${sym}$")
    ax.plot(t_ms, y_ref, color="tab:blue", lw=1.2, ls="--", label=f"reference ${sym}^*$")
    ax.set_ylabel(ylabel)
    ax.legend(loc="best")


def plot_loop(result, path: str | Path | None = None, title: str | None = None,
              output_label: str = "output y", input_label: str = "control u") -> Figure:
    """A :class:`~mfcontrol.Result`: output and reference on top, control below.
    Labels should carry units, e.g. ``output_label="speed (rad/s)"``."""
    fig = Figure(figsize=(8, 5.8), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    scale, time_label = _time_scale(result.time)
    t = result.time * scale
    _tracking_panel(axes[0], t, result.signals["y"], result.signals["y_ref"], output_label,
                    "y", result.signals.get("y_meas"))
    _input_panel(axes[1], t, result)
    axes[1].set_ylabel(input_label)
    for a in axes:
        a.grid(True, alpha=0.3)
        # named as a case run's events are
        _events(a, [(c.time * scale, f"{c.name} {'+' if c.add else ''}= {c.value:g}")
                    for c in result.changes], "0.45", "parameter changes")
    axes[-1].set_xlabel(time_label)
    if result.metrics.get("diverged"):
        axes[0].set_title(f"diverged at t = {result.metrics['t_diverge']:.6g} s",
                          color="tab:red", fontsize=9, loc="right")
    fig.suptitle(title if title is not None else result.name)
    return save_figure(fig, path)


def _input_panel(ax, t, result) -> None:
    """The controller's output, and what reached the plant where the actuator or an input
    disturbance made it differ."""
    u, u_plant = result.signals["u"], result.signals.get("u_plant")
    if u_plant is not None and _differs(u_plant, u):
        ax.plot(t, u, color="tab:green", lw=0.8, label="controller output $u$")
        ax.plot(t, u_plant, color="tab:olive", lw=1.0, ls="--",
                label="reaching the plant $u_{plant}$")
        ax.legend(loc="best", fontsize=8)
    else:
        ax.plot(t, u, color="tab:green", lw=1.0)


def plot_run(result: Run, path: str | Path | None = None, title: str | None = None,
             with_gamma: bool | None = None) -> Figure:
    """Output and reference (top), duty cycle (middle/bottom), gamma (bottom, optional)."""
    if with_gamma is None:
        assert result.config is not None  # a case run's figure: it has a configuration
        with_gamma = result.config["controller.law"] == "variational"
    n = 3 if with_gamma else 2
    fig = Figure(figsize=(8, 2.6 * n + 0.6), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True)
    quantity, sym, unit = _labels(result)
    scale, time_label = _time_scale(result.time)
    t = result.time * scale
    _tracking_panel(axes[0], t, result.signals["y"], result.signals["y_ref"],
                    f"{quantity} ${sym}$ ({unit})", sym, result.signals.get("y_meas"))
    _input_panel(axes[1], t, result)
    axes[1].set_ylabel(_input_label(result))
    if with_gamma:
        _gamma_axes(axes[2], result)
    for a in axes:
        a.grid(True, alpha=0.3)
        _mark_changes(a, result, scale)
    if result.metrics.get("settled"):  # a failing loop's figure shows the failure
        _transient_zoom(axes[0], t, result.signals["y"], result.signals["y_ref"],
                        event_times(result), scale)
    axes[-1].set_xlabel(time_label)
    if result.metrics.get("diverged"):
        axes[0].set_title(f"diverged at t = {result.metrics['t_diverge']:.6g} s",
                          color="tab:red", fontsize=9, loc="right")
    fig.suptitle(title if title is not None else (result.label or title_in_words(result,
                                                                               result.name)),
                 fontsize=10)
    return save_figure(fig, path)


def _gamma_axes(ax, result: Run) -> None:
    scale, _ = _time_scale(result.time)
    ax.plot(result.time * scale, result.signals["gamma"], color="tab:purple", lw=1.2)
    ax.set_ylabel(r"gain $\gamma$ (1)")
    ax.ticklabel_format(axis="y", useOffset=False)


def plot_gamma(result: Run, path: str | Path | None = None,
               title: str | None = None) -> Figure:
    """gamma(t) on its own axes (the paper's Figs. 4 and 8)."""
    fig = Figure(figsize=(8, 3.2), layout="constrained")
    ax = fig.subplots()
    scale, time_label = _time_scale(result.time)
    _gamma_axes(ax, result)
    _mark_changes(ax, result, scale)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel(time_label)
    fig.suptitle(title if title is not None else f"{result.name}: evolution of gamma")
    return save_figure(fig, path)


def plot_sweep(sweep: Sweep, kind: str = "gamma", path: str | Path | None = None,
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
    scale, time_label = _time_scale(first.time)
    def curve(m):
        return m.signals["gamma"] if kind == "gamma" else np.abs(m.error)

    # members whose curves coincide on the figure are drawn once, under one label that
    # says so: within 0.1 % of the axis; on the log axis within 0.02 decades (a line's
    # width) wherever either is above 1e-4 of the largest value
    finite = [c[np.isfinite(c)] for c in map(curve, sweep.members)]
    # the settled members set the scale (an unsettled one's range is clipped off the axis)
    settled = [c for c, m in zip(finite, sweep.members, strict=True) if m.metrics["settled"]]
    span = max((np.ptp(c) for c in (settled or finite) if c.size), default=0.0)
    top = max((np.abs(c).max() for c in finite if c.size), default=0.0)

    def same(a: np.ndarray, b: np.ndarray) -> bool:
        if a.shape != b.shape or not np.array_equal(np.isfinite(a), np.isfinite(b)):
            return False
        ok = np.isfinite(a)
        a, b = a[ok], b[ok]
        if kind == "gamma":
            return bool(np.all(np.abs(a - b) <= 1e-3 * span))
        seen = np.maximum(a, b) > 1e-4 * top
        with np.errstate(divide="ignore"):
            gap = np.abs(np.log10(a[seen]) - np.log10(b[seen]))
        return bool(np.all(gap <= 0.02))

    groups: list[list[int]] = []
    for j, m in enumerate(sweep.members):
        for g in groups:
            if same(curve(sweep.members[g[0]]), curve(m)):
                g.append(j)
                break
        else:
            groups.append([j])
    for g in groups:
        m = sweep.members[g[0]]
        values = ", ".join(f"{sweep.values[j]:g}" for j in g)
        label = (f"{short} = {values}" + (" (coincide)" if len(g) > 1 else "")
                 + (" (not settled)" if not m.metrics["settled"] else ""))
        t, c = m.time * scale, curve(m)
        if kind == "gamma":
            ax.plot(t, c, lw=1.2, label=label)
        else:
            ax.semilogy(t, np.where(c > 0, c, np.nan), lw=0.9, label=label)
    if len(groups) == 1 and len(sweep.members) > 1:
        _note(ax, f"all {len(sweep.members)} members give the same curve")
    elif len(groups) < len(sweep.members):
        _note(ax, "curves that coincide on this scale are drawn once")
    if kind == "gamma":
        ax.set_ylabel(r"gain $\gamma$ (1)")
        ax.ticklabel_format(axis="y", useOffset=False)
        _clip_outliers(ax, [curve(sweep.members[g[0]]) for g in groups
                            if sweep.members[g[0]].metrics["settled"]],
                       [curve(sweep.members[g[0]]) for g in groups
                        if not sweep.members[g[0]].metrics["settled"]])
    else:
        ax.set_ylabel(f"tracking error $|{sym} - {sym}^*|$ ({unit})")
    _mark_changes(ax, first, scale)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_xlabel(time_label)
    ax.legend(fontsize=8)
    what = "gain gamma" if kind == "gamma" else "tracking error"
    fig.suptitle(title if title is not None else
                 title_in_words(sweep, sweep.name, f"{what} of each member"), fontsize=10)
    return save_figure(fig, path)


def _note(ax, text: str) -> None:
    """A remark about the panel, above it (where no curve or legend sits)."""
    ax.set_title(text, fontsize=8, loc="left", color="0.3")


def title_in_words(result, fallback: str = "", extra: str = "") -> str:
    """A figure's title: the case's description (else ``fallback``), wrapped, and
    ``extra`` on a line of its own."""
    import textwrap

    cfg = getattr(result, "config", None)
    text = _shortened((cfg["description"] if cfg is not None and cfg["description"] else "")
                      or fallback, options.TITLE_MOST)
    # lines of even length (no one-word last line), "Fig. 6" and "Gamma = 5e-8" never split
    # (no-break spaces: textwrap breaks at ASCII whitespace only)
    for phrase in ("Fig. ", "Figs. ", " = "):
        text = text.replace(phrase, phrase.replace(" ", "\u00a0"))
    lines = math.ceil(len(text) / 95) if text else 1
    return "\n".join([*textwrap.wrap(text, math.ceil(len(text) / lines) + 8),
                      *([extra] if extra else [])])


def _shortened(text: str, most: int) -> str:
    """``text`` cut to at most ``most`` characters, at a word where there is one in its
    second half, and " ..." put in place of the rest: a title longer than a few lines
    leaves no room for the panels (matplotlib then draws none), and a long one took
    minutes to lay out."""
    if len(text) <= most:
        return text
    cut = text[:most - 4]
    space = cut.rfind(" ")
    return (cut[:space] if space >= most // 2 else cut).rstrip() + " ..."


def _clip_outliers(ax, kept: list[np.ndarray], outliers: list[np.ndarray]) -> None:
    """Limit the axis to the settled members' range when an unsettled one would flatten
    them (its range ten times theirs or more), and say so on the figure."""
    if not kept or not outliers:
        return
    finite = [c[np.isfinite(c)] for c in kept]
    lo, hi = min(c.min() for c in finite if c.size), max(c.max() for c in finite if c.size)
    wide = [c[np.isfinite(c)] for c in outliers]
    o_lo = min((c.min() for c in wide if c.size), default=lo)
    o_hi = max((c.max() for c in wide if c.size), default=hi)
    span = max(hi - lo, abs(hi) * 1e-6, 1e-300)
    if max(o_hi - lo, hi - o_lo) > 10 * span:
        pad = 0.1 * span
        ax.set_ylim(lo - pad, hi + pad)
        _note(ax, f"unsettled members leave the axis (they reach {o_lo:.3g} .. {o_hi:.3g})")


def plot_long_horizon(rows, path: str | Path | None = None, fidelity: str = "") -> Figure:
    """gamma(t) (top) and |y - y*| on a log axis (bottom) for each (case, integrator)."""
    fig = Figure(figsize=(8, 6), layout="constrained")
    ax = fig.subplots(2, 1, sharex=True)
    for case, order, r in rows:
        label = f"{case.removeprefix('voltage-').removesuffix('-variational')}, {order}"
        ax[0].plot(r.time * 1e3, r.signals["gamma"], lw=1.1, label=label)
        err = np.abs(r.error)
        ax[1].semilogy(r.time * 1e3, np.where(err > 0, err, np.nan), lw=0.7, label=label)
    ax[0].set_ylabel(r"gain $\gamma$ (1)")
    ax[0].ticklabel_format(axis="y", useOffset=False)
    ax[1].set_ylabel("tracking error $|v - v^*|$ (V)")
    ax[1].set_xlabel("time $t$ (ms)")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.suptitle(f"variational i-P over {rows[0][2].time[-1] * 1e3:.0f} ms ({fidelity})")
    return save_figure(fig, path)


def convergence(point: np.ndarray, value: np.ndarray, params: dict[str, np.ndarray],
                objective: str, title: str, path: str | Path | None = None,
                log: tuple[str, ...] = ()) -> Figure:
    """A tuner's search: every evaluated point's objective value and the best so far
    against the points evaluated, then each tuned key's values (one row each, on a log
    axis for the keys in ``log``)."""
    order = np.argsort(point, kind="stable")
    point, value = np.asarray(point)[order], np.asarray(value, dtype=float)[order]
    fig = Figure(figsize=(8, 3.2 + 1.3 * len(params)), layout="constrained")
    axes = fig.subplots(1 + len(params), 1, sharex=True, squeeze=False)[:, 0]
    ax = axes[0]
    finite = np.isfinite(value)
    ax.plot(point[finite] + 1, value[finite], ".", color="0.55", ms=3,
            label="a point's value")
    best = np.minimum.accumulate(np.where(finite, value, np.inf))
    shown = np.isfinite(best)
    ax.step(point[shown] + 1, best[shown], where="post", color="tab:red", lw=1.6,
            label="best so far")
    n_inf = int((~finite).sum())
    if n_inf:
        ax.plot([], [], " ", label=f"{n_inf} of {value.size} points scored inf "
                "(invalid, diverged or not settled)")
    if finite.any() and value[finite].min() > 0 and value[finite].max() > 10 * value[finite].min():
        ax.set_yscale("log")
    ax.set_ylabel(f"objective\n{objective}")
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(title)
    best_at = int(np.argmin(np.where(finite, value, np.inf))) if finite.any() else None
    for ax, (key, v) in zip(axes[1:], params.items(), strict=True):
        v = np.asarray(v, dtype=float)[order]
        ax.plot(point + 1, v, ".", color="tab:blue", ms=3)
        if best_at is not None:
            ax.plot(point[best_at] + 1, v[best_at], "*", color="tab:red", ms=11,
                    label=f"best: {v[best_at]:.4g}")
            ax.legend(loc="upper right", fontsize="small")
        ax.set_ylabel(options.label(key))
        if key in log:
            ax.set_yscale("log")
    axes[-1].set_xlabel("points evaluated")
    return save_figure(fig, path)


def comparison(results: Sequence[Run], labels: list[str], table: list[list[str]],
               header: list[str], title: str, path: str | Path | None = None) -> Figure:
    """Several runs of one scenario: their outputs on one axis with the reference, their
    controls below, and the metrics table beside."""
    fig = Figure(figsize=(14, 6.4), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.35, 1))
    top = fig.add_subplot(grid[0, 0])
    bottom = fig.add_subplot(grid[1, 0], sharex=top)
    side = fig.add_subplot(grid[:, 1])
    first = results[0]
    quantity, sym, unit = _labels(first)
    scale, time_label = _time_scale(first.time)
    colors = [f"C{i}" for i in range(10)]
    # a dash pattern of its own and decreasing widths per run, the first drawn widest:
    # runs that coincide (two controllers that settle alike) stay visible under each
    # other
    styles = ["-", (0, (5, 2)), (0, (1, 1.5)), (0, (6, 2, 1, 2))]
    top.plot(first.time * scale, first.signals["y_ref"], color="k", lw=1.0, ls="--",
             label=f"reference ${sym}^*$")
    for i, (r, label) in enumerate(zip(results, labels, strict=True)):
        c, ls = colors[i % 10], styles[i % len(styles)]
        lw = max(0.8, 2.0 - 0.4 * i)
        top.plot(r.time * scale, r.signals["y"], color=c, lw=lw, ls=ls, label=label)
        bottom.plot(r.time * scale, r.signals["u"], color=c, lw=0.6 * lw, ls=ls, alpha=0.85,
                    label=label)
    top.set_ylabel(f"{quantity} ${sym}$ ({unit})")
    bottom.set_ylabel(_input_label(first))
    bottom.set_xlabel(time_label)
    top.legend(loc="best", fontsize=8)
    for a in (top, bottom):
        a.grid(True, alpha=0.3)
        _mark_changes(a, first, scale)
    side.axis("off")
    first_width = min(0.4, 0.1 + 0.012 * max(len(row[0]) for row in table))
    rest = (1.0 - first_width) / max(1, len(header) - 1)
    cells = side.table(cellText=table, colLabels=header, loc="upper center",
                       cellLoc="right", colLoc="center",
                       colWidths=[first_width] + [rest] * (len(header) - 1))
    cells.auto_set_font_size(False)
    cells.set_fontsize(7)
    cells.scale(1.0, 1.4)
    if any("\n" in h for h in header):  # a header of two lines (a name, its unit)
        for j in range(len(header)):
            cells[0, j].set_height(cells[0, j].get_height() * 1.9)
    for i in range(len(table)):
        cells[i + 1, 0].get_text().set_color(colors[i % 10])
    side.set_title("metrics (true output y)", fontsize=10)
    fig.suptitle(title)
    return save_figure(fig, path)


def robustness_maps(maps: list[list[np.ndarray]], rows: list[str], columns: list[str],
                    axes: list[dict[str, np.ndarray]], objectives: list[str],
                    path: str | Path | None = None,
                    title: str = "Robustness: the tuned objective over plant changes"
                    ) -> Figure:
    """A grid of small heatmaps (one row per plant, one column per controller) of an
    objective over two swept keys; one colour scale per row (log), crosses on members
    that scored inf (diverged or not settled)."""
    from matplotlib.colors import LogNorm

    fig = Figure(figsize=(3.3 * len(columns) + 1.2, 2.5 * len(rows) + 0.8),
                 layout="constrained")
    grid = fig.subplots(len(rows), len(columns), squeeze=False)
    for i, (name, row_maps, ax_values, objective) in enumerate(
            zip(rows, maps, axes, objectives, strict=True)):
        (ky, vy), (kx, vx) = list(ax_values.items())[:2]
        finite = np.concatenate([m[np.isfinite(m)].ravel() for m in row_maps])
        finite = finite[finite > 0]
        norm = (LogNorm(finite.min(), max(finite.max(), finite.min() * 1.0001))
                if finite.size else None)
        image = None
        for j, m in enumerate(row_maps):
            ax = grid[i, j]
            m = np.asarray(m, dtype=float).reshape(vy.size, vx.size)
            shown = np.where(np.isfinite(m) & (m > 0), m, np.nan)
            image = ax.imshow(shown, origin="lower", aspect="auto", cmap="viridis", norm=norm)
            bad = np.argwhere(~np.isfinite(m))
            if bad.size:
                ax.plot(bad[:, 1], bad[:, 0], "x", color="tab:red", ms=9, mew=2)
            ax.set_xticks(range(vx.size), [f"{v:.3g}" for v in vx], fontsize=7)
            ax.set_yticks(range(vy.size), [f"{v:.3g}" for v in vy], fontsize=7)
            ax.set_title(f"{name}: {columns[j]}", fontsize=9)
            ax.set_xlabel(options.label(kx), fontsize=8)
            if j == 0:
                ax.set_ylabel(options.label(ky), fontsize=8)
        if image is not None and norm is not None:
            fig.colorbar(image, ax=list(grid[i]), label=f"objective {objective}\n(log scale)",
                         shrink=0.9)
    fig.suptitle(f"{title} (red x: diverged or not settled)")
    return save_figure(fig, path)


class LinearAnalysis(Protocol):
    """What an analysis's figure reads: a :class:`~mfcontrol.Analysis` is one."""

    @property
    def name(self) -> str: ...

    @property
    def margins(self) -> dict[str, Any]: ...

    @property
    def loop(self) -> Any: ...

    def poles(self) -> np.ndarray: ...


def _margin_words(m: dict[str, Any]) -> str:
    def num(v: float, fmt: str) -> str:
        return "none" if math.isinf(v) else format(v, fmt)

    return (f"Ms {m['Ms']:.3g}, gain margin {num(m['gain_margin'], '.3g')}, phase margin "
            f"{num(m['phase_margin_deg'], '.3g')} deg, delay margin "
            f"{num(m['delay_margin_samples'], '.3g')} samples")


def plot_analysis(analysis: LinearAnalysis, path: str | Path | None = None,
                  title: str | None = None) -> Figure:
    """A linear analysis (:func:`mfcontrol.analyze`) in four panels: the gains of the loop
    L, the sensitivities S and T and the noise-to-control gain C_y S over frequency; L's
    phase; the Nyquist curve of L with -1 and the Ms circle; the closed-loop poles with
    the unit circle."""
    from ...analysis.loop import frequencies

    m = analysis.margins
    loop = analysis.loop
    dt = loop.controller.dt
    omega = frequencies(dt, 2000)
    resp = loop.frequency_response(omega)
    fig = Figure(figsize=(11, 8), layout="constrained")
    (ax_mag, ax_nyq), (ax_ph, ax_pole) = fig.subplots(2, 2)

    def db(x: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore"):
            return 20 * np.log10(np.abs(x))

    for key, label, style in (("L", "loop gain $|L|$", dict(color="k", lw=1.5)),
                              ("S", "sensitivity $|S|$", dict(color="tab:red")),
                              ("T", "complementary sensitivity $|T|$",
                               dict(color="tab:blue")),
                              ("CS", r"noise to control $|C_y S|$",
                               dict(color="tab:green", ls="--"))):
        ax_mag.semilogx(omega, db(resp[key]), label=label, **style)
    ax_mag.axhline(0.0, color="0.6", lw=0.8)
    ax_mag.axhline(20 * math.log10(m["Ms"]), color="tab:red", lw=0.6, ls=":",
                   label=f"Ms = {m['Ms']:.3g}")
    ax_mag.set_ylabel("gain (dB)")
    ax_mag.set_title("Gains over frequency")
    ax_mag.legend(loc="best", fontsize=8)
    ax_mag.set_ylim(max(db(resp["L"]).min(), -80.0) - 5,
                    min(max(db(resp["L"]).max(), db(resp["CS"]).max()), 160.0) + 5)
    phase = np.degrees(np.unwrap(np.angle(resp["L"])))
    ax_ph.semilogx(omega, phase, color="k")
    for level in (-180.0 + 360.0 * k for k in range(-4, 4)):
        if phase.min() - 30 < level < phase.max() + 30:
            ax_ph.axhline(level, color="0.6", lw=0.8)
    ax_ph.set_xlabel("frequency (rad/s); the right edge is the Nyquist frequency pi/h")
    ax_ph.set_ylabel("phase of L (deg)")
    ax_ph.set_title("Phase of the loop gain")
    for ax in (ax_mag, ax_ph):
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlim(omega[0], omega[-1])

    # Nyquist: the curve and its mirror (negative frequencies), -1, the Ms circle
    L = resp["L"]
    ax_nyq.plot(L.real, L.imag, color="k", lw=1.3, label="$L(e^{j\\omega h})$, $\\omega > 0$")
    ax_nyq.plot(L.real, -L.imag, color="k", lw=0.8, ls=":", label="$\\omega < 0$")
    ax_nyq.plot([-1.0], [0.0], "r+", ms=12, mew=2, label="$-1$")
    circle = np.exp(1j * np.linspace(0, 2 * math.pi, 400))
    ax_nyq.plot((-1 + circle / m["Ms"]).real, (-1 + circle / m["Ms"]).imag, color="tab:red",
                lw=0.8, ls="--", label=f"distance 1/Ms = {1 / m['Ms']:.3g} from $-1$")
    ax_nyq.plot(circle.real, circle.imag, color="0.6", lw=0.6, label="unit circle")
    ax_nyq.set_xlim(-3.0, 2.0)
    ax_nyq.set_ylim(-2.5, 2.5)
    ax_nyq.set_aspect("equal", adjustable="box")
    ax_nyq.set_xlabel("real part of L")
    ax_nyq.set_ylabel("imaginary part of L")
    ax_nyq.set_title("Nyquist curve near $-1$")
    ax_nyq.grid(True, alpha=0.3)
    ax_nyq.legend(loc="lower right", fontsize=8)

    poles = analysis.poles()
    ax_pole.plot(circle.real, circle.imag, color="0.6", lw=0.8, label="unit circle")
    outside = np.abs(poles) >= 1.0
    ax_pole.plot(poles[~outside].real, poles[~outside].imag, "x", color="tab:blue",
                 label="poles inside (decay)")
    if outside.any():
        ax_pole.plot(poles[outside].real, poles[outside].imag, "x", color="tab:red", mew=2,
                     label="poles outside (grow)")
    # poles of a fast-sampled loop crowd near z = 1: zoom on them when they do
    near = "unit circle"
    if poles.size:
        lo = np.array([poles.real.min(), poles.imag.min()])
        hi = np.array([poles.real.max(), poles.imag.max()])
        span = max((hi - lo).max(), 1e-3)
        if span < 0.3:
            centre = (lo + hi) / 2
            half = 0.6 * span + 0.05 * span
            ax_pole.set_xlim(centre[0] - half, centre[0] + half)
            ax_pole.set_ylim(centre[1] - half, centre[1] + half)
            near = "zoomed on the poles"
    ax_pole.set_aspect("equal", adjustable="box")
    ax_pole.set_xlabel("real part of z")
    ax_pole.set_ylabel("imaginary part of z")
    ax_pole.set_title(f"Closed-loop poles ({near})\nspectral radius "
                      f"{m['spectral_radius']:.6g}: {'stable' if m['stable'] else 'unstable'}")
    ax_pole.grid(True, alpha=0.3)
    ax_pole.legend(loc="best", fontsize=8)
    head = title if title is not None else \
        f"Linear analysis of {analysis.name or 'the loop'}, sampled every {dt:g} s"
    fig.suptitle(f"{head}\n{_margin_words(m)}")
    return save_figure(fig, path)


class LinearRegion(Protocol):
    """What a region's figure reads: a :class:`~mfcontrol.Region` is one."""

    @property
    def name(self) -> str: ...

    @property
    def x_key(self) -> str: ...

    @property
    def y_key(self) -> str: ...

    @property
    def x(self) -> np.ndarray: ...

    @property
    def y(self) -> np.ndarray: ...

    @property
    def spectral_radius(self) -> np.ndarray: ...

    @property
    def Ms(self) -> np.ndarray: ...

    @property
    def point(self) -> tuple[float, float]: ...


def is_log_spaced(values) -> bool:
    """Positive values with a constant ratio between neighbours (after sorting and removing
    duplicates). Two values count as log-spaced only when they differ by 10x or more."""
    v = np.unique(np.asarray(values, dtype=float))
    if v.size < 2 or not np.all(np.isfinite(v)) or v[0] <= 0:
        return False
    ratios = v[1:] / v[:-1]
    if v.size == 2:
        return bool(ratios[0] >= 10.0)
    return bool(np.allclose(ratios, ratios[0], rtol=1e-6, atol=0.0))


def cell_edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Edges of the cells centred on the sorted ``values``: midpoints between neighbours
    (geometric when ``log``), the outer edges half a spacing beyond the end values."""
    v = np.asarray(values, dtype=float)
    if log:
        return 10.0 ** cell_edges(np.log10(v), log=False)
    if v.size == 1:
        half = 0.5 * abs(v[0]) if v[0] != 0 else 0.5
        return np.array([v[0] - half, v[0] + half])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def plot_region(region: LinearRegion, path: str | Path | None = None,
                title: str | None = None) -> Figure:
    """A stability region (:func:`mfcontrol.analyze_region`): Ms in colour (log scale)
    where the linear loop is stable, grey where it is not, the boundary in black, Ms = 1.4
    and 2 as contours, and the case's own point."""
    from matplotlib.colors import LogNorm
    from matplotlib.ticker import FormatStrFormatter

    r = region
    stable = r.spectral_radius < 1.0
    ms = np.where(stable & np.isfinite(r.Ms), r.Ms, np.nan)
    fig = Figure(figsize=(8, 6), layout="constrained")
    ax = fig.subplots()
    # cells centred on their values, geometric edges on a log axis (the maps' cells)
    log_x, log_y = is_log_spaced(r.x), is_log_spaced(r.y)
    ex, ey = cell_edges(r.x, log_x), cell_edges(r.y, log_y)
    ax.pcolormesh(ex, ey, np.where(stable, np.nan, 1.0), cmap="Greys", vmin=0, vmax=2.5)
    finite = ms[np.isfinite(ms)]
    if finite.size:
        top = max(float(np.percentile(finite, 99)), 1.0001 * float(finite.min()))
        image = ax.pcolormesh(ex, ey, ms, cmap="viridis_r",
                              norm=LogNorm(max(float(finite.min()), 1.0), max(top, 1.01)))
        bar = fig.colorbar(image, ax=ax, label="Ms, peak sensitivity (log scale; above its "
                                               "99th percentile: the top colour)",
                           extend="max", format="%.3g")
        bar.ax.yaxis.set_minor_formatter(FormatStrFormatter("%.3g"))
        if finite.min() < 2.0 < finite.max() or finite.min() < 1.4 < finite.max():
            lines = ax.contour(r.x, r.y, ms, levels=[1.4, 2.0], colors="0.15",
                               linewidths=0.9, linestyles=["--", "-"])
            ax.clabel(lines, fmt={1.4: "Ms 1.4", 2.0: "Ms 2"}, fontsize=8)
    if stable.any() and not stable.all():
        ax.contour(r.x, r.y, r.spectral_radius, levels=[1.0], colors="black", linewidths=2)
    ax.plot(*r.point, "*", color="tab:red", ms=14, mec="white",
            label=f"the case: {r.point[0]:.4g}, {r.point[1]:.4g}")
    if log_x:
        ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    ax.set_xlabel(options.label(r.x_key))
    ax.set_ylabel(options.label(r.y_key))
    ax.legend(loc="best", fontsize=8)
    n = int(stable.sum())
    head = title if title is not None else \
        f"Stability region of {r.name or 'the loop'} (linear analysis)"
    ax.set_title(f"{head}\nblack line: the stability boundary; grey: unstable "
                 f"({n:,} of {stable.size:,} cells stable)", fontsize=10)
    return save_figure(fig, path)
