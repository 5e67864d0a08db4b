"""Heat maps of a sweep's metrics over two swept keys, with the settling boundary.

A sweep folder ``DIR`` holds ``DIR/results.parquet`` (one row per member: the swept keys
under their dotted names, then the metrics) and ``DIR/sweep.json``. :func:`heatmap` turns
the rows into a grid ``metric(x, y)`` and draws it with ``pcolormesh`` on the cell edges
(geometric midpoints on a log axis, arithmetic otherwise), overlays the contour
``settled = 0.5`` in red, hatches the unsettled cells and greys out the members that
diverged: their metrics only cover the samples before divergence, so a member that blew up
early would otherwise look like the best one.

Uses matplotlib's object API (no pyplot), like :mod:`mfcontrol.api.results.plotting`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from matplotlib import colormaps
from matplotlib.collections import PatchCollection
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from ..api.results import metrics as _metrics
from ..api.results.plotting import cell_edges, is_log_spaced, save_figure
from ..config import options

if TYPE_CHECKING:
    import pandas as pd

#: Per-member columns of results.parquet that are not swept keys.
METRICS = (*_metrics.COLUMNS, "member")

#: Metrics that stay meaningful for a diverged member (the others stop accumulating at the
#: divergence, so they are hidden for diverged members).
_ABOUT_DIVERGENCE = frozenset({"diverged", "t_diverge", "n_samples", "settled", "member"})

BAD_COLOR = "0.82"
BOUNDARY_COLOR = "tab:red"
HATCH_COLOR = (1.0, 1.0, 1.0, 0.45)
CMAP = "viridis"
RESULTS = "results.parquet"


def load(folder: str | Path) -> pd.DataFrame:
    """``folder/results.parquet`` as a DataFrame (a path to the parquet file also works).
    The sweep's ``sweep.json``, when present, goes to ``frame.attrs["sweep"]``. A file
    written before the metric ``stable`` was renamed ``settled`` is read with the new
    name (the same test), so that its map is hatched as it was."""
    import pandas as pd

    folder = Path(folder)
    path = folder if folder.suffix == ".parquet" and folder.is_file() else folder / RESULTS
    if not path.is_file():
        raise ValueError(f"{folder}: no results.parquet there (is it a sweep's output folder?)")
    frame = pd.read_parquet(path)
    if "stable" in frame.columns and "settled" not in frame.columns:
        # written before the tracking test was named for what it is: the same column
        frame = frame.rename(columns={"stable": "settled"})
    meta = path.parent / "sweep.json"
    if meta.is_file():
        frame.attrs["sweep"] = json.loads(meta.read_text())
    return frame


def axis_label(key: str) -> str:
    """A swept key's quantity in words with its unit: ``load change dR (ohm)`` (the key
    itself when the options give it no words)."""
    return options.label(key)


def swept_keys(frame: pd.DataFrame) -> list[str]:
    """The columns that are not metrics, i.e. the swept keys."""
    return [c for c in frame.columns if c not in METRICS]


@dataclass
class _Grid:
    """The rows of one map arranged as ``z[i_y, i_x]``."""

    x: str
    y: str
    metric: str
    xs: np.ndarray
    ys: np.ndarray
    z: np.ndarray          # metric, NaN where hidden (diverged / missing / non-finite)
    settled: np.ndarray | None  # 1.0 / 0.0, NaN where no member
    n_diverged: int        # cells hidden because the member diverged
    n_missing: int         # cells with no value for another reason
    where: dict[str, Any]
    log_x: bool
    log_y: bool

    def settling(self) -> str | None:
        """'mixed', 'all settled', 'none settled', or None without a settled column."""
        if self.settled is None:
            return None
        s = self.settled[np.isfinite(self.settled)]
        if s.size == 0:
            return None
        if np.all(s == 1.0):
            return "all settled"
        if np.all(s == 0.0):
            return "none settled"
        return "mixed"


def _fmt(value) -> str:
    return f"{value:g}" if isinstance(value, (int, float, np.number)) else str(value)


def _select(frame: pd.DataFrame, where: dict[str, Any]) -> pd.DataFrame:
    keys = swept_keys(frame)
    for key, value in where.items():
        if key not in frame.columns:
            raise ValueError(f"where: {key!r} is not a column; swept keys are {keys}")
        col = frame[key]
        if np.issubdtype(col.dtype, np.number) and isinstance(value, (int, float, np.number)):
            mask = np.isclose(col.to_numpy(dtype=float), float(value), rtol=1e-9, atol=0.0)
        else:
            mask = (col == value).to_numpy()
        if not mask.any():
            available = ", ".join(_fmt(v) for v in sorted(col.unique()))
            raise ValueError(f"where: no member has {key} = {_fmt(value)} "
                             f"(its values: {available})")
        frame = frame[mask]
    return frame


def _grid(frame: pd.DataFrame, x: str, y: str, metric: str, where: dict | None,
          log_x: bool | None, log_y: bool | None) -> _Grid:
    keys = swept_keys(frame)
    metrics = [c for c in frame.columns if c in METRICS]
    for role, name in (("x", x), ("y", y)):
        if name not in keys:
            raise ValueError(f"{role} = {name!r} is not a swept key; allowed: {keys}")
    if x == y:
        raise ValueError(f"x and y are both {x!r}")
    if metric not in metrics:
        raise ValueError(f"metric = {metric!r} is not a metric column; allowed: {metrics}")
    where = dict(where or {})
    for name in (x, y):
        if name in where:
            raise ValueError(f"where fixes {name!r}, which is an axis of the map")
    rows = _select(frame, where)
    unfixed = [k for k in keys
               if k not in (x, y) and k not in where and rows[k].nunique(dropna=False) > 1]
    if unfixed:
        raise ValueError(f"more keys vary than x = {x!r} and y = {y!r}: {unfixed}; fix them "
                         f"with where={{key: value}}")
    if rows.duplicated([x, y]).any():
        raise ValueError(f"several rows share the same ({x}, {y}); cannot make one map")

    xs = np.sort(rows[x].unique()).astype(float)
    ys = np.sort(rows[y].unique()).astype(float)
    ix = np.searchsorted(xs, rows[x].to_numpy(dtype=float))
    iy = np.searchsorted(ys, rows[y].to_numpy(dtype=float))

    values = rows[metric].to_numpy(dtype=float)
    hidden = ~np.isfinite(values)
    if "diverged" in rows.columns and metric not in _ABOUT_DIVERGENCE:
        diverged = rows["diverged"].to_numpy(dtype=bool)
    else:
        diverged = np.zeros(len(rows), dtype=bool)
    z = np.full((ys.size, xs.size), np.nan)
    z[iy, ix] = np.where(diverged | hidden, np.nan, values)
    n_diverged = int(diverged.sum())
    n_missing = int(np.isnan(z).sum()) - n_diverged

    settled = None
    if "settled" in rows.columns:
        settled = np.full((ys.size, xs.size), np.nan)
        settled[iy, ix] = rows["settled"].to_numpy(dtype=float)

    def decide(name: str, vals: np.ndarray, flag: bool | None) -> bool:
        if flag is None:
            return is_log_spaced(vals)
        if flag and vals[0] <= 0:
            raise ValueError(f"log axis for {name!r} needs positive values, got {vals[0]:g}")
        return bool(flag)

    return _Grid(x, y, metric, xs, ys, z, settled, n_diverged, n_missing, where,
                 decide(x, xs, log_x), decide(y, ys, log_y))


def colour_range(maps: list[tuple[np.ndarray, np.ndarray | None]], metric: str,
                 log_color: bool | None = None) -> tuple[float, float, bool]:
    """One colour scale for maps of ``metric`` (each its values and its settled column, 1/0
    or None): ``(low, high, log)``. Logarithmic for positive values spanning more than two
    decades (or when ``log_color``), linear otherwise. The CLI's maps and the tuner's
    draw with it."""
    finite = np.concatenate([z[np.isfinite(z)] for z, _ in maps])
    # the settled members set the scale when there are any: an unsettled member that did not
    # diverge (IAE 1e7) flattened every settled cell to one colour; it is hatched, and drawn
    # in the scale's end colour. Not for the columns about divergence itself (a map of
    # `settled` over its settled members would be all one value)
    everything = finite
    if metric not in _ABOUT_DIVERGENCE:
        settled = np.concatenate([z[np.isfinite(z) & (s == 1.0)] for z, s in maps
                                 if s is not None] or [np.empty(0)])
        if settled.size:
            finite = settled
    if finite.size == 0:
        return 0.0, 1.0, False
    lo, hi = float(finite.min()), float(finite.max())
    if log_color is None:
        # a log scale masks values <= 0, which would then look diverged: every member's
        # value must be positive for it
        log_color = bool(everything.min() > 0 and hi / lo > 100.0)
    if log_color:
        if lo <= 0:
            raise ValueError(f"log colour scale needs positive values; {metric} "
                             f"reaches {lo:g}")
        if lo == hi:
            return lo / math.sqrt(10.0), hi * math.sqrt(10.0), True
        return lo, hi, True
    if lo == hi:
        pad = 0.5 * abs(lo) if lo != 0 else 0.5
        return lo - pad, hi + pad, False
    return lo, hi, False


def _norm(grids: list[_Grid], log_color: bool | None) -> Normalize:
    """One colour scale for all grids (:func:`colour_range`)."""
    lo, hi, log = colour_range([(g.z, g.settled) for g in grids], grids[0].metric, log_color)
    return LogNorm(lo, hi) if log else Normalize(lo, hi)


def _extend(grids: list[_Grid], norm: Normalize) -> str:
    """The colour bar's arrows for members beyond the scale (unsettled ones, see _norm)."""
    z = np.concatenate([g.z[np.isfinite(g.z)] for g in grids])
    above, below = bool((z > norm.vmax).any()), bool((z < norm.vmin).any())
    return {(True, True): "both", (True, False): "max", (False, True): "min"}.get(
        (above, below), "neither")


