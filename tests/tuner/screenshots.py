"""The screenshots of the tuner's guide page (docs/guide/tuner.md): the paper's case as it
opens; after a change (kp 2 -> 4) with the case's own run frozen as the reference; after
a robustness map around the case's own gains; the same map gone stale once kp changed; the
DC motor's case, its measured output drawn under the true one, its load step marked, its
limits titled in volts.

    python -m tests.tuner.screenshots [FOLDER]    # default docs/: docs/tuner-*.png
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path

from .browser import ROOT, Tuner, chromium, new_page, open_browser, wait_idle

CASE = "voltage-stable-standard"
MOTOR = "motor-noise-ipi-algebraic"
SIZE = {"width": 1620, "height": 1060}


@contextmanager
def opened(browser, case: str):
    """A page of the tuner of ``case``, drawn; the tuner stopped after."""
    tuner = Tuner(case)
    try:
        page = new_page(browser, tuner.url, **SIZE)
        wait_idle(page)
        yield page
    finally:
        tuner.stop()


def paper(browser, folder: Path) -> None:
    with opened(browser, CASE) as page:
        page.screenshot(path=folder / "tuner-initial.png", full_page=True)
        page.locator(".mf-freeze button").click()
        page.wait_for_function("() => Object.keys(mf.cells('frozen')).length > 0")
        page.evaluate("mf.change('mf-entry-controller-kp', '4')")
        wait_idle(page)
        page.screenshot(path=folder / "tuner-frozen.png", full_page=True)
        runs = page.evaluate("mf.run()")
        page.locator(".mf-undo button").click()  # back to the case's gain
        page.wait_for_function(f"() => mf.run() > {runs}")
        wait_idle(page)
        page.locator(".mf-map button").click()
        page.locator(".mf-map-status [data-done]").wait_for(timeout=120_000)
        page.wait_for_timeout(500)
        page.screenshot(path=folder / "tuner-map.png", full_page=True)
        page.evaluate("mf.change('mf-entry-controller-kp', '1.5')")
        page.wait_for_function("() => mf.model('map-subtitle').text.startsWith('Stale')")
        page.wait_for_timeout(500)
        page.screenshot(path=folder / "tuner-stale.png", full_page=True)


def motor(browser, folder: Path) -> None:
    with opened(browser, MOTOR) as page:
        page.screenshot(path=folder / "tuner-motor.png", full_page=True)


def main(folder: Path) -> None:
    from playwright.sync_api import sync_playwright

    folder.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = open_browser(p, chromium())
        try:
            paper(browser, folder)
            motor(browser, folder)
        finally:
            browser.close()


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs")
