"""The tuner's page: a Bokeh document built from a :class:`~mfcontrol.tuner.session.Session`.

Left, the options the case's run reads, in groups, each number as a slider (over log10 of
a positive gain) with a typed entry and its message line; centre, the output against its
reference, the controller's output and, where the gain adapts, gamma, with a frozen run in
grey, and below them the linear loop (:func:`mfcontrol.analyze`): the gains of L, S, T and
C_y S and L's phase over frequency, and the Nyquist curve with the Ms circle; right, the
metrics of the run and the linear loop's margins (and the frozen runs'), the buttons, the
robustness map's and the tuning's controls. Every change runs and analyses the case again
and redraws.

Every callback catches what it raises and shows it on the page: one page's bad input never
stops the server. The two long jobs run in a thread each and come back to the document
through ``doc.add_next_tick_callback``, the only safe way into a Bokeh document from
another thread.
"""

from __future__ import annotations

import functools
import html
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from bokeh.core.properties import value
from bokeh.document import Document
from bokeh.layouts import column, row
from bokeh.models import ColumnDataSource, CustomJS, InlineStyleSheet, Range1d
from bokeh.models.annotations import LabelSet, Span, Title
from bokeh.models.layouts import TabPanel, Tabs
from bokeh.models.widgets import Button, Div, MultiChoice, Select, Slider, Spinner, TextInput
from bokeh.plotting import figure

from ..analysis.loop import frequencies
from ..api.results import metrics as _metrics
from ..api.results.plotting import plain_labels, units
from ..api.results.result import Result
from ..config.resolve import Config
from ..errors import ConfigError
from . import heatmap
from .scale import scale_for
from .session import (
    DIGITS,
    LABELS,
    LINEAR_SHOWN,
    MAP_METRICS,
    MAX_FROZEN,
    SHORT,
    TABLE_METRICS,
    Field,
    RunRefused,
    Session,
    brief,
    control_figures,
    refusal,
    text_of,
)

log = logging.getLogger(__name__)

#: plotted points of a trajectory at most; longer runs keep each stretch's extremes. A
#: plot is some 600 pixels wide: 2,000 points with each stretch's extremes draw the same
#: picture as 10,000, and the browser's drawing was most of a change's round trip
MAX_POINTS = 2_000
LEFT, CENTRE, RIGHT = 400, 760, 400
CURRENT, FROZEN, REFERENCE, GAMMA = "#d62728", "#9a9a9a", "#1f4e9c", "#7b3294"
MEASURED = "#f4a582"  # the measured output, light under the true one
#: each frozen slot's line (all grey): the oldest solid
FROZEN_DASHES = ("solid", "dashed", "dotted")
#: the signals plotted of the current run and of a frozen one
CURRENT_SIGNALS = ("y_ref", "y", "y_meas", "u", "gamma")
FROZEN_SIGNALS = ("y", "u", "gamma")
MAP_LABEL, REDRAW_LABEL = "Robustness map (9 x 9)", "Redraw map (9 x 9)"
MAP_HELP = "Each axis: 9 values from the current one / 3 to x 3 (log-spaced when positive)."
_NOT_DRAWN = object()
#: how long the changes must pause before the linear loop is analysed and sent (ms).
#: Analysed on the next tick after each run, the analysis (20 to 130 ms) held the server's
#: loop and its figures the browser's frame: a change's metrics reached the page in a
#: median 107 ms instead of 85, its frame in 237 instead of 132 (bench_tuner.py)
AFTER_MS = 250
#: frequencies of the linear loop's plots (:func:`mfcontrol.analysis.loop.frequencies`:
#: five decades below the Nyquist frequency, as ``mfcontrol analyze``'s figure)
FREQUENCIES = 400
#: the gains of the Bode plot: column, legend, colour, dash
GAINS = (("L", "loop gain |L|", "#000000", "solid"),
         ("S", "sensitivity |S|", "#d62728", "solid"),
         ("T", "complementary sensitivity |T|", "#1f77b4", "solid"),
         ("CS", "noise to control |C_y S|", "#2ca02c", "dashed"))
LINEAR_COLUMNS = ("w", *(g[0] for g in GAINS), "phase", "re", "im", "im_mirror")

#: a tab's title where the group's name is too long for five tabs in the panel
TAB_TITLES = {"sensor, actuator, disturbance": "elements"}

_TABLE_CSS = """
table { border-collapse: collapse; font: 13px/1.35 system-ui, sans-serif; width: 100%; }
th, td { padding: 3px 6px; border-bottom: 1px solid #e3e3e3; text-align: right; }
th:first-child, td:first-child { text-align: left; }
th { font-weight: 600; color: #333; }
span.unit { color: #666; font-size: 11px; margin-left: 5px; }
td.frozen, th.frozen { color: #777; }
td.better { color: #1a7f37; } td.worse { color: #b42318; }
.verdict-no { color: #b42318; font-weight: 600; }
p.verdict { font: 13px/1.4 system-ui, sans-serif; margin: 0 0 6px 0; }
p.frozen-caption { font: 12px/1.35 system-ui, sans-serif; color: #555; margin: 4px 0 0 0; }
"""


def _guarded(method: Callable) -> Callable:
    """Run a callback so that whatever it raises is shown on the page, not raised into
    the server."""
    @functools.wraps(method)
    def wrapper(self: TunerPage, *args: Any, **kwargs: Any) -> Any:
        try:
            return method(self, *args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - the server outlives any one input
            log.exception("tuner callback %s", method.__name__)
            self.status(f"{type(exc).__name__}: {exc}", error=True)
            return None
    return wrapper


def _slug(key: str) -> str:
    return key.replace(".", "-").replace("_", "-")


def fmt(v: Any) -> str:
    """A metric as the table shows it."""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.4g}"


def _fills(div: Div, column: str) -> CustomJS:
    """A script that puts the HTML of a data source's ``column`` in ``div``'s element, not
    as the Div's text (which would lay the whole page out again)."""
    return CustomJS(args={"div": div}, code=f"""
        const html = cb_obj.data.{column}[0];
        const view = Bokeh.index.find_one(div);
        if (view != null && view.markup_el != null) {{
            view.markup_el.innerHTML = html;
        }} else {{
            div.text = html;  // a Bokeh without markup_el: the same, with a layout
        }}
    """)