def quantity(key: str) -> str:
    """A swept key's quantity in words, without its unit (for a title)."""
    return options.label(key).split(" (")[0]


def _what(metric: str, x: str, y: str) -> str:
    """A map's title in words: the metric over the two swept quantities."""
    return f"{_metrics.LABELS.get(metric, (metric,))[0]} over {quantity(x)} and {quantity(y)}"


def _hatch_unsettled(ax, grid: _Grid) -> None:
    """Light hatching over the unsettled members that did not diverge (the diverged ones are
    grey already), so the map shows which side of the boundary is which."""
    ex, ey = cell_edges(grid.xs, grid.log_x), cell_edges(grid.ys, grid.log_y)
    iy, ix = np.nonzero((grid.settled == 0.0) & np.isfinite(grid.z))
    cells = [Rectangle((ex[i], ey[j]), ex[i + 1] - ex[i], ey[j + 1] - ey[j])
             for j, i in zip(iy, ix, strict=True)]
    if cells:
        ax.add_collection(PatchCollection(cells, facecolor="none", edgecolor=HATCH_COLOR,
                                          linewidth=0, hatch="///", gid="unsettled-hatch"),
                          autolim=False)


def _boundary(ax, grid: _Grid) -> bool:
    """Draw the contour settled = 0.5 (computed in the axes' own coordinates, so on a log
    axis it crosses halfway between cells, on the cell edges). True if it was drawn."""
    if grid.settling() != "mixed":
        return False
    assert grid.settled is not None  # it is "mixed"
    import contourpy

    # Extend the settled grid by its own border values out to the outer cell edges, so the
    # boundary runs to the edge of the map (and a single row or column gets one too).
    ex = cell_edges(grid.xs, grid.log_x)
    ey = cell_edges(grid.ys, grid.log_y)
    tx = np.concatenate([ex[:1], grid.xs, ex[-1:]])
    ty = np.concatenate([ey[:1], grid.ys, ey[-1:]])
    if grid.log_x:
        tx = np.log10(tx)
    if grid.log_y:
        ty = np.log10(ty)
    s = np.pad(grid.settled, 1, mode="edge")
    gen = contourpy.contour_generator(tx, ty, np.ma.masked_invalid(s),
                                      line_type=contourpy.LineType.Separate)
    label = "boundary of the settled runs"
    drawn = False
    # LineType.Separate: one (n, 2) array of points per line (contourpy's annotation is
    # the union over every line type)
    for line in cast(list[np.ndarray], gen.lines(0.5)):
        lx = 10.0 ** line[:, 0] if grid.log_x else line[:, 0]
        ly = 10.0 ** line[:, 1] if grid.log_y else line[:, 1]
        ax.plot(lx, ly, color=BOUNDARY_COLOR, lw=2.2, label=label if not drawn else None,
                gid="settling-boundary")
        drawn = True
    return drawn


