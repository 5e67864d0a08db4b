"""What the browser tests and the screenshot script share: the tuner started as the
command line starts it, headless Chromium driven by Playwright, and page-side helpers.

The tests skip without Chromium (Debian's, /usr/bin/chromium) or Playwright unless
MFCONTROL_REQUIRE_BROWSER is set (CI sets it), as the C export's tests do with a compiler.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: Chromium offline: no background traffic, no update check, no QUIC
ARGS = ["--no-sandbox", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run", "--disable-quic", "--disable-gpu"]

#: page-side helpers: Bokeh draws every widget in a shadow root, so the elements are
#: found through them
HELPERS = r"""
window.mf = {
  find(root, sel) {
    const hit = root.querySelector(sel);
    if (hit) return hit;
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) { const f = mf.find(el.shadowRoot, sel); if (f) return f; }
    }
    return null;
  },
  inside(cls, sel) {           // the element sel drawn by the widget of class cls
    const host = mf.find(document, "." + cls);
    if (!host) return null;
    return (host.shadowRoot && mf.find(host.shadowRoot, sel)) || mf.find(host, sel);
  },
  run() {                      // the run counter of the metrics table
    const t = mf.inside("mf-metrics", "table");
    return t ? Number(t.dataset.run) : -1;
  },
  // type text into an entry (as a user does: the change event of Enter), and time until
  // the metrics of the run it causes are in the page, then until the next frame is drawn
  async change(cls, text) {
    const input = mf.inside(cls, "input");
    const host = mf.find(document, ".mf-metrics");
    const root = host.shadowRoot || host;
    const before = mf.run();
    const t0 = performance.now();
    const metrics = await new Promise((resolve, reject) => {
      const obs = new MutationObserver(() => {
        if (mf.run() > before) { obs.disconnect(); resolve(performance.now() - t0); }
      });
      obs.observe(root, {subtree: true, childList: true, attributes: true,
                         characterData: true});
      setTimeout(() => { obs.disconnect(); reject(new Error("no redraw in 10 s")); }, 10000);
      input.value = text;
      input.dispatchEvent(new Event("change", {bubbles: true}));
    });
    await new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
    return {metrics, painted: performance.now() - t0};
  },
  cells(column) {              // metric -> exact value (data-value) of a table column
    const t = mf.inside("mf-metrics", "table");
    const out = {};
    for (const tr of t.querySelectorAll("tr[data-metric]")) {
      const td = tr.querySelector("td." + column);
      if (td && td.dataset.value !== undefined) out[tr.dataset.metric] = td.dataset.value;
    }
    return out;
  },
  margins() {                  // margin -> exact value of the linear loop's table, and
    const t = mf.inside("mf-linear", "table");  // the run it was sent at
    const out = {};
    if (!t) return out;
    for (const tr of t.querySelectorAll("tr[data-margin]")) {
      const td = tr.querySelector("td.current");
      if (td && td.dataset.value !== undefined) out[tr.dataset.margin] = td.dataset.value;
    }
    out.run = Number(t.dataset.run);
    return out;
  },
  text(cls) {                  // the text a Div shows (not its shadow root's styles)
    const el = mf.find(document, "." + cls);
    if (!el) return null;
    const root = el.shadowRoot || el;
    return [...root.children].filter(c => !["STYLE", "LINK"].includes(c.tagName))
      .map(c => c.innerText).join("");
  },
  model(name) { return Bokeh.documents[0].get_model_by_name(name); },
};
"""


def chromium() -> str:
    """The system's Chromium, with Playwright importable; skip (or fail under
    MFCONTROL_REQUIRE_BROWSER) without them."""
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    why = None
    if path is None:
        why = "no chromium on this machine"
    else:
        try:
            import playwright.sync_api  # noqa: F401
        except ImportError:
            why = "playwright is not installed"
    if why:
        if os.environ.get("MFCONTROL_REQUIRE_BROWSER"):
            pytest.fail(why)
        pytest.skip(why)
    return str(path)


class Tuner:
    """``mfcontrol tuner CASE --no-browser`` in a subprocess; ``url`` once it listens."""

    def __init__(self, case: str = "voltage-stable-standard", *sets: str) -> None:
        args = [sys.executable, "-m", "mfcontrol.cli", "tuner", case, "--no-browser"]
        for s in sets:
            args += ["--set", s]
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, cwd=ROOT)
        line = self.proc.stdout.readline()  # the engine loads first: seconds, not minutes
        m = re.search(r"http://127\.0\.0\.1:\d+/", line)
        if not m:
            self.proc.kill()
            raise RuntimeError(f"the tuner did not start: {line!r} {self.proc.stderr.read()}")
        self.url = m[0]

    def stop(self) -> tuple[int, str]:
        """Ctrl-C, as a terminal sends it: (exit code, stderr)."""
        self.proc.send_signal(signal.SIGINT)
        try:
            _, err = self.proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, err = self.proc.communicate()
        return self.proc.returncode, err


def open_browser(playwright, path: str):
    return playwright.chromium.launch(executable_path=path, args=ARGS)


def new_page(browser, url: str, width: int = 1660, height: int = 1000):
    """A page of the tuner, loaded and drawn (the metrics table is there); any request
    that would leave 127.0.0.1 is recorded in ``page.outside`` and refused."""
    context = browser.new_context(viewport={"width": width, "height": height},
                                  accept_downloads=True)
    context.add_init_script(HELPERS)
    page = context.new_page()
    page.outside = []

    def route(r):
        if r.request.url.startswith("http://127.0.0.1:"):
            r.continue_()
        else:
            page.outside.append(r.request.url)
            r.abort()

    context.route("**/*", route)
    page.goto(url)
    page.wait_for_function("() => window.mf && mf.run() >= 1", timeout=30_000)
    return page


def wait_idle(page, quiet_ms: int = 400, timeout: float = 20.0) -> int:
    """Wait until no new run has come for ``quiet_ms``; the run counter."""
    end = time.monotonic() + timeout
    last, since = page.evaluate("mf.run()"), time.monotonic()
    while time.monotonic() < end:
        page.wait_for_timeout(50)
        now = page.evaluate("mf.run()")
        if now != last:
            last, since = now, time.monotonic()
        elif (time.monotonic() - since) * 1e3 >= quiet_ms:
            return now
    raise TimeoutError("the page kept redrawing")
