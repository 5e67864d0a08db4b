"""The tuner end to end: the command line's server, headless Chromium driven by
Playwright, and the engine in this process as the judge of what the page shows.

One server for the module (every page load is a fresh session of its own), one browser.
The round trip of a change is measured in the page, from the entry's change event to the
metrics of the new run being in the page (a MutationObserver on the table), and then to
the next drawn frame; ``-s`` prints it.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys

import pytest

from mfcontrol.api.run.simulate import simulate
from mfcontrol.cli import main
from mfcontrol.experiments.cases import resolve_case

from .browser import ROOT, Tuner, chromium, new_page, open_browser, wait_idle

pytest.importorskip("bokeh")
from mfcontrol.tuner.page import CURRENT_SIGNALS, FROZEN_SIGNALS  # noqa: E402

CASE = "voltage-stable-standard"  # 10,000 samples
MOTOR = "motor-noise-ipi-algebraic"  # 10,000 samples, sensor noise, a load step at 5 s
SHOWN = ("iae", "ise", "itae", "max_abs_e", "tv_u", "settled")


@pytest.fixture(scope="module")
def browser():
    path = chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = open_browser(p, path)
        yield b
        b.close()


def served(case: str):
    """A tuner of ``case`` for a module's tests (the fixtures' body)."""
    t = Tuner(case)
    yield t
    t.stop()


def opened(browser, url: str):
    """A fresh page of a tuner for one test, which must ask nothing beyond 127.0.0.1."""
    page = new_page(browser, url)
    yield page
    assert page.outside == [], "the page asked for something beyond 127.0.0.1"
    page.context.close()


@pytest.fixture(scope="module")
def tuner(browser):
    yield from served(CASE)


@pytest.fixture
def page(browser, tuner):
    yield from opened(browser, tuner.url)


def engine(**overrides) -> dict:
    """The metrics of the case with these settings, simulated here."""
    _, cfg = resolve_case(CASE, {k.replace("__", "."): v for k, v in overrides.items()})
    return simulate(cfg).metrics


def engine_trace(names: tuple[str, ...] = CURRENT_SIGNALS, **overrides):
    """The output as the page should plot it: the engine's run at the samples the page
    keeps (all up to MAX_POINTS, else each stretch's extremes), in float32."""
    import numpy as np

    from mfcontrol.tuner.page import keep_points

    _, cfg = resolve_case(CASE, {k.replace("__", "."): v for k, v in overrides.items()})
    r = simulate(cfg)
    keep = keep_points(r.time.size, [r.signals[k] for k in names])
    return np.asarray(r.signals["y"][keep], dtype=np.float32).tolist()


def plotted(page, source: str) -> list:
    return page.evaluate(f"Array.from(mf.model('{source}').data.y)")


def assert_shows(cells: dict, metrics: dict) -> None:
    """The table's exact values (data-value: the repr) are the engine's."""
    for m in SHOWN:
        assert cells[m] == repr(metrics[m]), m


def test_the_page_shows_the_case_run_by_the_engine(page):
    assert_shows(page.evaluate("mf.cells('current')"), engine())
    assert plotted(page, "current-run") == engine_trace()


def test_a_typed_value_redraws_with_the_engines_metrics(page):
    page.evaluate("mf.change('mf-entry-controller-kp', '3.5')")
    assert_shows(page.evaluate("mf.cells('current')"), engine(controller__kp=3.5))
    assert plotted(page, "current-run") == engine_trace(controller__kp=3.5)


def test_moving_a_slider_redraws_with_the_engines_metrics(page):
    handle = page.locator(".mf-slider-controller-alpha .noUi-handle")
    handle.focus()
    for _ in range(5):
        page.keyboard.press("ArrowRight")
    wait_idle(page)
    text = page.locator(".mf-entry-controller-alpha input").input_value()
    alpha = float(text)
    assert alpha > 10.0  # five steps of 0.01 in log10 from 10
    assert_shows(page.evaluate("mf.cells('current')"), engine(controller__alpha=alpha))


def test_freeze_keeps_a_grey_trace_and_a_second_column(page):
    before = page.evaluate("mf.cells('current')")
    page.locator(".mf-freeze button").click()
    page.wait_for_function("() => Object.keys(mf.cells('frozen')).length > 0")
    page.evaluate("mf.change('mf-entry-controller-kp', '4')")
    current, frozen = page.evaluate("mf.cells('current')"), page.evaluate("mf.cells('frozen')")
    assert frozen == {k: v for k, v in before.items() if k in frozen}
    assert_shows(current, engine(controller__kp=4.0))
    assert current["iae"] != frozen["iae"]
    # two traces of the output: the current run and the frozen one
    assert plotted(page, "current-run") == engine_trace(controller__kp=4.0)
    assert plotted(page, "frozen-run-1") == engine_trace(FROZEN_SIGNALS)
    # a second frozen run: a column and a trace of its own, the first kept
    page.locator(".mf-freeze button").click()
    page.wait_for_function("() => Object.keys(mf.cells('frozen-2')).length > 0")
    assert page.evaluate("mf.cells('frozen-1')") == frozen
    assert_shows(page.evaluate("mf.cells('frozen-2')"), engine(controller__kp=4.0))
    assert plotted(page, "frozen-run-2") == engine_trace(FROZEN_SIGNALS, controller__kp=4.0)
    caption = page.evaluate("mf.inside('mf-metrics', 'p.frozen-caption').innerText")
    assert "#1 (solid grey): controller.kp = 2 (now 4)" in caption
    assert "#2 (dashed grey): the current settings" in caption
    page.locator(".mf-clear button").click()
    page.wait_for_function("() => Object.keys(mf.cells('frozen')).length === 0")
    assert page.evaluate("mf.model('frozen-run-1').data.y.length") == 0


def test_the_saved_case_runs_to_the_displayed_metrics(page, tmp_path):
    page.evaluate("mf.change('mf-entry-controller-alpha', '12.5')")
    page.evaluate("mf.change('mf-entry-plant-dR', '2')")
    shown = page.evaluate("mf.cells('current')")
    with page.expect_download() as download:
        page.locator(".mf-save button").click()
    case = tmp_path / download.value.suggested_filename
    download.value.save_as(case)
    assert case.name == f"{CASE}-tuned.toml"
    out = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "mfcontrol.cli", "run", str(case), "--out",
                    str(out)], check=True, cwd=ROOT, capture_output=True)
    ran = json.loads((out / "metrics.json").read_text())
    for m in SHOWN:
        assert shown[m] == repr(ran[m]), m


