"""The tuner's server as ``mfcontrol tuner`` runs it, without a browser: it listens on
127.0.0.1 only, serves its own JavaScript (nothing from a CDN), refuses a websocket from
another origin, and Ctrl-C ends it with exit code 130 and one line."""

from __future__ import annotations

import re
import urllib.request

import pytest

from .browser import Tuner


@pytest.fixture(scope="module")
def tuner():
    t = Tuner("first-order-ip-algebraic", "controller.kp=5")
    yield t
    if t.proc.poll() is None:
        t.stop()


def test_the_page_and_its_javascript_come_from_the_server(tuner):
    page = urllib.request.urlopen(tuner.url, timeout=20).read().decode()
    scripts = re.findall(r'<script[^>]+src="([^"]+)"', page)
    assert scripts, page[:500]
    for src in scripts:
        assert src.startswith("/static/") or src.startswith(tuner.url), src
        body = urllib.request.urlopen(tuner.url.rstrip("/") + src if src.startswith("/")
                                      else src, timeout=20).read()
        assert len(body) > 1000
    assert "cdn.bokeh.org" not in page and "https://" not in page.replace(
        "https://bokeh.org", "")


def test_a_websocket_from_another_origin_is_refused(tuner):
    from tornado.httpclient import HTTPClientError, HTTPRequest
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    ws = tuner.url.replace("http://", "ws://") + "ws"

    async def connect(origin: str):
        req = HTTPRequest(ws, headers={"Origin": origin}, request_timeout=10)
        conn = await websocket_connect(req)
        conn.close()

    with pytest.raises(HTTPClientError) as refused:
        IOLoop.current().run_sync(lambda: connect("http://example.com"))
    assert refused.value.code == 403  # and the server says so on stderr
    IOLoop.current().run_sync(lambda: connect(tuner.url.rstrip("/")))  # its own page's


def test_ctrl_c_stops_it_with_exit_130_and_one_line():
    code, err = Tuner("first-order-ip-algebraic").stop()
    assert code == 130
    assert err.strip().splitlines() == ["mfcontrol: tuner stopped"]


def test_a_port_in_use_is_one_line_and_exit_2(capsys):
    """Found in review: a busy --port ended with a raw OSError and exit code 1."""
    import socket

    pytest.importorskip("bokeh")
    from mfcontrol.cli import main

    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        rc = main(["tuner", "voltage-stable-standard", "--no-browser", "--port", str(port)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and f"--port = {port}: is in use" in err[0]
