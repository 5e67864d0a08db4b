"""The page's callbacks in this process, on a Bokeh document without a browser: what a
refused entry leaves on screen, one job at a time, the status line (found in review)."""

from __future__ import annotations

import html
import math

import numpy as np
import pytest

pytest.importorskip("bokeh")

from bokeh.document import Document  # noqa: E402

from mfcontrol.tuner.page import TunerPage  # noqa: E402
from mfcontrol.tuner.session import Session  # noqa: E402


@pytest.fixture
def page():
    return TunerPage(Document(), Session("voltage-stable-standard", {"sim.t_end": 2e-3}))


def test_a_refused_choice_puts_the_menu_back(page):
    """The menu kept showing the refused model while the session (and a saved case) kept
    the buck."""
    view = page.views["plant.model"]
    view.select.value = "first-order"  # as the browser sets it: the callback runs
    assert page.session.cfg["plant.model"] == "buck"
    assert view.select.value == "buck"
    assert "plant.model" in page.status_div.text


def test_a_refused_slider_goes_back_to_the_value_in_force(page):
    view = page.views["controller.alpha"]
    before = view.slider.value
    page.change(view, "-1")
    assert view.slider.value == before and view.entry.value == "10.0"
    assert page.session.cfg["controller.alpha"] == 10.0


def test_an_accepted_change_clears_an_old_refusal_from_the_status(page):
    view = page.views["controller.kp"]
    page.change(view, "-x")
    assert "not changed" in page.status_div.text
    page.change(view, "2.5")
    assert "not changed" not in page.status_div.text
    assert page.session.cfg["controller.kp"] == 2.5


def test_one_job_at_a_time(page, monkeypatch):
    """A double click on Map started two jobs (the flag was set and never read)."""
    started = []
    monkeypatch.setattr(TunerPage, "_start", lambda self, *a: (started.append(a),
                                                               setattr(self, "_busy", True)))
    page.start_map()
    page.start_map()
    page.start_tune()
    assert len(started) == 1 and "running" in page.status_div.text


def test_a_tuning_is_not_applied_to_settings_changed_while_it_ran(page):
    """Found in review: its best values were applied on top of a plant.dR changed during
    the tuning, and the status showed a value the table did not."""

    class Best:  # what mfcontrol.tune returns, as far as the page reads it
        value, start_value, evaluations, seconds, stopped = 1e-4, 2e-4, 40, 0.1, "budget"
        best = {"controller.kp": 3.0}

        class objective:  # noqa: N801
            text = "iae"

    page._tuned_from = page.session.cfg
    page.change(page.views["plant.dR"], "2.0")  # while the tuning runs
    page._tune_done(Best())
    assert page.session.cfg["controller.kp"] == 2.0
    assert "not applied" in page.tune_status.text


MOTOR = "motor-noise-ipi-algebraic"


@pytest.fixture
def motor():
    return TunerPage(Document(), Session(MOTOR))


class Tuned:
    """What mfcontrol.tune returns, as far as the page reads it."""

    value, start_value, evaluations, seconds, stopped = 1e-4, 2e-4, 40, 0.1, "budget"

    def __init__(self, best):
        from mfcontrol.api.results.objective import Objective

        self.best = best
        self.objective = Objective.parse("iae")


def test_a_law_switch_shows_the_laws_gains_and_says_where_they_come_from(motor):
    motor.change(motor.views["controller.law"], "pid")
    assert motor.views["controller.kp"].entry.value == "2.0"
    assert motor.views["controller.ki"].entry.value == "0.0"
    assert "the library&#x27;s defaults" in motor.status_div.text
    motor.change(motor.views["controller.law"], "i-PI")
    assert motor.views["controller.alpha"].entry.value == "50.0"
    assert "from the case" in motor.status_div.text


def test_an_emptied_entry_shows_the_cases_value(motor):
    view = motor.views["controller.alpha"]
    motor.change(view, "70")
    motor.change(view, "")
    assert view.entry.value == "50.0" and motor.session.value("controller.alpha") == 50.0
    assert "back to the case&#x27;s 50.0" in motor.status_div.text


