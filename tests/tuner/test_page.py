"""The page's callbacks in this process, on a Bokeh document without a browser: what a
refused entry leaves on screen, one job at a time, the status line (found in review)."""

from __future__ import annotations

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