def test_a_bad_entry_shows_the_clis_message_and_changes_nothing(page, capsys):
    assert main(["show", CASE, "--set", "controller.alpha=-1"]) == 2
    cli_line = capsys.readouterr().err.strip().removeprefix("mfcontrol: error: ")
    before, runs = page.evaluate("mf.cells('current')"), page.evaluate("mf.run()")
    entry = page.locator(".mf-entry-controller-alpha input")
    entry.fill("-1")
    entry.press("Enter")
    page.wait_for_function("() => mf.text('mf-message-controller-alpha')")
    assert page.evaluate("mf.text('mf-message-controller-alpha')").strip() == cli_line
    assert page.evaluate("mf.run()") == runs
    assert page.evaluate("mf.cells('current')") == before
    # the server lives on: a good entry redraws and clears the message
    page.evaluate("mf.change('mf-entry-controller-alpha', '20')")
    assert_shows(page.evaluate("mf.cells('current')"), engine(controller__alpha=20.0))
    page.locator(".mf-message-controller-alpha").wait_for(state="hidden")


def test_round_trip_of_a_change_is_recorded(page, record_property):
    wait_idle(page)
    values = ["2.2", "2.5", "3", "1.8", "2.1", "2.7", "3.3", "1.6", "2.4", "2.9", "2.0", "3.1"]
    times = [page.evaluate(f"mf.change('mf-entry-controller-kp', '{v}')") for v in values]
    times = times[2:]  # the first changes warm the browser's code paths
    metrics = [t["metrics"] for t in times]
    painted = [t["painted"] for t in times]
    med, worst = statistics.median(metrics), max(metrics)
    text = (f"round trip of a change, 10,000 samples ({CASE}), {len(metrics)} changes: "
            f"metrics in the page median {med:.1f} ms, max {worst:.1f} ms; next frame drawn "
            f"median {statistics.median(painted):.1f} ms, max {max(painted):.1f} ms")
    print(text)
    record_property("counts", text)
    # The speed is measured by benchmarks/bench_tuner.py on a quiet machine (median 68-72
    # ms to the metrics, 102-118 ms to the next frame), not asserted here: on the shared
    # cores of the suite it ranged from 112 to 275 ms, and a timed test fails on load,
    # not on a regression. Here: every change made its round trip, and the last one shows
    assert all(0.0 < m < math.inf for m in metrics + painted), times
    assert page.locator(".mf-entry-controller-kp input").input_value() == values[-1]


