"""The robustness map on the page: a Bokeh heat map of a
:class:`~mfcontrol.tuner.session.RobustnessMap`, drawn as the command line's maps are
(:mod:`mfcontrol.experiments.maps`): cells centred on the swept values (edges at the
geometric midpoints on a log axis), the colour scale set by the settled members, unsettled
members hatched, diverged ones grey (their metrics stop at the divergence), the current
setting marked; later changes of the settings move the mark, or dim the map and call it
stale (:meth:`MapFigure.show`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from bokeh.models import ColumnDataSource, HoverTool, LinearColorMapper, LogColorMapper, Range1d
from bokeh.models.annotations import ColorBar, Legend, LegendItem, Title
from bokeh.models.renderers import GlyphRenderer
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

from ..api.results import metrics as _metrics
from ..api.results.plotting import cell_edges
from ..experiments.maps import colour_range
from .session import SHORT, MapState, RobustnessMap

GREY = "#d1d1d1"  # matplotlib's "0.82": the colour of the CLI maps' diverged cells
STALE_ALPHA = 0.3  # a stale map's cells, faded
HATCH_ALPHA = 0.45


@dataclass
class MapFigure:
    """A drawn map and the parts a later change of the settings updates."""

    m: RobustnessMap
    fig: Any
    subtitle: Title
    here: ColumnDataSource
    here_item: LegendItem
    centre_item: LegendItem
    cells: GlyphRenderer
    hatch: GlyphRenderer | None
    shown: str = ""

    def retire(self) -> None:
        """Drop the names a page's script finds the map by: the browser keeps a replaced
        map's models, and two models of one name are an error there."""
        for model in (self.fig, self.subtitle, self.here):
            model.name = None

    def show(self, state: MapState) -> None:
        """Show how the map stands to the settings: the mark on the current setting (or
        none off the map), the map's own centre (+) once they differ, the cells faded and
        the subtitle red when stale; nothing sent when nothing changed."""
        key = f"{state.kind} {state.here} {state.title}"
        if key == self.shown:
            return
        self.shown = key
        self.subtitle.text = f"{state.title}, {self.m.seconds:.2f} s"
        self.subtitle.text_color = "#444444" if state.kind in ("current", "moved") \
            else "#b42318"
        self.here.data = ({"x": [state.here[0]], "y": [state.here[1]]} if state.here
                          else {"x": [], "y": []})
        self.here_item.visible = state.here is not None
        self.centre_item.visible = state.kind != "current"
        fade = STALE_ALPHA if state.kind == "stale" else 1.0
        self.cells.glyph.fill_alpha = fade
        if self.hatch is not None:
            self.hatch.glyph.hatch_alpha = HATCH_ALPHA * fade


def _any(*renderers: Any) -> list[Any]:
    """Renderers for a legend item (Bokeh's stubs hold GlyphRenderer invariant in its
    glyph, so a quad's renderer does not type as a glyph's)."""
    return list(renderers)


def _mapper(m: RobustnessMap):
    """Viridis over the CLI maps' colour range (:func:`mfcontrol.experiments.maps.
    colour_range`: the settled members' values, logarithmic over more than two decades);
    members beyond it take its end colours (they are hatched: unsettled)."""
    lo, hi, log = colour_range([(m.z, m.settled)], m.metric)
    mapper = LogColorMapper if log else LinearColorMapper
    return mapper(palette=Viridis256, low=lo, high=hi, nan_color=GREY)


