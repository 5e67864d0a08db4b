"""Round trip of a change in the browser tuner, against the engine's run of the same case.

Starts ``mfcontrol tuner voltage-stable-standard --no-browser`` (10,000 samples), loads the
page in headless Chromium (Debian's, through Playwright's ``executable_path``), then types
values of ``controller.kp`` one after another. Each change is timed in the page, from the
entry's change event until the new run's metrics are in the page, and until the next frame
is drawn. In the same process, interleaved with the changes, the baseline: the same
setting simulated by the tuner's model (``Session.run``, the engine and its metrics),
which is what a change cannot avoid. Prints the medians, the ratio of the round trip to
that baseline, and the issue's target (100 ms). Timings are printed, never asserted.

Run:  python benchmarks/bench_tuner.py [--changes 30]
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the browser harness of the tests (tests/tuner/browser.py)

from tests.tuner.browser import Tuner, new_page, open_browser, wait_idle  # noqa: E402

from mfcontrol.tuner.session import Session  # noqa: E402

CASE = "voltage-stable-standard"
TARGET_MS = 100.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--changes", type=int, default=30)
    args = parser.parse_args()
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        sys.exit("bench_tuner: needs Debian's chromium (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    values = [f"{1.5 + 0.05 * (i % 30):g}" for i in range(args.changes + 3)]
    session = Session(CASE)
    tuner = Tuner(CASE)
    try:
        with sync_playwright() as p:
            browser = open_browser(p, path)
            page = new_page(browser, tuner.url)
            wait_idle(page)
            trips, painted, engine = [], [], []
            for i, v in enumerate(values):
                t = page.evaluate(f"mf.change('mf-entry-controller-kp', '{v}')")
                session.set("controller.kp", v)
                t0 = time.perf_counter()
                session.run()
                run_ms = (time.perf_counter() - t0) * 1e3
                if i >= 3:  # the first changes warm the browser's and the engine's paths
                    trips.append(t["metrics"])
                    painted.append(t["painted"])
                    engine.append(run_ms)
            browser.close()
    finally:
        tuner.stop()
    med, eng = statistics.median(trips), statistics.median(engine)
    print(f"{CASE} (10,000 samples), {len(trips)} changes of controller.kp:")
    print(f"  round trip to the metrics in the page: median {med:.1f} ms, "
          f"max {max(trips):.1f} ms (target {TARGET_MS:.0f} ms: "
          f"{'met' if med < TARGET_MS else 'missed'})")
    print(f"  to the next drawn frame:               median {statistics.median(painted):.1f} "
          f"ms, max {max(painted):.1f} ms")
    print(f"  baseline, the engine's run (Session.run): median {eng:.2f} ms")
    print(f"  ratio round trip / engine run: {med / eng:.1f}")


if __name__ == "__main__":
    main()