def test_a_robustness_map_is_drawn_with_its_unstable_members(page):
    page.locator(".mf-map button").click()
    page.locator(".mf-map-status [data-done]").wait_for(timeout=60_000)
    status = page.evaluate("mf.text('mf-map-status')")
    # the same grid in this process: the page says how many members are stable, and some
    # are not (the map's point is to show where)
    from mfcontrol.tuner.session import Session

    m = Session(CASE).robustness_map("controller.alpha", "plant.dR", "iae")
    stable = int(m.settled.sum())
    assert 0 < stable < 81 and "81 runs in" in status and f": {stable} settled" in status
    assert page.evaluate("mf.model('map').children.length") == 1
    title = page.evaluate("mf.model('robustness-map').title.text")
    assert title == "Robustness map: IAE over ultra-local model gain alpha and load change dR"


def test_tuning_applies_the_best_values_and_redraws(page):
    """And (issue 28) the values are shown to 4 digits, and a map drawn before is drawn
    again around them (it stayed on the old setting, titled "around the current
    setting")."""
    page.locator(".mf-map button").click()
    page.locator(".mf-map-status [data-done]").wait_for(timeout=60_000)
    page.evaluate("mf.model('tune-keys').value = ['controller.kp']")
    page.evaluate("mf.model('budget').value = 40")
    page.wait_for_timeout(200)
    page.locator(".mf-tune button").first.click()
    page.locator(".mf-tune-status [data-done]").wait_for(timeout=60_000)
    assert "applied" in page.evaluate("mf.text('mf-tune-status')")
    wait_idle(page)
    text = page.locator(".mf-entry-controller-kp input").input_value()
    kp = float(text)
    assert kp != 2.0 and 0.2 <= kp <= 20.0
    assert text == repr(float(f"{kp:.4g}"))  # 4 significant digits, and run as shown
    shown = page.evaluate("mf.cells('current')")
    assert_shows(shown, engine(controller__kp=kp))
    assert float(shown["iae"]) <= engine()["iae"]  # never worse than the case's own
    page.wait_for_function("() => mf.model('map-subtitle') && mf.model('map-subtitle')"
                           ".text.startsWith('81 runs around the current setting')",
                           timeout=60_000)
    page.locator(".mf-map-status [data-done]").wait_for(timeout=60_000)
    assert "is stale" not in page.evaluate("mf.text('mf-map-status')")


def test_an_emptied_entry_returns_to_the_cases_value(page):
    """Issue 28: an emptied entry took the library's default, not the case's value."""
    page.evaluate("mf.change('mf-entry-reference-t-ramp2', '0.007')")
    assert_shows(page.evaluate("mf.cells('current')"), engine(reference__t_ramp2=0.007))
    page.evaluate("mf.change('mf-entry-reference-t-ramp2', '')")
    assert page.locator(".mf-entry-reference-t-ramp2 input").input_value() == "0.005"
    assert_shows(page.evaluate("mf.cells('current')"), engine())
    assert "back to the case's 0.005" in page.evaluate("mf.text('mf-status')")


def test_the_linear_loop_follows_every_change(page):
    """Issue 30: the margins and the Bode and Nyquist data are the analysis's of the
    settings shown, after every change."""
    import mfcontrol

    _, cfg = resolve_case(CASE)
    m = mfcontrol.analyze(cfg).margins
    shown = page.evaluate("mf.margins()")
    assert float(shown["Ms"]) == m["Ms"] and float(shown["spectral_radius"]) == \
        m["spectral_radius"]
    page.evaluate("mf.change('mf-entry-controller-kp', '4')")
    runs = page.evaluate("mf.run()")
    page.wait_for_function(f"() => mf.margins().run >= {runs}", timeout=30_000)
    _, cfg = resolve_case(CASE, {"controller.kp": 4.0})
    after = mfcontrol.analyze(cfg).margins
    assert float(page.evaluate("mf.margins()")["Ms"]) == after["Ms"] != m["Ms"]
    assert "unstable" in page.evaluate("mf.text('mf-linear')")
    n = page.evaluate("mf.model('linear-loop').data.w.length")
    assert n == 400