def test_undo_restores_the_fields_and_the_run(page):
    assert page.undo_button.disabled
    first = page.session.result.metrics
    page.change(page.views["controller.kp"], "3")
    assert not page.undo_button.disabled
    page.undo()
    assert page.views["controller.kp"].entry.value == "2.0"
    assert page.session.result.metrics == first and page.undo_button.disabled
    assert "undone: controller.kp = 3.0" in page.status_div.text


def changes_after_the_metrics(page, action) -> list[str]:
    """The models changed after the metrics were sent, during ``action``: the server
    sends each change as a message, applied in order, and the page (a user, the browser
    tests) reads the metrics as "redrawn". The linear loop's models are left out: they
    come after the metrics by design (on the server's next tick)."""
    seen: list[str] = []
    linear = {id(m) for m in (page.lin_src, page.ms_src, page.ms_line, page.linear_text,
                              page.linear_div, page.linear_title)}

    def record(event):
        model, attr = getattr(event, "model", None), getattr(event, "attr", None)
        if model is not None and id(model) not in linear:
            seen.append("metrics" if model is page.page_text else f"{model}.{attr}")

    page.doc.on_change(record)
    action()
    page.doc.remove_on_change(record)
    assert "metrics" in seen
    return seen[len(seen) - seen[::-1].index("metrics"):]


def test_the_metrics_are_sent_after_the_fields_and_the_status_line(page, motor):
    """A browser run of CI: the undo's metrics came before the entry showed the value
    undone, and a test reading the entry as soon as the metrics changed read the old one."""
    view = page.views["controller.kp"]
    assert changes_after_the_metrics(page, lambda: page.change(view, "3")) == []
    assert changes_after_the_metrics(page, page.undo) == []
    assert changes_after_the_metrics(page, page.freeze) == []
    assert changes_after_the_metrics(page, page.clear) == []
    alpha = motor.views["controller.alpha"]
    motor.change(alpha, "70")
    assert changes_after_the_metrics(motor, lambda: motor.change(alpha, "")) == []
    assert changes_after_the_metrics(
        motor, lambda: motor.change(motor.views["controller.law"], "i-PD")) == []


def test_several_frozen_runs_each_a_column_a_line_and_its_settings(page):
    page.freeze()
    page.change(page.views["controller.kp"], "3")
    page.freeze()
    page.change(page.views["controller.kp"], "4")
    text = page.page_text.data["metrics"][0]
    assert 'class="frozen frozen-1"' in text and 'class="frozen frozen-2"' in text
    assert "<th>vs #2</th>" in text
    assert "controller.kp = 2 (now 4)" in text and "controller.kp = 3 (now 4)" in text
    assert len(page.frz[0].data["y"]) and len(page.frz[1].data["y"])
    assert not len(page.frz[2].data["y"])
    labels = [item.label.value for item in page._frozen_items[1] if item.visible]
    assert labels == ["frozen #2"] * 3
    page.clear()
    assert not len(page.frz[0].data["y"]) and page.clear_button.disabled


def test_tuned_values_are_shown_to_four_digits(page):
    page._tuned_from = page.session.cfg
    page._tune_done(Tuned({"controller.kp": 2.0417379446695296}))
    assert page.views["controller.kp"].entry.value == "2.042"
    assert "controller.kp = 2.042" in page.tune_status.text
    assert "2.0417379" not in page.page_text.data["metrics"][0]
    page.undo()
    assert page.views["controller.kp"].entry.value == "2.0"


def test_a_map_off_the_setting_is_marked_and_redrawn_after_a_tuning(page, monkeypatch):
    """Issue 28: after Tune moved alpha, the map, its title and its marker stayed where
    they were."""
    page._map_done(page.session.robustness_map("controller.alpha", "plant.dR", n=3))
    view = page.map_view
    assert view.subtitle.text.startswith("9 runs around the current setting (marked)")
    assert page.map_button.label == "Robustness map (9 x 9)"
    page.change(page.views["controller.alpha"], "12")  # on the map: the mark moves
    assert dict(view.here.data) == {"x": [12.0], "y": [1.0]} and view.centre_item.visible
    page.change(page.views["controller.kp"], "3")  # another setting: stale
    assert view.subtitle.text.startswith("Stale: 9 runs around alpha = 10, dR = 1 (+)")
    assert view.cells.glyph.fill_alpha < 1 and not view.here_item.visible
    assert "controller.kp = 2 (now 3)" in page.map_status.text
    assert page.map_button.label == "Redraw map (9 x 9)"
    page.undo()
    page.undo()
    assert view.subtitle.text.startswith("9 runs around the current setting")
    assert view.cells.glyph.fill_alpha == 1
    # a tuning applied under a map: the map is drawn again around the tuned values
    started = []
    monkeypatch.setattr(TunerPage, "start_map", lambda self: started.append(1))
    page._tuned_from = page.session.cfg
    page._tune_done(Tuned({"controller.alpha": 14.5}))
    assert started == [1]
    # the map drawn again: the old one's models lose the names the page's script reads
    page._map_done(page.session.robustness_map("controller.alpha", "plant.dR", n=3))
    assert view.subtitle.name is None and view.fig.name is None
    assert page.map_view.subtitle.name == "map-subtitle"
    assert page.map_view.subtitle.text.startswith("9 runs around the current setting")