def draw(m: RobustnessMap, units: tuple[str, str], labels: tuple[str, str],
         width: int = 720, height: int = 470) -> MapFigure:
    """The map as a Bokeh figure (``units``: the output's and the input's, for the colour
    bar's metric; ``labels``: the axes' in the plant's words, :meth:`Session.label`),
    drawn around the settings it was run under (:meth:`MapFigure.show` then marks the
    current ones)."""
    ex, ey = cell_edges(m.xs, m.log_x), cell_edges(m.ys, m.log_y)
    rows, cols = np.indices(m.z.shape)
    iy, ix = rows.ravel(), cols.ravel()
    z = m.z.ravel()
    shown = np.where(m.diverged.ravel(), math.nan, z)  # a diverged member's metric stops
    verdict = np.where(m.diverged.ravel(), "diverged",
                       np.where(m.settled.ravel(), "settled", "not settled"))
    src = ColumnDataSource({
        "left": ex[ix], "right": ex[ix + 1], "bottom": ey[iy], "top": ey[iy + 1],
        "x": m.xs[ix], "y": m.ys[iy], "z": shown, "verdict": verdict})
    metric_words = SHORT.get(m.metric, m.metric)
    words = [label.split(" (")[0] for label in labels]  # without the unit, as quantity()
    fig = figure(width=width, height=height, toolbar_location="right", name="robustness-map",
                 x_axis_type="log" if m.log_x else "linear",
                 y_axis_type="log" if m.log_y else "linear",
                 x_range=Range1d(ex[0], ex[-1]), y_range=Range1d(ey[0], ey[-1]),
                 title=Title(text=f"Robustness map: {metric_words} over {words[0]} and "
                                  f"{words[1]}", text_font_size="12pt"),
                 tools="pan,wheel_zoom,box_zoom,reset,save")
    # Bokeh does not wrap a title: the second line is a title of its own, nearer the plot
    subtitle = Title(text=f"{m.z.size} runs around the current setting (marked), "
                          f"{m.seconds:.2f} s", text_font_size="10pt",
                     text_font_style="normal", text_color="#444444", name="map-subtitle")
    fig.add_layout(subtitle, "above")
    mapper = _mapper(m)
    cells = fig.quad(left="left", right="right", bottom="bottom", top="top", source=src,
                     fill_color={"field": "z", "transform": mapper}, line_color=None)
    unsettled = ~m.settled.ravel() & ~m.diverged.ravel()
    legend = []
    hatch = None
    if unsettled.any():
        sel = np.flatnonzero(unsettled)
        hatch = fig.quad(left=ex[ix[sel]], right=ex[ix[sel] + 1], bottom=ey[iy[sel]],
                         top=ey[iy[sel] + 1], fill_alpha=0.0, line_color=None,
                         hatch_pattern="/", hatch_color="black", hatch_alpha=HATCH_ALPHA,
                         hatch_scale=10)
        legend.append(LegendItem(label=f"not settled ({int(unsettled.sum())} of {z.size}), "
                                       "hatched", renderers=_any(hatch)))
    if m.diverged.any():
        grey = fig.quad(left=[], right=[], bottom=[], top=[], fill_color=GREY,
                        line_color="#808080")
        legend.append(LegendItem(label=f"diverged ({int(m.diverged.sum())} of {z.size})",
                                 renderers=_any(grey)))
    centre = fig.scatter([m.at[0]], [m.at[1]], marker="cross", size=14, line_color="black",
                         line_width=2)
    centre_item = LegendItem(label="the map's centre", renderers=_any(centre), visible=False)
    here_src = ColumnDataSource({"x": [m.at[0]], "y": [m.at[1]]}, name="map-here")
    here = fig.scatter("x", "y", source=here_src, marker="circle_cross", size=16,
                       fill_color="white", fill_alpha=0.3, line_color="black", line_width=2)
    here_item = LegendItem(label="current setting", renderers=_any(here))
    legend += [here_item, centre_item]
    fig.add_layout(Legend(items=legend, orientation="horizontal", location="center",
                          label_text_font_size="10pt", border_line_color=None), "below")
    fig.xaxis.axis_label, fig.yaxis.axis_label = labels
    for ax in (fig.xaxis, fig.yaxis):
        ax.axis_label_text_font_size = "11pt"
        ax.axis_label_text_font_style = "normal"
    fig.add_layout(ColorBar(color_mapper=mapper, title=_metrics.label(m.metric, *units),
                            title_text_font_size="10pt", title_text_font_style="normal",
                            width=14), "right")
    fig.add_tools(HoverTool(renderers=[cells], tooltips=[
        (m.x, "@x{%.4g}"), (m.y, "@y{%.4g}"), (m.metric, "@z{%.4g}"), ("verdict", "@verdict")],
        formatters={"@x": "printf", "@y": "printf", "@z": "printf"}))
    fig.grid.visible = False
    return MapFigure(m, fig, subtitle, here_src, here_item, centre_item, cells,
                     hatch if unsettled.any() else None)