def _title(grid: _Grid, title: str | None) -> str:
    if title is None:
        title = _what(grid.metric, grid.x, grid.y)
    fixed = ", ".join(f"{k} = {_fmt(v)}" for k, v in grid.where.items())
    if fixed:
        title += f"\n({fixed})"
    state = grid.settling()
    if state in ("all settled", "none settled"):
        title += f" [{state}]" if fixed else f"\n[{state}]"
    return title


def _draw(ax, grid: _Grid, norm: Normalize, title: str | None):
    cmap = colormaps[CMAP].with_extremes(bad=BAD_COLOR)
    mesh = ax.pcolormesh(cell_edges(grid.xs, grid.log_x), cell_edges(grid.ys, grid.log_y),
                         np.ma.masked_invalid(grid.z), cmap=cmap, norm=norm,
                         edgecolors="face", linewidth=0)
    if grid.log_x:
        ax.set_xscale("log")
    if grid.log_y:
        ax.set_yscale("log")
    ex, ey = cell_edges(grid.xs, grid.log_x), cell_edges(grid.ys, grid.log_y)
    ax.set_xlim(ex[0], ex[-1])
    ax.set_ylim(ey[0], ey[-1])
    if grid.settled is not None:
        _hatch_unsettled(ax, grid)
    _boundary(ax, grid)
    handles, _ = ax.get_legend_handles_labels()
    if any(c.get_gid() == "unsettled-hatch" for c in ax.collections):
        handles.append(Patch(facecolor="0.45", edgecolor=HATCH_COLOR, hatch="///", lw=0,
                             label="not settled"))
    if grid.n_diverged:
        handles.append(Patch(facecolor=BAD_COLOR, edgecolor="0.5",
                             label=f"diverged ({grid.n_diverged} of {grid.z.size})"))
    if grid.n_missing:
        what = "did not diverge" if grid.metric == "t_diverge" else "no value"
        handles.append(Patch(facecolor=BAD_COLOR, edgecolor="0.5",
                             label=f"{what} ({grid.n_missing} of {grid.z.size})"))
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14),
                  ncols=min(len(handles), 3), fontsize=8, frameon=False)
    ax.set_xlabel(axis_label(grid.x))
    ax.set_ylabel(axis_label(grid.y))
    ax.set_title(_title(grid, title), fontsize=10)
    return mesh