def test_the_measured_output_is_drawn_where_it_differs(page, motor):
    """Issue 28: the measured (noisy) signal was not drawn."""
    assert not page._measured.visible  # the paper's case measures y itself
    assert motor._measured.visible and motor._measured_item.visible
    y, y_meas = motor.src.data["y"], motor.src.data["y_meas"]
    assert len(y) == len(y_meas) and (y != y_meas).any()


def test_the_schedule_is_a_field_and_its_changes_are_marked_in_words(motor):
    view = motor.views["plant.schedule"]
    assert view.entry.value == '[{t = 5.0, name = "load", set = 0.05}]'
    assert dict(motor.events.data) == {"t": [5.0], "text": ["load torque set to 0.05 N m"]}
    motor.change(view, '[{t = 2.0, name = "load", set = 0.02}]')
    assert dict(motor.events.data) == {"t": [2.0], "text": ["load torque set to 0.02 N m"]}


def test_titles_in_the_plants_words_and_the_control_beside_the_verdict(motor):
    """Issue 28: the motor's limits were titled duty_min / duty_max; the page said
    "stable: yes" under a control chattering rail to rail."""
    assert motor.views["controller.duty_min"].slider.title == \
        "armature voltage u, lower limit (V)"
    assert motor.views["controller.duty_min"].entry.description.startswith(
        "controller.duty_min: ")
    assert ("controller.duty_max", "armature voltage u, upper limit (V)") in \
        motor.map_x.options
    motor.change(motor.views["controller.law"], "pid")
    for key, value in (("controller.kp", "20"), ("controller.ki", "50")):
        motor.change(motor.views[key], value)  # the i-PI's gains on the PID
    text = motor.page_text.data["metrics"][0]
    assert "settled</span> (the output: |e| within 10 % of max |y*|" in text
    assert "control u: TV(u) 1.313e+05 V, a mean step of 27" in text
    assert 'data-metric="u_at_limit"' in text


def test_a_number_changed_keeps_the_widgets(page):
    """Found while fixing issue 28: the fields were compared with the widgets in another
    order (the option table's against the tabs'), and every change built them all again
    (a round trip of 340 ms, and a slider lost under the mouse)."""
    view = page.views["controller.kp"]
    page.change(view, "3")
    assert page.views["controller.kp"] is view


def tracebacks(caplog) -> list[str]:
    """The log records that carry a traceback (what the server's log would show)."""
    return [r.getMessage() for r in caplog.records if r.exc_info]


def test_a_slider_at_the_end_of_a_huge_value_runs_and_past_the_floats_is_refused(
        page, caplog):
    """Issue 29: alpha typed as 1e308 put its slider's end at 10^310; slid there, the
    callback raised OverflowError into the server's log and the page said nothing."""
    view = page.views["controller.alpha"]
    page.change(view, "1e308")  # a finite number > 0: accepted, and run
    assert page.session.cfg["controller.alpha"] == 1e308
    view.slider.value = view.slider.end  # as the browser sets it: the callback runs
    alpha = page.session.cfg["controller.alpha"]
    assert 1e308 < alpha < math.inf and view.entry.value == repr(alpha)
    # a position past the end (what a page's script can send): refused on the page
    runs, result, shown = page.runs, page.session.result, page.page_text.data["metrics"]
    view.slider.value = view.slider.end + 2.0
    assert page.runs == runs and page.session.result is result
    assert page.page_text.data["metrics"] == shown  # the run before stays on the page
    assert page.session.cfg["controller.alpha"] == alpha
    assert view.entry.value == repr(alpha) and view.slider.value == view.slider.end
    status = html.unescape(page.status_div.text)
    assert "controller.alpha = inf: must be a finite number > 0" in status
    assert "not changed" in status and len(status.splitlines()) == 1
    assert tracebacks(caplog) == []


