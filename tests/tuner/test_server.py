"""The tuner's server as ``mfcontrol tuner`` runs it, without a browser: it listens on
127.0.0.1 only, serves its own JavaScript (nothing from a CDN), refuses a websocket from
another origin and any request naming another host, and Ctrl-C ends it with exit code 130
and one line."""

from __future__ import annotations

import http.client
import re
import urllib.parse
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


def fetch(url: str, path: str, host: str) -> tuple[int, str, str]:
    """GET ``path`` from the tuner at ``url`` with the Host header ``host`` (as a page of
    another site sends it after its name was rebound to 127.0.0.1): (status, content
    type, body)."""
    where = urllib.parse.urlsplit(url)
    conn = http.client.HTTPConnection(where.hostname, where.port, timeout=300)
    try:
        conn.request("GET", path, headers={"Host": host})  # replaces http.client's own
        reply = conn.getresponse()
        return reply.status, reply.getheader("Content-Type", ""), reply.read().decode()
    finally:
        conn.close()


#: the session token Bokeh writes into the page and autoload.js (``"token":"eyJ...``):
#: whoever reads it can open the page's websocket and drive the tuner
TOKEN = re.compile(r"token\W+eyJ")


def paths(url: str) -> list[str]:
    """The page and its autoload.js (how another page would embed the tuner)."""
    return ["/", "/autoload.js?bokeh-autoload-element=mf&bokeh-absolute-url="
            + urllib.parse.quote(url.rstrip("/"), safe="")]


def test_a_request_naming_another_host_is_refused_without_the_token(tuner):
    """Issue 29: ``curl -H 'Host: evil.example:PORT'`` got the page and its session token,
    which a page of evil.example whose name was rebound to 127.0.0.1 (DNS rebinding) can
    read as its own."""
    port = urllib.parse.urlsplit(tuner.url).port
    for host in (f"evil.example:{port}", "evil.example", f"127.0.0.1.evil.example:{port}",
                 f"localhost.evil.example:{port}", "127.0.0.1", f"127.0.0.1:{port + 1}",
                 ""):
        for path in paths(tuner.url):
            status, kind, body = fetch(tuner.url, path, host)
            assert status == 403, (host, path, status)
            assert kind.startswith("text/plain") and len(body.splitlines()) == 1, body
            assert not TOKEN.search(body), body


def test_the_page_answers_at_127_0_0_1_and_at_localhost(tuner):
    port = urllib.parse.urlsplit(tuner.url).port
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LocalHost:{port}"):
        for path in paths(tuner.url):
            status, _, body = fetch(tuner.url, path, host)
            assert status == 200 and TOKEN.search(body), (host, path, status)


def websocket(url: str, host: str, origin: str) -> None:
    """Open the tuner's websocket with these Host and Origin headers (raises
    HTTPClientError when refused)."""
    from tornado.httpclient import HTTPRequest
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    async def connect():
        req = HTTPRequest(url.replace("http://", "ws://") + "ws", request_timeout=300,
                          headers={"Host": host, "Origin": origin})
        conn = await websocket_connect(req)
        conn.close()

    IOLoop.current().run_sync(connect)


def test_a_websocket_naming_another_host_is_refused(tuner):
    """Even with the tuner's own origin: the Host is checked before anything else."""
    from tornado.httpclient import HTTPClientError

    port = urllib.parse.urlsplit(tuner.url).port
    for host in (f"evil.example:{port}", "127.0.0.1"):
        with pytest.raises(HTTPClientError) as refused:
            websocket(tuner.url, host, tuner.url.rstrip("/"))
        assert refused.value.code == 403, host
    # the page opened at localhost opens its websocket from there
    websocket(tuner.url, f"localhost:{port}", f"http://localhost:{port}")
    websocket(tuner.url, f"127.0.0.1:{port}", tuner.url.rstrip("/"))


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