def heatmap(frame: pd.DataFrame, x: str, y: str, metric: str, *, ax=None,
            where: dict | None = None, log_x: bool | None = None, log_y: bool | None = None,
            log_color: bool | None = None, title: str | None = None,
            units: tuple[str, str] | None = None) -> Figure:
    """``metric`` over the swept keys ``x`` (horizontal) and ``y`` (vertical).

    ``where`` fixes the other swept keys that vary in ``frame`` ({key: value}). Log axes
    and the log colour scale are chosen automatically when left at None. Diverged members
    are drawn light grey (their metrics stop at the divergence), except for the metrics
    about divergence itself (``diverged``, ``t_diverge``, ``n_samples``, ``settled``); the
    contour between settled and unsettled members is drawn in red and the unsettled cells are
    hatched. ``units``: the output's and the input's units for the colour bar, by default
    read from the sweep's case (``frame.attrs["sweep"]``, as :func:`load` keeps it).
    Returns the new figure, or ``ax``'s figure.
    """
    grid = _grid(frame, x, y, metric, where, log_x, log_y)
    norm = _norm([grid], log_color)
    if ax is None:
        fig = Figure(figsize=(7, 5.2), layout="constrained")
        ax = fig.subplots()
    else:
        fig = ax.get_figure()
    mesh = _draw(ax, grid, norm, title)
    fig.colorbar(mesh, ax=ax, label=_metrics.label(metric, *(units or _units(frame))),
                 extend=_extend([grid], norm))
    return fig


