"""The tuner's local server: Bokeh's server with the page as a function handler, on
127.0.0.1 only, accepting websockets from its own address only, its JavaScript served by
itself (nothing from a CDN: it works offline)."""

from __future__ import annotations

import logging
import socket
import sys
import threading
import webbrowser
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TextIO

from .session import Session

HOST = "127.0.0.1"
log = logging.getLogger(__name__)


def free_port(host: str = HOST) -> int:
    """A port nothing listens on now (the OS's choice for port 0)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


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
    bokeh.server.server.Server
        Its ``port`` is the one bound. The case is loaded, checked and run once before
        (a bad case or setting raises the CLI's error, and the first page opens at once).
    """
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    from .page import make_document

    first = Session(case, overrides)
    first.run()  # the engine compiled and the case checked before anyone connects
    overrides = dict(overrides or {})
    # the batch kernels load on their first use (seconds): a small map in the background
    # now, so that the page's first map and tuning start at once
    threading.Thread(target=_warm, args=(first,), daemon=True, name="mfcontrol-warm").start()

    def session() -> Session:
        return Session(case, overrides)

    app = Application(FunctionHandler(make_document(session)))
    port = port or free_port()
    kwargs: dict[str, Any] = {"address": HOST, "port": port,
                              # the page's websocket from this very origin only: another
                              # site open in the browser cannot drive the tuner
                              "allow_websocket_origin": [f"{HOST}:{port}"],
                              "use_xheaders": False}
    if io_loop is not None:
        kwargs["io_loop"] = io_loop
    return Server({"/": app}, **kwargs)


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
