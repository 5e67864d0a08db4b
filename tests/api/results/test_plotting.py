"""Figures that read like a paper's (issue 15): events named, coinciding curves said to
coincide, an outlier kept from flattening the others, titles in words."""

import dataclasses

import numpy as np

import mfcontrol
from mfcontrol.api.results.plotting import units


def _texts(fig):
    return [t.get_text() for ax in fig.axes for t in ax.texts] + \
        [ax.get_title(loc="left") for ax in fig.axes]


def test_a_run_names_its_events_and_its_case_in_words():
    r = mfcontrol.run_case("voltage-stable-standard")
    fig = r.plot()
    assert _texts(fig).count("load change") == 4  # two changes, two panels
    assert fig._suptitle.get_text().startswith("Voltage control, standard i-P")


def test_coinciding_members_are_drawn_once_and_said_to_coincide():
    sw = mfcontrol.run_case("sweep-Gamma")
    same = dataclasses.replace(sw, members=[sw.members[0]] * 3, values=[1.0, 2.0, 3.0])
    fig = same.plot(kind="gamma")
    ax = fig.axes[0]
    assert len(ax.get_lines()) == 1 + 2  # one curve, two event lines
    assert ax.get_legend().get_texts()[0].get_text() == "Gamma = 1, 2, 3 (coincide)"
    assert "all 3 members give the same curve" in _texts(fig)


def test_an_unstable_member_does_not_flatten_the_stable_ones():
    sw = mfcontrol.run_case("sweep-Gamma", {"fidelity": "paper"})
    assert not all(m.metrics["settled"] for m in sw.members)
    fig = sw.plot(kind="gamma")
    lo, hi = fig.axes[0].get_ylim()
    stable = np.concatenate([m.signals["gamma"] for m in sw.members if m.metrics["settled"]])
    assert lo <= stable.min() and stable.max() <= hi and hi - lo < 2 * np.ptp(stable)
    assert any(t.startswith("unsettled members leave the axis") for t in _texts(fig))


def test_units_of_every_plant_family():
    from mfcontrol.experiments.cases import resolve_case

    assert units(resolve_case("voltage-stable-standard")[1]) == ("V", "1")
    assert units(resolve_case("power-standard")[1]) == ("W", "1")
    assert units(resolve_case("motor-noise-ipi")[1]) == ("rad/s", "V")


def test_members_that_coincide_on_the_scale_are_drawn_once():
    """Published choices: eps_M = 1e-5 and 0.1 give tracking errors within 3e-5 of the
    largest; they looked like one curve under two legend entries."""
    sw = mfcontrol.run_case("sweep-epsM")
    fig = sw.plot(kind="error")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["eps_M = 1e-05, 0.1 (coincide)", "eps_M = 1000"]
    assert "curves that coincide on this scale are drawn once" in _texts(fig)


def test_an_unstable_member_does_not_widen_what_counts_as_coinciding():
    """Printed equations: Gamma = 5e-10 and 5e-9 end at 0.998 and 0.973, apart on the
    stable members' axis; the unstable members' range (-194 .. 11) merged them."""
    sw = mfcontrol.run_case("sweep-Gamma", {"fidelity": "paper"})
    labels = [t.get_text() for t in sw.plot(kind="gamma").axes[0].get_legend().get_texts()]
    assert labels[:2] == ["Gamma = 5e-10", "Gamma = 5e-09"]


def test_a_transient_too_small_to_see_gets_a_zoom_and_a_failure_does_not():
    """The paper's figures zoom on the load change: the 0.17 V transient of the stable
    variational run at 4 ms is under 3 % of a 7.5 V axis (issue 15)."""
    from mfcontrol.api.results.plotting import plot_run

    stable = mfcontrol.run_case("voltage-stable-variational")
    (inset,) = plot_run(stable).axes[0].child_axes
    lo, hi = inset.get_xlim()
    assert lo < 4.0 < hi and hi - lo < 1.0  # ms, around the first load change
    assert "load change at 4 ms" in inset.get_title()
    # the legend moved out of the inset's corner
    legend = plot_run(stable).axes[0].get_legend()
    assert legend is not None and legend._loc != 0  # not "best", which ignores insets
    failing = mfcontrol.run_case("voltage-unstable-standard")
    assert not failing.metrics["settled"] and plot_run(failing).axes[0].child_axes == []
    quiet = mfcontrol.run_case("voltage-stable-variational",
                               overrides={"plant.change_times": [0.02]})
    assert plot_run(quiet).axes[0].child_axes == []  # no event in the run