def _units(frame) -> tuple[str, str]:
    """The output's and input's units of the case a sweep's frame came from, when known."""
    from ..api.results.plotting import units
    from .cases import resolve_case

    meta = frame.attrs.get("sweep") or {}
    try:
        return units(resolve_case(meta["case"], meta.get("overrides") or {})[1])
    except (KeyError, TypeError, ValueError):  # not a sweep folder's frame, or a lost case
        return "output unit", "input unit"


def _case_title(folder: Path, metric: str) -> str | None:
    meta = folder / "sweep.json"
    if not meta.is_file():
        return None
    try:
        case = json.loads(meta.read_text()).get("case")
    except (OSError, ValueError, AttributeError):
        return None
    return f"{case}: {_metrics.LABELS.get(metric, (metric,))[0]}" if case else None


def draw_map(folder: str | Path, x: str, y: str, metric: str, path: str | Path | None = None,
             where: dict | None = None) -> Path:
    """The heat map of one sweep folder as a PNG. The default path is
    ``folder/map-{metric}-{x}-{y}.png`` (with ``-{key}={value}`` per fixed key when
    ``where`` is given, so maps at different slices do not overwrite each other)."""
    folder = Path(folder)
    frame = load(folder)
    if path is None:
        name = f"map-{metric}-{x}-{y}"
        name += "".join(f"-{k}={_fmt(v)}" for k, v in (where or {}).items())
        path = folder / f"{name}.png"
    fig = heatmap(frame, x, y, metric, where=where, title=_case_title(folder, metric))
    path = Path(path)
    if not path.suffix:  # a PNG, as savefig writes it: named so
        path = path.with_name(path.name + ".png")
    save_figure(fig, path)
    return path


def draw_maps_side_by_side(frames_and_titles: list[tuple[pd.DataFrame, str]], x: str, y: str,
                           metric: str, path: str | Path, *, where: dict | None = None,
                           log_color: bool | None = None,
                           units: tuple[str, str] | None = None) -> Path:
    """One row of heat maps on one colour scale (the same norm for every panel), e.g. two
    control laws swept over the same grid; each panel carries its title. ``where`` applies
    to every frame. Writes a PNG and returns its path."""
    if not frames_and_titles:
        raise ValueError("draw_maps_side_by_side: no frames given")
    grids = [_grid(frame, x, y, metric, where, None, None) for frame, _ in frames_and_titles]
    # One axis scale for every panel: log only if it suits all of them.
    log_x = all(g.log_x for g in grids)
    log_y = all(g.log_y for g in grids)
    for g in grids:
        g.log_x, g.log_y = log_x, log_y
    norm = _norm(grids, log_color)
    n = len(grids)
    fig = Figure(figsize=(4.8 * n + 1.2, 5.0), layout="constrained")
    axes = fig.subplots(1, n, sharex=True, sharey=True, squeeze=False)[0]
    mesh = None
    for ax, grid, (_, title) in zip(axes, grids, frames_and_titles, strict=True):
        grid.where = {}  # the fixed keys go to the figure title, once
        mesh = _draw(ax, grid, norm, title)
    assert mesh is not None  # there is a frame: checked above
    for ax in axes[1:]:
        ax.set_ylabel("")
    fig.colorbar(mesh, ax=list(axes), label=_metrics.label(
        metric, *(units or _units(frames_and_titles[0][0]))), extend=_extend(grids, norm))
    head = _what(metric, x, y)
    fixed = ", ".join(f"{k} = {_fmt(v)}" for k, v in (where or {}).items())
    fig.suptitle(head + (f" ({fixed})" if fixed else ""))
    path = Path(path)
    if not path.suffix:  # a PNG, as savefig writes it: named so
        path = path.with_name(path.name + ".png")
    save_figure(fig, path)
    return path
