"""The tuner's local server: Bokeh's server with the page as a function handler, on
127.0.0.1 only, answering only requests addressed to it by name (the Host header) and
accepting websockets from its own pages only, its JavaScript served by itself (nothing
from a CDN: it works offline)."""

from __future__ import annotations

import logging
import sys
import threading
import webbrowser
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

from .session import Session

HOST = "127.0.0.1"
#: the names the server answers to (with its port): the address it listens on and the
#: name a user may type for it
NAMES = (HOST, "localhost")
log = logging.getLogger(__name__)


def make_server(case: str | Path, overrides: Mapping[str, Any] | None = None,
                port: int = 0, io_loop: Any = None):
    """A Bokeh server for the tuner of ``case``, not started.

    Parameters
    ----------
    case : str or Path
        A built-in case or a case file.
    overrides : mapping, optional
        Dotted keys set on it (as ``--set``).
    port : int
        The port on 127.0.0.1; 0 for a free one.
    io_loop : tornado.ioloop.IOLoop, optional
        The loop to run on (default: the current thread's).

    Returns
    -------
    bokeh.server.server.BaseServer
        Its ``port`` is the one bound. The case is loaded, checked and run once before
        (a bad case or setting raises the CLI's error, and the first page opens at once).

    Raises
    ------
    OSError
        When the port cannot be bound (in use).

    Notes
    -----
    Every request goes through :func:`local_only` first: one whose Host header is not
    ``127.0.0.1:PORT`` or ``localhost:PORT`` gets a 403 and never reaches Bokeh, so the
    page, its autoload.js (both carry the session token), the websocket and the static
    files are all covered by one check. Bokeh's own ``Server`` builds its HTTP server
    around its application with no way in between, so the parts are put together here as
    Bokeh's ``BaseServer`` documents.
    """
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.resources import server_url
    from bokeh.server.server import BaseServer
    from bokeh.server.tornado import BokehTornado
    from bokeh.server.util import bind_sockets
    from tornado.httpserver import HTTPServer
    from tornado.ioloop import IOLoop

    from .page import make_document

    first = Session(case, overrides)
    first.run()  # the engine compiled and the case checked before anyone connects
    overrides = dict(overrides or {})
    # the batch kernels load on their first use (seconds): a small map in the background
    # now, so that the page's first map and tuning start at once
    threading.Thread(target=_warm, args=(first,), daemon=True, name="mfcontrol-warm").start()
    first.analysis()  # python-control and scipy imported: the first page's analysis

    def session() -> Session:
        return Session(case, overrides)

    app = Application(FunctionHandler(make_document(session)))
    # bound first (the port the OS chose is known before the names that carry it)
    sockets, port = bind_sockets(HOST, port)
    try:
        hosts = [f"{name}:{port}" for name in NAMES]
        # the page's websocket from its own pages only: another site open in the browser
        # cannot drive the tuner
        bokeh = BokehTornado({"/": app}, extra_websocket_origins=hosts,
                             absolute_url=server_url(HOST, port))
        http = HTTPServer(local_only(bokeh, hosts), xheaders=False)
        http.add_sockets(sockets)
    except Exception:
        for s in sockets:
            s.close()
        raise
    return BaseServer(io_loop or IOLoop.current(), bokeh, http)


def local_only(app: Any, hosts: Sequence[str]) -> Any:
    """``app`` behind a check of the Host header: a request naming any host but one of
    ``hosts`` (``name:port``, compared without case) is refused with a 403 and one plain
    line, before ``app`` sees it.

    Parameters
    ----------
    app : tornado.httputil.HTTPServerConnectionDelegate
        What answers the requests let through (Bokeh's Tornado application).
    hosts : sequence of str
        The Host headers answered.

    Returns
    -------
    tornado.routing.RuleRouter
        What the HTTP server is to serve.

    Notes
    -----
    The server listens on 127.0.0.1 only, yet a page of another site can still reach it:
    its name rebound to 127.0.0.1 (DNS rebinding), the browser takes the tuner for that
    site and lets its script read the page, session token included. Such a request
    names the other site in its Host header, which a browser always sends and a page
    cannot set: the check refuses it. A websocket's upgrade is such a request too.
    """
    from tornado.routing import AnyMatches, Matcher, Rule, RuleRouter

    allowed = frozenset(h.lower() for h in hosts)

    class Named(Matcher):
        def match(self, request: Any) -> dict[str, Any] | None:
            # the header as sent (Tornado's request.host defaults a missing one to
            # 127.0.0.1); several Host headers are joined by commas, so never match
            host = request.headers.get("Host", "").strip().lower()
            return {} if host in allowed else None

    def refuse(request: Any) -> None:
        from tornado.httputil import HTTPHeaders, ResponseStartLine

        # one line in the log, the name repr'd: it is whatever the request said
        log.warning("tuner: refused a request for %r (Host %r: not one of %s)",
                    request.path, request.headers.get("Host"), ", ".join(sorted(allowed)))
        body = (f"403 Forbidden: this server answers only at {' or '.join(hosts)}\n"
                .encode())
        request.connection.write_headers(
            ResponseStartLine("HTTP/1.1", 403, "Forbidden"),
            HTTPHeaders({"Content-Type": "text/plain; charset=utf-8",
                         "Content-Length": str(len(body))}),
            body)
        request.connection.finish()

    return RuleRouter([Rule(Named(), app), Rule(AnyMatches(), refuse)])


def _warm(session: Session) -> None:
    try:
        session.robustness_map(*session.map_axes(), n=3)
    except Exception:  # noqa: BLE001 - a warm-up only: the page reports real errors
        log.debug("tuner: warm-up map failed", exc_info=True)


def serve(case: str | Path, overrides: Mapping[str, Any] | None = None, port: int = 0,
          open_browser: bool = True, out: TextIO = sys.stdout,
          opener: Callable[[str], Any] = webbrowser.open) -> None:
    """Start the tuner's server, print its address, open it in the browser (unless
    ``open_browser`` is False) and serve until interrupted (KeyboardInterrupt, which the
    caller turns into exit code 130)."""
    server = make_server(case, overrides, port)
    server.start()
    url = f"http://{HOST}:{server.port}/"
    print(f"mfcontrol tuner: {url} (Ctrl-C stops it)", file=out, flush=True)
    if open_browser:
        server.io_loop.add_callback(opener, url)
    try:
        server.io_loop.start()
    finally:
        server.stop()