def test_titles_wrap_into_even_lines_without_splitting_a_figure_number():
    """'(paper Fig.' / '6)' was a title's last two lines (the text wrapped at 95 characters
    as it came)."""
    from mfcontrol.api.results.plotting import title_in_words

    title = title_in_words(mfcontrol.run_case("voltage-unstable-variational"), extra="x")
    lines = title.split("\n")
    assert len(lines) == 3 and lines[-1] == "x"
    assert all(len(line) <= 100 and not line.endswith(("Fig.", "=")) for line in lines)
    assert abs(len(lines[0]) - len(lines[1])) < 20  # even, no one-word line


def test_a_loop_run_names_its_parameter_changes():
    """Found in review: simulate_loop(...).plot drew a bare line at each change."""
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    ctrl = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-3)
    res = mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=2.0,
                                  changes=[mfcontrol.Change(1.0, "b", 0.5, add=True)])
    assert _texts(res.plot()).count("b += 0.5") == 2  # both panels


def test_a_saved_figure_is_savefig_own_drawn_once(tmp_path, monkeypatch):
    from matplotlib.backend_bases import FigureCanvasBase
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from mfcontrol.api.results.plotting import DPI

    r = mfcontrol.run_case("voltage-stable-standard")  # constrained layout and a zoom inset
    draws = []
    monkeypatch.setattr(Figure, "draw", lambda self, renderer, _draw=Figure.draw:
                        draws.append(1) or _draw(self, renderer))
    fig = r.plot(tmp_path / "ours.png")
    assert len(draws) == 1
    r.plot().savefig(tmp_path / "savefig.png", dpi=DPI)
    assert (tmp_path / "ours.png").read_bytes() == (tmp_path / "savefig.png").read_bytes()
    # left as savefig leaves it: its own canvas, resolution and layout engine
    assert type(fig.canvas) is FigureCanvasBase and fig.canvas.figure is fig
    assert fig.dpi == 100.0 and isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)
    fig.savefig(tmp_path / "again.png", dpi=DPI)
    assert (tmp_path / "again.png").read_bytes() == (tmp_path / "savefig.png").read_bytes()
    # another suffix: savefig's format
    r.plot(tmp_path / "run.svg")
    assert (tmp_path / "run.svg").read_text().lstrip().startswith("<?xml")


def test_many_load_changes_are_one_collection_named_once():
    """Issue 29: 1,000 load changes drew 2,000 lines and labels per figure (half a minute
    of CPU); past NAMED_EVENTS they are one collection of ticks per panel, named once by
    their count, and a few are still named one by one."""
    from matplotlib.collections import LineCollection

    from mfcontrol.api.results.plotting import NAMED_EVENTS, plot_run

    times = [1e-5 * (i + 1) for i in range(1000)]  # the last at t_end: not in the run
    r = mfcontrol.run_case("voltage-stable-standard",
                           overrides={"plant.change_times": times, "plant.dR": 1e-3})
    fig = plot_run(r)
    assert _texts(fig).count("999 load changes") == 2  # once per panel
    assert not any(t == "load change" for t in _texts(fig))
    for ax in fig.axes[:2]:
        assert len(ax.get_lines()) <= 3  # the curves only
        (ticks,) = [c for c in ax.collections if isinstance(c, LineCollection)]
        assert len(ticks.get_segments()) == 999
    few = times[4::100][:NAMED_EVENTS]  # NAMED_EVENTS changes: each named
    fig = plot_run(mfcontrol.run_case("voltage-stable-standard",
                                      overrides={"plant.change_times": few}))
    assert _texts(fig).count("load change") == 2 * NAMED_EVENTS


def test_a_loop_run_with_many_changes_names_them_once():
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    ctrl = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-3)
    changes = [mfcontrol.Change(0.01 * (i + 1), "w", 0.001, add=True) for i in range(50)]
    res = mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=1.0, changes=changes)
    texts = _texts(res.plot())
    assert texts.count("50 parameter changes") == 2 and "w += 0.001" not in texts


def test_a_long_description_is_shortened_in_the_title():
    """A 10 MB description was laid out as a title for minutes (and left no room for the
    panels): a title shows at most TITLE_MOST characters of it, cut at a word."""
    from mfcontrol.api.results.plotting import title_in_words
    from mfcontrol.config.options import MAX_DESCRIPTION, TITLE_MOST

    words = "control " * (MAX_DESCRIPTION // 8)
    r = mfcontrol.run_case("voltage-stable-standard",
                           overrides={"description": words[:MAX_DESCRIPTION]})
    title = title_in_words(r, extra="x")
    lines = title.split("\n")
    assert len(lines) == 4 and lines[-1] == "x"  # three lines of description
    text = " ".join(lines[:-1])
    assert len(text) <= TITLE_MOST and text.endswith("control ...")
    assert r.plot()._suptitle.get_text().endswith("control ...")
    # a description that fits is left whole
    assert not title_in_words(mfcontrol.run_case("voltage-unstable-variational")).endswith(
        "...")