def test_undo_goes_back_to_the_run_before(page):
    assert page.locator(".mf-undo button").is_disabled()
    page.evaluate("mf.change('mf-entry-controller-kp', '3.5')")
    runs = page.evaluate("mf.run()")
    page.locator(".mf-undo button").click()
    page.wait_for_function(f"() => mf.run() > {runs}")
    assert page.locator(".mf-entry-controller-kp input").input_value() == "2.0"
    assert_shows(page.evaluate("mf.cells('current')"), engine())
    assert plotted(page, "current-run") == engine_trace()
    page.wait_for_function("() => mf.inside('mf-undo', 'button').disabled")


def test_a_map_off_the_setting_says_so(page):
    """Issue 28: after the setting moved, the map's title still said "around the current
    setting (marked)" and its mark stayed."""
    page.locator(".mf-map button").click()
    page.locator(".mf-map-status [data-done]").wait_for(timeout=60_000)
    subtitle = "mf.model('map-subtitle').text"
    assert page.evaluate(subtitle).startswith("81 runs around the current setting (marked)")
    page.evaluate("mf.change('mf-entry-controller-alpha', '12')")  # on the map
    page.wait_for_function("() => mf.model('map-here').data.x[0] === 12")
    assert page.evaluate(subtitle).startswith("81 runs around alpha = 10, dR = 1 (+)")
    page.evaluate("mf.change('mf-entry-controller-kp', '3')")  # another setting
    page.wait_for_function(f"() => {subtitle}.startsWith('Stale')")
    assert page.evaluate("mf.model('map-here').data.x.length") == 0
    assert "controller.kp = 2 (now 3)" in page.evaluate("mf.text('mf-map-status')")
    assert page.locator(".mf-map button").inner_text() == "Redraw map (9 x 9)"


@pytest.fixture(scope="module")
def motor_tuner(browser):
    yield from served(MOTOR)


@pytest.fixture
def motor(browser, motor_tuner):
    yield from opened(browser, motor_tuner.url)


def test_the_motor_in_its_own_words_with_its_measured_output_and_its_load_step(motor):
    """Issue 28: the motor's voltage limits were titled duty_min / duty_max, the measured
    (noisy) signal was not drawn, the scheduled load step could not be seen or edited."""
    title = motor.evaluate("mf.text('mf-slider-controller-duty-min')")
    assert "armature voltage u, lower limit (V)" in title
    _, cfg = resolve_case(MOTOR)
    r = simulate(cfg)
    y_meas = motor.evaluate("Array.from(mf.model('current-run').data.y_meas)")
    assert y_meas != plotted(motor, "current-run")  # the noise, drawn
    assert motor.evaluate("mf.model('measured-output').visible")
    assert float(max(y_meas)) == pytest.approx(float(r.signals["y_meas"].max()), rel=1e-6)
    assert motor.evaluate("Array.from(mf.model('events').data.text)") == [
        "load torque set to 0.05 N m"]
    motor.evaluate("""mf.change('mf-entry-plant-schedule',
                               '[{t = 2.0, name = "load", set = 0.1}]')""")
    assert motor.evaluate("Array.from(mf.model('events').data.t)") == [2.0]
    _, cfg = resolve_case(MOTOR, {"plant.schedule": [{"t": 2.0, "name": "load", "set": 0.1}]})
    assert_shows(motor.evaluate("mf.cells('current')"), simulate(cfg).metrics)


def test_a_law_switch_loads_the_laws_gains(motor):
    """Issue 28: i-PI -> PID kept the i-PI's gains; the control chattered rail to rail
    under "stable: yes"."""
    runs = motor.evaluate("mf.run()")
    motor.locator(".mf-select-controller-law select").select_option("pid")
    motor.wait_for_function(f"() => mf.run() > {runs}", timeout=120_000)
    wait_idle(motor)
    assert motor.locator(".mf-entry-controller-kp input").input_value() == "2.0"
    assert motor.locator(".mf-entry-controller-ki input").input_value() == "0.0"
    assert "the library's defaults" in motor.evaluate("mf.text('mf-status')")
    _, cfg = resolve_case(MOTOR, {"controller.law": "pid", "controller.kp": 2.0,
                                  "controller.ki": 0.0})
    assert_shows(motor.evaluate("mf.cells('current')"), simulate(cfg).metrics)
    verdict = motor.evaluate("mf.inside('mf-metrics', 'p.verdict').innerText")
    assert "control u: TV(u) 1.137e+04 V" in verdict and "at a limit" in verdict