def keep_points(n: int, columns: list[np.ndarray], limit: int = MAX_POINTS) -> np.ndarray:
    """Indices of the samples to plot: all of them up to ``limit``, else each stretch's
    first sample and every column's least and largest one (an oscillation keeps its
    envelope, as a plain stride would not)."""
    if n <= limit:
        return np.arange(n)
    stretches = max(1, limit // (2 * len(columns) + 1))
    size = n // stretches
    m = size * stretches
    base = np.arange(stretches) * size
    keep = [base, np.array([n - 1])]
    for c in columns:
        a = np.nan_to_num(np.asarray(c[:m], dtype=float), nan=0.0, posinf=0.0,
                          neginf=0.0).reshape(stretches, size)
        keep += [base + a.argmin(axis=1), base + a.argmax(axis=1)]
    return np.unique(np.concatenate(keep))


def _finite(a: np.ndarray) -> np.ndarray:
    """float32 for the browser, with an infinity as a gap (NaN) instead of an axis that
    cannot scale."""
    with np.errstate(over="ignore"):  # beyond float32 is inf, then a gap: no warning
        out = np.asarray(a, dtype=np.float32)
    return np.where(np.isfinite(out), out, np.float32(np.nan))


class FieldView:
    """The widgets of one option: a slider and an entry for a number, a menu for a choice,
    an entry for a list; and the line for its message."""

    def __init__(self, page: TunerPage, field: Field) -> None:
        self.page, self.field, self.key = page, field, field.key
        slug = _slug(field.key)
        value = page.session.value(field.key)
        self.slider: Slider | None = None
        self.entry: TextInput | None = None
        self.select: Select | None = None
        self.message = Div(text="", visible=False, width=LEFT - 30,
                           css_classes=["mf-message", f"mf-message-{slug}"],
                           styles={"color": "#b42318", "font-size": "12px"})
        # the title in the plant's words, the key (what --set and a case file name) in
        # the help beside it
        title = field.label or field.key
        doc = f"{field.key}: {field.doc}"
        if field.kind == "choice":
            choices: list[str | tuple[Any, str]] = list(field.choices)
            self.select = Select(title=title, value=text_of(value),
                                 options=choices, width=LEFT - 40,
                                 description=doc, css_classes=[f"mf-select-{slug}"])
            self.select.on_change("value", self._on_select)
            widgets: list = [self.select]
        elif field.kind == "list":
            self.entry = TextInput(title=title, value=text_of(value), width=LEFT - 40,
                                   description=doc, css_classes=[f"mf-entry-{slug}"])
            self.entry.on_change("value", self._on_entry)
            widgets = [self.entry]
        else:
            self.scale = scale_for(field.key, value)
            unset = value is None
            self.slider = Slider(start=self.scale.start, end=self.scale.end,
                                 step=self.scale.step, show_value=False, width=LEFT - 170,
                                 value=0.0 if unset else self.scale.coordinate(value),
                                 title=self._title(), disabled=unset,
                                 css_classes=[f"mf-slider-{slug}"])
            self.entry = TextInput(value=text_of(value), width=115, title="value",
                                   placeholder="unset" if unset else "",
                                   description=doc, css_classes=[f"mf-entry-{slug}"])
            self.slider.on_change("value", self._on_slider)
            self.entry.on_change("value", self._on_entry)
            widgets = [row(self.slider, self.entry, spacing=6)]
        self.layout = column(*widgets, self.message, spacing=0)

    def _title(self) -> str:
        return (self.field.label or self.key) + (" (log scale)" if self.scale.log else "")

    # a widget set from here triggers its own callback: ``page.quiet`` tells it apart
    def _on_slider(self, attr: str, old: Any, new: Any) -> None:
        if not self.page.quiet:
            self.page.change(self, text_of(self.scale.value(new)), slide=True)

    def _on_entry(self, attr: str, old: Any, new: Any) -> None:
        if not self.page.quiet:
            self.page.change(self, new)

    def _on_select(self, attr: str, old: Any, new: Any) -> None:
        if not self.page.quiet:
            self.page.change(self, new)

    def show_error(self, text: str | None) -> None:
        self.message.text = html.escape(text or "")
        self.message.visible = bool(text)

    def show_value(self, value: Any) -> None:
        """Show the session's value (the page is quiet while this runs)."""
        if self.select is not None:
            self.select.value = text_of(value)
            return
        assert self.entry is not None
        self.entry.value = text_of(value)
        if self.slider is None:
            return
        if value is None:
            self.slider.disabled = True
            return
        self.slider.disabled = False
        if not self.scale.holds(value):  # a typed value off the slider: centre it there
            self.scale = scale_for(self.key, value)
            self.slider.update(start=self.scale.start, end=self.scale.end,
                               step=self.scale.step, title=self._title())
        self.slider.value = self.scale.coordinate(value)


class TunerPage:
    """The document of one browser tab and its session."""

    def __init__(self, doc: Document, session: Session) -> None:
        self.doc, self.session = doc, session
        self.quiet = False
        self.runs = 0
        self._unsent = ""  # the metrics of the last redraw, until _publish sends them
        self.views: dict[str, FieldView] = {}
        self._stop_tune = threading.Event()
        self._busy = False
        self._status_error = False
        self._tuned_from: Config | None = None
        self._scale = 1.0
        # the run each frozen slot shows (none yet: the first redraw hides the empty ones)
        self._frozen_shown: list[Any] = [_NOT_DRAWN] * MAX_FROZEN
        self._pending: Any = None  # the linear loop's analysis, waiting for a pause
        self._tab_titles: list[str] = []
        self._shown_keys: list[str] = []  # the options the fields show, in the session's order
        self._status_note = False
        self.map_view: heatmap.MapFigure | None = None
        self._map_shown: str | None = None  # the map's state last shown
        self._map_done_text = ""
        self._build()
        self._rebuild_fields()
        self.redraw()
        doc.on_session_destroyed(lambda _ctx: self._stop_tune.set())

    # --- layout -----------------------------------------------------------------------

    def _build(self) -> None:
        s = self.session
        self.head = Div(text=self._head(), width=LEFT + CENTRE + RIGHT, css_classes=["mf-head"])
        self.status_div = Div(text="", width=LEFT, css_classes=["mf-status"],
                              styles={"font-size": "12px"})
        self.tabs = Tabs(tabs=[], width=LEFT, css_classes=["mf-tabs"])
        self.src = ColumnDataSource({k: [] for k in ("t", *CURRENT_SIGNALS)},
                                    name="current-run")
        self.frz = [ColumnDataSource({k: [] for k in ("t", *FROZEN_SIGNALS)},
                                     name=f"frozen-run-{i + 1}") for i in range(MAX_FROZEN)]
        self.events = ColumnDataSource({"t": [], "text": []}, name="events")
        self.out_fig = self._figure("Output and reference", 300)
        self.u_fig = self._figure("Controller output", 210, x_range=self.out_fig.x_range)
        self.g_fig = self._figure("Adaptive gain gamma", 190, x_range=self.out_fig.x_range)
        self._draw_traces()
        self._build_linear()

        self.metrics = Div(width=RIGHT, css_classes=["mf-metrics"],
                           stylesheets=[InlineStyleSheet(css=_TABLE_CSS)])
        self.linear_div = Div(width=RIGHT, css_classes=["mf-linear"],
                              stylesheets=[InlineStyleSheet(css=_TABLE_CSS)])
        self.linear_text = ColumnDataSource({"html": [""]}, name="linear-text")
        self.linear_text.js_on_change("data", _fills(self.linear_div, "html"))
        self.freeze_button = Button(label="Freeze this run", width=112,
                                    css_classes=["mf-freeze"])
        self.clear_button = Button(label="Clear frozen", width=96, disabled=True,
                                   css_classes=["mf-clear"])
        self.undo_button = Button(label="Undo", width=70, disabled=True,
                                  css_classes=["mf-undo"])
        self.save_button = Button(label="Save case", width=90, button_type="primary",
                                  css_classes=["mf-save"])
        self.freeze_button.on_click(self.freeze)
        self.clear_button.on_click(self.clear)
        self.undo_button.on_click(self.undo)
        # what changes in words at every run: the metrics and the case's text. Bokeh lays
        # the whole page out again whenever a Div's text changes (some 50 ms with this many
        # widgets, half the round trip), so they travel in a data source, one message
        # with the traces' one, and a script puts the metrics in the Div's element
        self.page_text = ColumnDataSource({"metrics": [""], "toml": [""],
                                           "filename": [f"{s.name}.toml"]}, name="page-text")
        self.page_text.js_on_change("data", _fills(self.metrics, "metrics"))
        self.save_button.js_on_click(CustomJS(args={"store": self.page_text}, code="""
            const text = store.data.toml[0];
            const blob = new Blob([text], {type: "application/toml"});
            const url = URL.createObjectURL(blob);
            const a = document.createElement("a");
            a.href = url;
            a.download = store.data.filename[0];
            document.body.appendChild(a);
            a.click();
            a.remove();
            setTimeout(() => URL.revokeObjectURL(url), 10000);
        """))

        metric_options: list[str | tuple[Any, str]] = [(m, SHORT.get(m, m))
                                                        for m in MAP_METRICS]
        self.map_x = Select(title="map: horizontal axis", width=RIGHT // 2 - 10,
                            css_classes=["mf-map-x"], name="map-x")
        self.map_y = Select(title="vertical axis", width=RIGHT // 2 - 10,
                            css_classes=["mf-map-y"], name="map-y")
        self.map_metric = Select(title="metric", value="iae", options=metric_options,
                                 width=RIGHT // 2 - 10, css_classes=["mf-map-metric"])
        self.map_button = Button(label=MAP_LABEL, width=RIGHT // 2 - 10,
                                 css_classes=["mf-map"], align="end")
        self.map_button.on_click(self.start_map)
        self.map_status = Div(text=MAP_HELP, width=RIGHT, css_classes=["mf-map-status"],
                              styles={"font-size": "12px"})
        self.map_holder = column(Div(text=""), css_classes=["mf-map-figure"], name="map")

        self.tune_keys = MultiChoice(title="tune: options (bounds: current / 10 .. x 10)",
                                     width=RIGHT, css_classes=["mf-tune-keys"],
                                     name="tune-keys")
        self.budget = Spinner(title="budget (points)", low=10, step=10, value=200,
                              width=RIGHT // 3 - 10, css_classes=["mf-budget"], name="budget")
        self.objective = Select(title="objective", value="iae", options=metric_options,
                                width=RIGHT // 3 - 10, css_classes=["mf-objective"])
        self.tune_button = Button(label="Tune", width=70, button_type="success",
                                  css_classes=["mf-tune"], align="end")
        self.stop_button = Button(label="Stop", width=60, disabled=True,
                                  css_classes=["mf-tune-stop"], align="end")
        self.tune_button.on_click(self.start_tune)
        self.stop_button.on_click(lambda: self._stop_tune.set())
        self.tune_status = Div(text="", width=RIGHT, css_classes=["mf-tune-status"],
                               styles={"font-size": "12px"})

        def heading(text: str) -> Div:
            return Div(text=f"<b>{text}</b>", width=RIGHT,
                       styles={"margin-top": "10px", "font-size": "14px"})

        right = column(
            heading("Metrics"), self.metrics,
            row(self.freeze_button, self.clear_button, self.undo_button, self.save_button,
                spacing=4),
            heading("Linear loop (mfcontrol.analyze)"), self.linear_div,
            heading("Robustness"), row(self.map_x, self.map_y),
            row(self.map_metric, self.map_button), self.map_status,
            heading("Tuning by simulation (mfcontrol.tune)"), self.tune_keys,
            row(self.budget, self.objective, self.tune_button, self.stop_button),
            self.tune_status, width=RIGHT)
        centre = column(self.out_fig, self.u_fig, self.g_fig, self.linear_title,
                        row(column(self.gain_fig, self.phase_fig), self.nyq_fig),
                        self.map_holder)
        left = column(Div(text="<b>Options the run reads</b> (type a value and press "
                      "Enter; an empty entry returns to the case's value)", width=LEFT,
                          styles={"font-size": "13px"}),
                      self.status_div, self.tabs, width=LEFT)
        self.doc.add_root(column(self.head, row(left, centre, right, spacing=14)))
        # a data source no plot draws reaches the browser only as a root of its own
        self.doc.add_root(self.linear_text)
        self.doc.title = f"mfcontrol tuner: {s.name}"

    def _figure(self, title: str, height: int, width: int = CENTRE, **kwargs: Any):
        fig = figure(width=width, height=height, title=Title(text=title, text_font_size="12pt"),
                     tools="pan,box_zoom,wheel_zoom,reset,save", toolbar_location="right",
                     **kwargs)
        for ax in (fig.xaxis, fig.yaxis):
            ax.axis_label_text_font_size = "11pt"
            ax.axis_label_text_font_style = "normal"
        return fig

    def _draw_traces(self) -> None:
        o, u, g = self.out_fig, self.u_fig, self.g_fig
        for i, src in enumerate(self.frz):
            for fig, col in ((o, "y"), (u, "u"), (g, "gamma")):
                fig.line("t", col, source=src, color=FROZEN, line_width=2.2,
                         line_dash=FROZEN_DASHES[i], legend_label=f"frozen {i + 1}")
        for fig in (o, u, g):
            fig.vspan(x="t", source=self.events, line_color="#555555", line_dash="dotted",
                      line_width=1.5, **({"legend_label": "scheduled change"}
                                         if fig is o else {}))
        # each scheduled change in words at the top of the output's plot
        o.add_layout(LabelSet(x="t", y=6, y_units="screen", text="text", source=self.events,
                              x_offset=-4, text_font_size="9pt", text_color="#333333",
                              text_baseline="bottom", angle=math.pi / 2,
                              background_fill_color="white", background_fill_alpha=0.75))
        o.line("t", "y_ref", source=self.src, color=REFERENCE, line_dash="dashed",
               line_width=1.5, legend_label="reference")
        self._measured = o.line("t", "y_meas", source=self.src, color=MEASURED,
                                line_width=1.0, alpha=0.8, legend_label="measured output",
                                name="measured-output")
        o.line("t", "y", source=self.src, color=CURRENT, line_width=1.6,
               legend_label="output")
        u.line("t", "u", source=self.src, color="#2ca02c", line_width=1.4,
               legend_label="controller output")
        g.line("t", "gamma", source=self.src, color=GAMMA, line_width=1.6,
               legend_label="gamma")
        # the legend items of each frozen slot, in every plot, and the measured output's
        self._frozen_items = [[item for fig in (o, u, g) for item in fig.legend.items
                               if item.label.value == f"frozen {i + 1}"]
                              for i in range(MAX_FROZEN)]
        self._measured_item = next(item for item in o.legend.items
                                   if item.label.value == "measured output")
        for fig in (o, u, g):
            # the ramps and the duty rise to the right; gamma falls from its start
            fig.legend.location = "bottom_left" if fig is g else "top_left"
            fig.legend.label_text_font_size = "10pt"
            fig.legend.background_fill_alpha = 0.7
            fig.legend.click_policy = "hide"

    def _build_linear(self) -> None:
        """The linear loop's figures: the gains and L's phase over frequency (left), the
        Nyquist curve near -1 with the Ms circle (right); empty while there is none."""
        self.linear_title = Div(text="", width=CENTRE, css_classes=["mf-linear-title"],
                                styles={"font-size": "14px", "margin-top": "8px"})
        self.lin_src = ColumnDataSource({k: [] for k in LINEAR_COLUMNS}, name="linear-loop")
        self.ms_src = ColumnDataSource({"x": [], "y": []}, name="ms-circle")
        wide = CENTRE - 320
        self.gain_fig = self._figure("Gains of the linear loop", 250, width=wide,
                                     x_axis_type="log")
        self.phase_fig = self._figure("Phase of the loop gain L", 180, width=wide,
                                      x_axis_type="log", x_range=self.gain_fig.x_range)
        for col, label, colour, dash in GAINS:
            self.gain_fig.line("w", col, source=self.lin_src, color=colour, line_dash=dash,
                               line_width=1.6 if col == "L" else 1.3, legend_label=label)
        self.ms_line = Span(location=0.0, dimension="width", line_color="#d62728",
                            line_dash="dotted", line_width=1.2)
        self.gain_fig.add_layout(self.ms_line)
        self.gain_fig.add_layout(Span(location=0.0, dimension="width",
                                      line_color="#999999", line_width=1.0))
        self.gain_fig.yaxis.axis_label = "gain (dB)"
        self.gain_fig.legend.location = "bottom_left"
        self.gain_fig.legend.label_text_font_size = "9pt"
        self.gain_fig.legend.background_fill_alpha = 0.7
        self.gain_fig.legend.click_policy = "hide"
        self.phase_fig.line("w", "phase", source=self.lin_src, color="#000000", line_width=1.4)
        self.phase_fig.add_layout(Span(location=-180.0, dimension="width",
                                       line_color="#999999", line_width=1.0))
        self.phase_fig.yaxis.axis_label = "phase of L (deg)"
        self.phase_fig.xaxis.axis_label = "frequency (rad/s), up to the Nyquist frequency"
        circle = np.exp(1j * np.linspace(0.0, 2.0 * math.pi, 200))
        # a square frame over square ranges: a circle drawn round
        self.nyq_fig = self._figure("Nyquist curve near -1", 430, width=310,
                                    x_range=Range1d(start=-3.0, end=2.0),
                                    y_range=Range1d(start=-2.5, end=2.5))
        self.nyq_fig.frame_width = self.nyq_fig.frame_height = 230
        self.nyq_fig.line(circle.real, circle.imag, color="#bbbbbb", line_width=1.0,
                          legend_label="unit circle")
        self.nyq_fig.line("re", "im", source=self.lin_src, color="#000000", line_width=1.6,
                          legend_label="L, w > 0")
        self.nyq_fig.line("re", "im_mirror", source=self.lin_src, color="#000000",
                          line_width=1.0, line_dash="dotted", legend_label="w < 0")
        self.nyq_fig.line("x", "y", source=self.ms_src, color="#d62728", line_dash="dashed",
                          line_width=1.2, legend_label="distance 1/Ms from -1")
        self.nyq_fig.scatter([-1.0], [0.0], marker="cross", size=14, line_width=2.5,
                             color="#d62728", legend_label="-1")
        self.nyq_fig.xaxis.axis_label = "real part of L"
        self.nyq_fig.yaxis.axis_label = "imaginary part of L"
        self.nyq_fig.legend.location = "bottom_right"
        self.nyq_fig.legend.label_text_font_size = "9pt"
        self.nyq_fig.legend.background_fill_alpha = 0.7

    def _show_linear(self, a: Any) -> None:
        """The linear loop of the current settings in the figures (empty where there is
        none: ``a`` is then the reason, in words)."""
        # the title only when it changes: a Div's new text lays the page out again
        title = ("<b>Linear loop</b> (mfcontrol.analyze: no noise, no limits; its margins "
                 "are on the right)" if not isinstance(a, str) else
                 f"<b>Linear loop</b>: no analysis of these settings ({html.escape(a)})")
        if self.linear_title.text != title:
            self.linear_title.text = title
        if isinstance(a, str):
            self.lin_src.data = {k: [] for k in LINEAR_COLUMNS}
            self.ms_src.data = {"x": [], "y": []}
            return
        m = a.margins
        w = frequencies(a.sample_time, FREQUENCIES)
        resp = a.loop.frequency_response(w)

        def db(x: np.ndarray) -> np.ndarray:
            with np.errstate(divide="ignore"):
                return _finite(20.0 * np.log10(np.abs(x)))

        L = resp["L"]
        self.lin_src.data = {"w": _finite(w), **{g[0]: db(resp[g[0]]) for g in GAINS},
                             "phase": _finite(np.degrees(np.unwrap(np.angle(L)))),
                             "re": _finite(L.real), "im": _finite(L.imag),
                             "im_mirror": _finite(-L.imag)}
        ms = m["Ms"]
        if math.isfinite(ms) and ms > 0:
            circle = -1.0 + np.exp(1j * np.linspace(0.0, 2.0 * math.pi, 200)) / ms
            self.ms_src.data = {"x": _finite(circle.real), "y": _finite(circle.imag)}
            self.ms_line.location = 20.0 * math.log10(ms)
            self.ms_line.visible = True
        else:
            self.ms_src.data = {"x": [], "y": []}
            self.ms_line.visible = False

    def _rebuild_fields(self) -> None:
        """The option widgets, grouped, and the lists of numbers the map and the tuning
        offer: again whenever the options the run reads change (a model, a law)."""
        groups = self.session.groups()
        self._shown_keys = [f.key for f in self.session.fields()]
        self.views = {}
        panels = []
        active_title = (self._tab_titles[self.tabs.active] if self._tab_titles
                        else "controller")
        for name, fields in groups.items():
            if not fields:
                continue
            views = [FieldView(self, f) for f in fields]
            self.views.update({v.key: v for v in views})
            heading = Div(text=f"<i>{html.escape(name)}</i>", styles={"color": "#555"})
            panels.append(TabPanel(title=TAB_TITLES.get(name, name),
                                   child=column(heading, *[v.layout for v in views], spacing=4)))
        titles = self._tab_titles = [p.title for p in panels]
        self.quiet = True
        try:
            self.tabs.update(tabs=panels, active=titles.index(active_title)
                             if active_title in titles else 0)
            keys = self.session.numeric_keys()
            # a menu entry in the plant's words, its value the key
            options: list[str | tuple[Any, str]] = [(k, self.session.label(k)) for k in keys]
            x, y = self.session.map_axes()
            if self.map_x.value in keys and self.map_y.value in keys \
                    and self.map_x.value != self.map_y.value:  # the user's choice stays
                x, y = self.map_x.value, self.map_y.value
            self.map_x.update(options=options, value=x)
            self.map_y.update(options=options, value=y)
            chosen = [k for k in self.tune_keys.value if k in keys] or \
                self.session.tuned_keys()
            self.tune_keys.update(options=options, value=chosen)
        finally:
            self.quiet = False

    # --- changes ----------------------------------------------------------------------

    @_guarded
    def change(self, view: FieldView, text: str, slide: bool = False) -> None:
        """An option typed, slid or chosen: set it, run, redraw; a refused entry (by the
        option's check, or by the law or plant its run builds) shows its one-line message
        beside the field and in the status line, and changes nothing: the run before
        stays drawn, nothing is logged. What else the change set (a law's gains, the
        case's value of an emptied entry) is said in the status line."""
        before = self.session.snapshot()
        error = self.session.set(view.key, text, slide=slide)
        if error is None:
            try:
                self.redraw(publish=False)
            except ConfigError as exc:  # the run refused it (a trajectory too long, say)
                self.session.restore(before)
                error = str(exc)
            except RunRefused as exc:  # the law refused it (a window of 1 sample, say)
                error = refusal(view.key, self.session.value(view.key), str(exc))
                self.session.restore(before)
                # the page says it; the cause for whoever debugs with the log at DEBUG
                log.debug("tuner: %s", error, exc_info=exc.__cause__)
            except Exception:
                self.session.restore(before)  # as if never set, and reported
                raise
        if error is not None:
            # the menu or slider back to the value in force (it showed the refused one,
            # while the session and a saved case kept the old); the run before stays
            # drawn (the refused one failed before drawing anything)
            self._show(view)
            view.show_error(error)
            self.status(f"{view.key} not changed: {error}", error=True)
            return
        view.show_error(None)
        if self.session.note:
            self.status(self.session.note)
        elif self._status_error or self._status_note:  # an old line no longer applies
            self.status("")
        self._after_settings(before[0])
        self._publish()

    def _after_settings(self, then: Config) -> None:
        """The fields after the settings changed from ``then``: built again when the
        options shown changed, else each field whose value changed shown anew."""
        if [f.key for f in self.session.fields()] != self._shown_keys:
            self._rebuild_fields()
            return
        for key, view in self.views.items():
            if then[key] != self.session.value(key) or not _same_text(
                    view, self.session.value(key)):
                self._show(view)
        self.undo_button.disabled = not self.session.can_undo()

    @_guarded
    def undo(self) -> None:
        """Back one step (:meth:`Session.undo`) and redraw."""
        then = self.session.cfg
        what = self.session.undo()
        if what is None:
            self.status("nothing to undo")
            return
        self.redraw(publish=False)
        for view in self.views.values():
            view.show_error(None)
        self._after_settings(then)
        self.status(f"undone: {what}")
        self._publish()

    def _show(self, view: FieldView) -> None:
        self.quiet = True
        try:
            view.show_value(self.session.value(view.key))
        finally:
            self.quiet = False

    def status(self, text: str, error: bool = False) -> None:
        # only when it changes: a Div's new text lays the whole page out again (~50 ms)
        self._status_error = error
        self._status_note = bool(text) and not error
        color = "#b42318" if error else "#333333"
        new = f'<span style="color:{color}">{html.escape(text)}</span>'
        if self.status_div.text != new:
            self.status_div.text = new

    # --- drawing ----------------------------------------------------------------------

    def redraw(self, publish: bool = True) -> None:
        """Run the session and show the run: traces, metrics, the case's text, the frozen
        runs, how a map drawn before stands to the settings. ``publish=False``: all but the
        metrics, which the caller sends with :meth:`_publish` once the fields and the status
        line are shown too (the metrics are what the page reads as "redrawn")."""
        r = self.session.run()
        self.runs += 1
        s = self.session
        y_label, u_label = plain_labels(s.cfg)
        t_end = s.cfg["sim.t_end"]
        self._scale, t_label = (1e3, "time t (ms)") if t_end < 1.0 else (1.0, "time t (s)")
        # Bokeh's server sends each change as a message of its own, which the browser
        # applies in order: the traces first, the metrics (which a user, and the round-trip
        # test, read as "redrawn") after them; and nothing that has not changed
        self.src.data = self._columns(r, CURRENT_SIGNALS)
        # the measured output where it is not the output itself (noise, resolution, delay)
        measured = not np.array_equal(r.signals["y_meas"], r.signals["y"], equal_nan=True)
        if self._measured.visible != measured:
            self._measured.visible = self._measured_item.visible = measured
        for i, src in enumerate(self.frz):
            run = s.frozen[i] if i < len(s.frozen) else None
            if run is not self._frozen_shown[i]:
                src.data = (self._columns(run, FROZEN_SIGNALS) if run is not None
                            else {k: [] for k in ("t", *FROZEN_SIGNALS)})
                for item in self._frozen_items[i]:
                    item.visible = run is not None
                    if run is not None:
                        item.label = value(f"frozen #{s.frozen_numbers[i]}")
                self._frozen_shown[i] = run
        events = s.events()
        times = [t * self._scale for t, _ in events]
        if list(self.events.data["t"]) != times or \
                list(self.events.data["text"]) != [w for _, w in events]:
            self.events.data = {"t": times, "text": [w for _, w in events]}
        self.out_fig.yaxis.axis_label = y_label
        self.u_fig.yaxis.axis_label = u_label
        self.g_fig.yaxis.axis_label = "gain gamma (1)"
        self.g_fig.visible = s.adapts()
        last = self.g_fig if s.adapts() else self.u_fig
        for fig in (self.out_fig, self.u_fig, self.g_fig):
            fig.xaxis.axis_label = t_label if fig is last else ""
        text = self._verdict(r) + self._table(r) + self._frozen_caption()
        if self.runs == 1:  # the page as first sent; afterwards, through page_text
            self.metrics.text = text
        self.undo_button.disabled = not s.can_undo()
        self.clear_button.disabled = not s.frozen
        self._show_map_state()
        self._unsent = text
        if publish:
            self._publish()

    def _publish(self) -> None:
        """Send the metrics of the last redraw (last of its messages: Bokeh's server sends
        each change as a message of its own, applied in order)."""
        s = self.session
        self.page_text.data = {"metrics": [self._unsent], "toml": [s.toml()],
                               "filename": [f"{s.name}-tuned.toml"]}
        self._after_sent(self._update_linear)

    def _after_sent(self, job: Callable[[], Any]) -> None:
        """``job`` once the changes pause: :data:`AFTER_MS` after the last one on the
        server's loop (a newer change puts it off again), so that the run's metrics and
        traces reach the page and are drawn first, and a slider's drag is not analysed
        at every step; at once for the page as first sent and outside a server."""
        if self.doc.session_context is None or self.runs <= 1:
            job()
            return
        if self._pending is not None:
            try:
                self.doc.remove_timeout_callback(self._pending)
            except ValueError:  # it ran already
                pass

        def run() -> None:
            self._pending = None
            job()

        self._pending = self.doc.add_timeout_callback(run, AFTER_MS)

    @_guarded
    def _update_linear(self) -> None:
        """The linear loop of the current settings: its figures and its margins' table
        (:meth:`Session.analysis`, kept per settings: a frozen run's is not redone)."""
        a = self.session.analysis()
        self._show_linear(a)
        text = self._linear_table(a)
        if self.runs <= 1:  # the page as first sent; afterwards, through linear_text
            self.linear_div.text = text
        self.linear_text.data = {"html": [text]}

    def _columns(self, r: Result, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        cols = [r.signals[k] for k in names]
        keep = keep_points(r.time.size, cols)
        out = {"t": _finite(r.time[keep] * self._scale)}
        out.update({k: _finite(c[keep]) for k, c in zip(names, cols, strict=True)})
        return out

    def _head(self) -> str:
        s = self.session
        return (f'<div style="font: 14px system-ui, sans-serif">'
                f'<span style="font-size:20px;font-weight:600">mfcontrol tuner: '
                f'{html.escape(s.name)}</span> &nbsp; {html.escape(s.description)}</div>')

    def _verdict(self, r: Result) -> str:
        """The library's verdict on the output, said with what it judges, and beside it
        what the control did (a loop can track while u chatters from limit to limit)."""
        s, m = self.session, r.metrics
        s_cfg = s.cfg
        if m["diverged"]:
            verdict = (f'<span class="verdict-no" style="color:#b42318">diverged at '
                       f't = {m["t_diverge"]:.4g} s</span>')
        else:
            rule = (f'(the output: |e| within {100 * s_cfg["metrics.settled_tol"]:.4g} % of '
                    f'max |y*| over the last {100 * s_cfg["metrics.final_window"]:.4g} % of '
                    'the run)')
            verdict = ('<span style="color:#1a7f37">settled</span> ' if m["settled"] else
                       '<span style="color:#b42318">not settled</span> ') + html.escape(rule)
        _, u_unit = units(s_cfg)
        f = control_figures(r)
        unit = "" if u_unit == "1" else " " + html.escape(u_unit)  # a duty has none
        control = (f'<span class="mf-control">control u: TV(u) {fmt(m["tv_u"])}{unit}, '
                   f'a mean step of {fmt(f["step_share"])} % of its range '
                   f'{fmt(f["low"])} .. {fmt(f["high"])}{unit}, at a limit '
                   f'{fmt(f["u_at_limit"])} % of the samples</span>')
        changed = ", ".join(f"{k} = {text_of(v)}" for k, v in s.changed().items())
        return (f'<p class="verdict">{verdict}. {r.time.size:,} samples simulated in '
                f'{1e3 * s.seconds:.1f} ms.<br>{control}.<br>Changed from the case: '
                f'{html.escape(changed) or "nothing"}</p>')

    def _table(self, r: Result) -> str:
        """The metrics as an HTML table: each value shown to 4 digits, its exact repr in
        ``data-value`` (what a test compares with the engine's); a column for each frozen
        run (``frozen-N``, N its number) and the change against the newest."""
        s = self.session
        y_unit, u_unit = units(s.cfg)
        runs = [_shown_metrics(r)] + [_shown_metrics(f) for f in s.frozen]
        rows = []
        for m in TABLE_METRICS:
            values = [run.get(m) for run in runs]
            if m == "final_gamma" and not s.adapts():
                continue
            if m != "settled" and not any(_defined(v) for v in values):
                continue
            words, unit = LABELS.get(m, (m, ""))
            if m in _metrics.LABELS and m != "settled":
                full = _metrics.label(m, y_unit, u_unit)
                unit = full[len(words) + 2:-1] if full != words else ""
            unit = unit.replace("^2", "\u00b2") if m != "settled" else ""
            cells = [f'<td title="{html.escape(words)}">{html.escape(SHORT.get(m, m))}'
                     f'<span class="unit">{html.escape(unit)}</span></td>',
                     _cell("current", values[0])]
            cells += [_cell(f"frozen frozen-{n}", v)
                      for n, v in zip(s.frozen_numbers, values[1:], strict=True)]
            if s.frozen:
                cells.append(_change(m, values[0], values[-1]))
            rows.append(f'<tr data-metric="{m}">{"".join(cells)}</tr>')
        head = "<th>metric</th><th>this run</th>"
        head += "".join(f'<th class="frozen">#{n}</th>' for n in s.frozen_numbers)
        if s.frozen:
            head += f"<th>vs #{s.frozen_numbers[-1]}</th>"
        return (f'<table class="metrics" data-run="{self.runs}"><tr>{head}</tr>'
                f'{"".join(rows)}</table>')

    def _linear_table(self, a: Any) -> str:
        """The linear loop's verdict and margins (:func:`mfcontrol.analyze`), with a column
        for each frozen run's, and what the analysis leaves out."""
        s = self.session
        head = ('<p class="verdict">The law as a filter around the plant, linearised where '
                'the plant is not linear; no noise, no limits: ')
        if isinstance(a, str):
            return head + f"no analysis: {html.escape(a)}</p>"
        frozen = [s.analysis(run.config) if run.config is not None else "" for run in s.frozen]
        runs = [_rounded(a.margins)] + [_rounded(f.margins) if not isinstance(f, str) else {}
                                        for f in frozen]
        verdict = ('<span class="linear-stable" style="color:#1a7f37">stable</span> (every '
                   'pole inside the unit circle)' if a.margins["stable"] else
                   '<span class="linear-unstable" style="color:#b42318">unstable</span> '
                   '(a pole on or outside the unit circle)')
        rows = []
        for key, words, unit in LINEAR_SHOWN:
            cells = [f'<td>{html.escape(words)}<span class="unit">{html.escape(unit)}'
                     f'</span></td>', _cell("current", runs[0].get(key))]
            cells += [_cell(f"frozen frozen-{n}", m.get(key))
                      for n, m in zip(s.frozen_numbers, runs[1:], strict=True)]
            rows.append(f'<tr data-margin="{key}">{"".join(cells)}</tr>')
        th = "<th>margin</th><th>this run</th>" + "".join(
            f'<th class="frozen">#{n}</th>' for n in s.frozen_numbers)
        notes = "".join(f"<li>{html.escape(n)}</li>" for n in a.notes)
        return (head + verdict + "</p>"
                f'<table class="margins" data-run="{self.runs}"><tr>{th}</tr>'
                f'{"".join(rows)}</table>'
                + (f'<ul class="frozen-caption" style="margin:4px 0 0 16px; padding:0">'
                   f'{notes}</ul>' if notes else ""))

    def _frozen_caption(self) -> str:
        """Each frozen run's settings against the current ones, redrawn with the table:
        what a column compares."""
        s = self.session
        lines = []
        for n, run, dash in zip(s.frozen_numbers, s.frozen, FROZEN_DASHES, strict=False):
            assert run.config is not None
            diff = s.differences(run.config)
            what = ("the current settings" if not diff else ", ".join(
                f"{k} = {brief(a)} (now {brief(b)})" for k, (a, b) in diff.items()))
            lines.append(f"<b>#{n}</b> ({dash} grey): {html.escape(what)}")
        return (f'<p class="frozen-caption">{"<br>".join(lines)}</p>' if lines else "")

    # --- freeze -----------------------------------------------------------------------

    @_guarded
    def freeze(self) -> None:
        s = self.session
        dropped = s.frozen_numbers[0] if len(s.frozen) == MAX_FROZEN else None
        s.freeze()
        self.redraw(publish=False)
        self.status(f"this run is frozen as #{s.frozen_numbers[-1]}: a grey trace in the "
                    "plots, a column of the table" + (f" (#{dropped}, the oldest, dropped: "
                                                      f"{MAX_FROZEN} at most)" if dropped
                                                      else ""))
        self._publish()

    @_guarded
    def clear(self) -> None:
        self.session.clear()
        self.redraw(publish=False)
        self.status("frozen runs cleared")
        self._publish()

    # --- the long jobs ----------------------------------------------------------------

    def _later(self, fn: Callable, *args: Any) -> None:
        """Call ``fn(*args)`` on the document's thread (from a job's thread)."""
        try:
            self.doc.add_next_tick_callback(functools.partial(_guarded(fn), self, *args))
        except Exception:  # noqa: BLE001 - the tab was closed: nothing to show it on
            log.debug("tuner: no document to report to", exc_info=True)

    def _refuse_while_busy(self) -> bool:
        """One job at a time: a double click on Map or Tune started two (the buttons are
        disabled only once the server's answer reaches the page)."""
        if self._busy:
            self.status("a map or a tuning is running: wait for it, or stop it", error=True)
        return self._busy

    def _start(self, job: Callable[[], Any], done: Callable, failed: Callable) -> None:
        """Run ``job`` in a thread; ``done`` or ``failed`` then runs on the document's
        thread."""

        def work() -> None:
            try:
                result = job()
            except Exception as exc:  # noqa: BLE001 - reported on the page
                self._later(failed, exc)
            else:
                self._later(done, result)
        self._busy = True
        self.map_button.disabled = self.tune_button.disabled = True
        threading.Thread(target=work, daemon=True, name="mfcontrol-tuner-job").start()

    def _idle(self) -> None:
        self._busy = False
        self.map_button.disabled = self.tune_button.disabled = False
        self.stop_button.disabled = True

    @_guarded
    def start_map(self) -> None:
        if self._refuse_while_busy():
            return
        x, y, metric = self.map_x.value, self.map_y.value, self.map_metric.value
        total = 81
        self.map_status.text = _progress("robustness map", 0, total)
        t0 = time.perf_counter()

        def progress(done: int, n: int) -> None:
            self._later(TunerPage._map_progress, done, n, time.perf_counter() - t0)

        self._start(lambda: self.session.robustness_map(x, y, metric, progress=progress),
                    TunerPage._map_done, TunerPage._map_failed)

    def _map_progress(self, done: int, total: int, seconds: float) -> None:
        self.map_status.text = _progress("robustness map", done, total, seconds)

    def _map_done(self, m) -> None:
        self._idle()
        s = self.session
        if self.map_view is not None:
            self.map_view.retire()
        self.map_view = heatmap.draw(m, units(m.cfg), (s.label(m.x), s.label(m.y)),
                                     width=CENTRE)
        self.map_holder.children = [self.map_view.fig]
        settled = int(m.settled.sum())
        self._map_done_text = (f"{m.z.size} runs in {m.seconds:.2f} s: {settled} settled, "
                               f"{m.z.size - settled} not ({int(m.diverged.sum())} diverged).")
        self._map_shown = None
        self._show_map_state()

    def _show_map_state(self) -> None:
        """The map, if any, against the settings now (:meth:`Session.map_state`): its mark
        and subtitle, and below the button what it means; the button says "Redraw" when
        the map is not around the current setting."""
        if self.map_view is None:
            return
        state = self.session.map_state(self.map_view.m)
        self.map_view.show(state)
        if state.kind == self._map_shown:
            return
        self._map_shown = state.kind
        error = state.kind in ("stale", "outside")
        self.map_status.text = _finished(
            self._map_done_text + (" " + state.text if state.text else ""), error=error)
        label = REDRAW_LABEL if state.kind != "current" else MAP_LABEL
        if self.map_button.label != label:
            self.map_button.label = label

    def _map_failed(self, exc: Exception) -> None:
        self._idle()
        self.map_status.text = _finished(str(exc), error=True)

    @_guarded
    def start_tune(self) -> None:
        if self._refuse_while_busy():
            return
        keys = list(self.tune_keys.value)
        budget = int(self.budget.value or 0)
        objective = self.objective.value
        self._stop_tune.clear()
        self._tuned_from = self.session.cfg
        self.stop_button.disabled = False
        t0 = time.perf_counter()
        self.tune_status.text = _progress("tuning", 0, budget)

        def progress(done: int, total: int, best: float) -> None:
            self._later(TunerPage._tune_progress, done, total, best, time.perf_counter() - t0,
                        objective)
            if self._stop_tune.is_set():
                raise KeyboardInterrupt  # tune() stops and returns the best so far

        self._start(lambda: self.session.tune(keys, budget, progress, objective=objective),
                    TunerPage._tune_done, TunerPage._tune_failed)

    def _tune_progress(self, done: int, total: int, best: float, seconds: float,
                       objective: str) -> None:
        # the objective the tuning minimises, not the menu's value of the moment
        self.tune_status.text = _progress("tuning", done, total, seconds,
                                          f"best {objective} {fmt(best)}")

    def _tune_done(self, result) -> None:
        self._idle()
        if not math.isfinite(result.value):
            self.tune_status.text = _finished(f"no point was settled in {result.evaluations} "
                                              "points: the values are kept", error=True)
            return
        best = ", ".join(f"{k} = {fmt(v)}" for k, v in result.best.items())
        if self.session.cfg is not self._tuned_from:
            # the best values are the best under the settings the tuning started from; on
            # settings changed since, they would be shown as what they are not
            self.tune_status.text = _finished(
                f"settings changed while tuning: its best ({best}, {result.objective.text} "
                f"{fmt(result.value)}) is not applied", error=True)
            return
        before = self.session.snapshot()
        then = self.session.cfg
        try:
            applied = self.session.apply_tuned(result.best)
            self.redraw(publish=False)
        except Exception:
            self.session.restore(before)
            raise
        self._after_settings(then)
        for view in self.views.values():
            view.show_error(None)
        run = self.session.result
        assert run is not None
        shown = ", ".join(f"{k} = {text_of(v)}" for k, v in applied.items())
        self.tune_status.text = _finished(
            f"applied, to {DIGITS} digits: {shown}; {result.objective.text} "
            f"{fmt(result.objective.score_run(run.metrics))} (the values before: "
            f"{fmt(result.start_value)}). {result.evaluations} points in "
            f"{result.seconds:.1f} s ({result.stopped}). Undo goes back.")
        self._publish()
        # a map drawn before is of the settings before: drawn again around the new ones
        if self.map_view is not None and self.session.map_state(
                self.map_view.m).kind != "current":
            self.start_map()

    def _tune_failed(self, exc: Exception) -> None:
        self._idle()
        self.tune_status.text = _finished(str(exc), error=True)


def _same_text(view: FieldView, value: Any) -> bool:
    """Whether a field shows ``value`` already."""
    shown = view.select.value if view.select is not None else (
        view.entry.value if view.entry is not None else None)
    return shown == text_of(value)


def _shown_metrics(r: Result) -> dict[str, Any]:
    """A run's metrics as the table shows them: the library's, and the share of samples
    with u at a limit (:func:`~mfcontrol.tuner.session.control_figures`)."""
    return {**r.metrics, "u_at_limit": control_figures(r)["u_at_limit"]}


def _finished(text: str, error: bool = False) -> str:
    """A job's last line (``data-done`` marks it for whoever waits on the page)."""
    style = ' style="color:#b42318"' if error else ""
    return f'<span data-done="1"{style}>{html.escape(text)}</span>'


def _defined(v: Any) -> bool:
    return v is not None and not (isinstance(v, float) and math.isnan(v))


def _rounded(margins: dict[str, Any]) -> dict[str, Any]:
    """The margins as shown: an integrating loop's steady-state error, summed in floats to
    some 1e-13, as the 0 it is (as ``mfcontrol analyze`` prints it)."""
    from ..experiments.analyze import ROUNDING

    e = margins.get("steady_state_error")
    if isinstance(e, float) and abs(e) < ROUNDING:
        return {**margins, "steady_state_error": 0.0}
    return margins


def _cell(cls: str, v: Any) -> str:
    exact = "" if v is None else f' data-value="{html.escape(repr(v))}"'
    style = ' class="verdict-no"' if v is False else ""
    text = f"<span{style}>{fmt(v)}</span>"
    return f'<td class="{cls}"{exact}>{text}</td>'


def _change(metric: str, now: Any, then: Any) -> str:
    """The relative change against the frozen run; green where the run is better (every
    metric of the table but gamma is better smaller)."""
    if (metric in ("settled", "final_gamma") or not isinstance(now, float)
            or not isinstance(then, float) or not math.isfinite(now)
            or not math.isfinite(then) or then == 0):
        return "<td></td>"
    pct = 100.0 * (now - then) / abs(then)
    cls = "better" if pct < 0 else "worse" if pct > 0 else ""
    ratio = now / then
    # beyond a factor of ten a ratio reads better than a percentage of six digits
    def times(r: float) -> str:
        return f"{r:,.0f}" if r >= 100 else f"{r:.3g}"

    text = (f"x {times(ratio)}" if ratio >= 10 else f"/ {times(1 / ratio)}"
            if 0 < ratio <= 0.1 else f"{pct:+.1f} %")
    return f'<td class="{cls}">{text}</td>'


def _progress(what: str, done: int, total: int, seconds: float = 0.0, extra: str = "") -> str:
    share = done / total if total else 0.0
    tail = f", {extra}" if extra else ""
    return (f'<progress value="{done}" max="{total}" style="width:160px"></progress> '
            f'{what}: {done:,}/{total:,} ({100 * share:.0f} %), {seconds:.1f} s{tail}')


def make_document(session_factory: Callable[[], Session]) -> Callable[[Document], None]:
    """The Bokeh application function: a fresh session and page per browser tab."""
    def modify(doc: Document) -> None:
        TunerPage(doc, session_factory())
    return modify


__all__ = ["FieldView", "TunerPage", "make_document"]