def test_a_value_the_law_cannot_run_with_is_refused_on_the_page(caplog):
    """Issue 29: the algebraic estimator's window slider goes down to 1, which the law
    refused with a ValueError: a traceback in the server's log, and on the page a
    ValueError without the option's name. (The configuration now refuses it first; a
    law's own refusal takes the same path, Session.run's RunRefused.)"""
    page = TunerPage(Document(), Session("first-order-ip-algebraic", {"sim.t_end": 0.5}))
    view = page.views["controller.window"]
    before = page.session.cfg["controller.window"]
    runs, result, shown = page.runs, page.session.result, page.page_text.data["metrics"]
    for move in (lambda: page.change(view, "1"),  # typed
                 lambda: setattr(view.slider, "value", view.slider.start)):  # slid to 1
        move()
        status = html.unescape(page.status_div.text)
        assert ("controller.window not changed: controller.window = 1: must be at least 2 "
                "samples for the algebraic estimator" in status), status
        assert len(status.splitlines()) == 1
        assert html.unescape(view.message.text) in status  # beside the field too
        assert page.runs == runs and page.session.result is result
        assert page.page_text.data["metrics"] == shown
        assert page.session.cfg["controller.window"] == before
        assert view.entry.value == str(before)
        assert view.scale.value(view.slider.value) == before
        assert not page.session.can_undo()
    assert tracebacks(caplog) == []
    page.change(view, str(before + 2))  # the server lives on: a good value runs
    assert page.runs == runs + 1 and "not changed" not in page.status_div.text


def test_the_linear_loop_is_drawn_and_its_margins_listed():
    """Issue 30: the Bode and Nyquist plots and the margins follow every change."""
    import mfcontrol

    page = TunerPage(Document(), Session("bench-lag3"))
    a = mfcontrol.analyze(page.session.cfg)
    w = np.asarray(page.lin_src.data["w"], dtype=float)
    assert np.all(np.diff(w) > 0) and w[-1] == pytest.approx(math.pi / a.sample_time, 1e-6)
    L = a.loop.frequency_response(w)["L"]
    assert np.allclose(page.lin_src.data["L"], 20 * np.log10(np.abs(L)), atol=1e-3)
    assert np.allclose(page.lin_src.data["re"], L.real, atol=1e-5, rtol=1e-5)
    assert page.ms_line.location == pytest.approx(20 * math.log10(a.margins["Ms"]))
    text = page.linear_text.data["html"][0]
    assert text == page.linear_div.text and 'class="linear-stable"' in text
    assert 'data-margin="Ms"><td>Ms, peak |S|' in html.unescape(text)
    assert f'data-value="{a.margins["Ms"]!r}"' in text
    page.freeze()
    page.change(page.views["controller.kp"], str(20 * page.session.cfg["controller.kp"]))
    after = mfcontrol.analyze(page.session.cfg)
    assert not after.margins["stable"]
    text = page.linear_text.data["html"][0]
    assert 'class="linear-unstable"' in text
    # the frozen run's margins in a column of their own
    assert (f'<td class="frozen frozen-1" data-value="{a.margins["Ms"]!r}">' in text
            and '<th class="frozen">#1</th>' in text)
    assert page.ms_line.location == pytest.approx(20 * math.log10(after.margins["Ms"]))


def test_a_loop_without_analysis_says_why_and_draws_nothing(monkeypatch):
    monkeypatch.setattr(Session, "analysis", lambda self, cfg=None: "no steady state")
    page = TunerPage(Document(), Session("voltage-stable-standard", {"sim.t_end": 2e-3}))
    assert list(page.lin_src.data["w"]) == [] and list(page.ms_src.data["x"]) == []
    assert "no steady state" in page.linear_title.text
    assert "no analysis: no steady state" in page.linear_text.data["html"][0]
