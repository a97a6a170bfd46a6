"""Starting the studio: a socket on 127.0.0.1, uvicorn serving the app, the URL printed.

    from grammarkit_studio import serve, running

    serve("grammars/paris.grammar", open_browser=True)     # blocks until Ctrl-C

    with running("grammars/paris.grammar") as studio:      # in a background thread
        print(studio.url)
"""
from __future__ import annotations

import contextlib
import socket
import threading
import time
from pathlib import Path
from typing import Any, Iterator

from grammarkit.errors import GrammarkitError

from .app import MAX_MESSAGE, Studio

HOST = "127.0.0.1"  # never anything else: the studio is for the person at this machine


def bind(port: int | None) -> socket.socket:
    """A listening socket on 127.0.0.1 (`port`, or a free one the system picks)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind((HOST, port or 0))
    except OSError as exc:
        sock.close()
        raise GrammarkitError(f"cannot listen on {HOST}:{port}: {exc.strerror or exc} "
                              "(leave out --port to take a free one)") from None
    sock.listen(64)
    return sock


def _server(studio: Studio, sock: socket.socket, log_level: str) -> Any:
    import uvicorn

    from uvicorn.config import WS_PROTOCOLS

    ws = "websockets-sansio" if "websockets-sansio" in WS_PROTOCOLS else "websockets"
    config = uvicorn.Config(studio.app, log_level=log_level, ws=ws, ws_max_size=MAX_MESSAGE,
                            ws_per_message_deflate=False, lifespan="on", access_log=False,
                            server_header=False, timeout_graceful_shutdown=2)
    server = uvicorn.Server(config)
    return server


def serve(path: str | Path, *, port: int | None = None, open_browser: bool = False,
          budget: float = 30.0, log_level: str = "warning", echo: Any = print) -> None:
    """Run the studio for `path` until interrupted."""
    sock = bind(port)
    studio = Studio(path, port=sock.getsockname()[1], budget=budget)
    server = _server(studio, sock, log_level)
    echo(f"grammarkit studio: {studio.path}")
    echo(f"  open {studio.url}")
    echo("  (this address holds a secret token: do not share it; Ctrl-C stops the studio)")
    if open_browser:
        import webbrowser

        threading.Timer(0.5, webbrowser.open, args=(studio.url,)).start()
    try:
        server.run(sockets=[sock])
    finally:
        studio.close()
        sock.close()


@contextlib.contextmanager
def running(path: str | Path, *, port: int | None = None, budget: float = 30.0,
            log_level: str = "warning", poll: float = 0.5) -> Iterator[Studio]:
    """The studio served from a background thread while the block runs (tests, notebooks)."""
    sock = bind(port)
    studio = Studio(path, port=sock.getsockname()[1], budget=budget, poll=poll)
    server = _server(studio, sock, log_level)
    server.install_signal_handlers = lambda: None  # not the main thread
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True,
                              name="grammarkit-studio")
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started and thread.is_alive() and time.monotonic() < deadline:
        time.sleep(0.02)
    if not server.started:
        studio.close()
        sock.close()
        raise GrammarkitError("the studio server did not start")
    try:
        yield studio
    finally:
        server.should_exit = True
        thread.join(10)
        studio.close()
        sock.close()
