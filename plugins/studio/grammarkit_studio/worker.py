"""A worker process that runs `work.Work` operations under a time budget.

The server never derives in its own process: a grammar that takes too long (or loops until the
engine's limits stop it) must not freeze the page, and Python cannot stop a running thread. So
each `Worker` owns one child process; a call that overruns its budget ends that process and
starts a fresh one, and the caller gets a `BudgetExceeded` error saying so. The engine's own
`Limits` (depth, shapes, repeats, triangles, solids) still apply inside the child.

Hand-written rather than concurrent.futures: a process pool cannot end the one process that
runs an overrunning task, and streaming results (the gallery) needs a pipe. The child is a plain
`python -m grammarkit_studio.worker FD` (not multiprocessing's spawn, which re-imports the
caller's main script), talking pickled messages over a socket pair through
multiprocessing.connection.Connection.
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from typing import Any, Callable

from grammarkit.errors import GrammarkitError

from .work import StudioError


class BudgetExceeded(GrammarkitError):
    """A worker call took longer than its time budget; the worker process was restarted."""


class WorkerFailed(GrammarkitError):
    """The worker process died (out of memory, a crash in native code); it was restarted."""


def _serve(conn: Any, path: str, root: str) -> None:  # runs in the child process
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C in the terminal stops the server, which ends us
    _exit_with_parent()
    from .work import Work, error_json

    work = Work(path, root)
    while True:
        try:
            op, kwargs = conn.recv()
        except (EOFError, OSError):
            return  # the server went away
        try:
            try:
                if op == "gallery":
                    for item in work.gallery(**kwargs):
                        conn.send(("item", item))
                    reply = ("end", None)
                elif op == "format":
                    reply = ("ok", work.format_text(**kwargs))
                else:
                    reply = ("ok", getattr(work, op)(**kwargs))
            except (EOFError, OSError):
                raise
            except (GrammarkitError, KeyboardInterrupt, MemoryError, RecursionError) as exc:
                reply = ("error", error_json(exc))
            except Exception as exc:  # noqa: BLE001 - a bug must reach the page, not kill the worker
                reply = ("error", error_json(exc))
            conn.send(reply)
        except (EOFError, OSError):
            return  # the server closed our socket (it stopped, or gave up on this call)


def _exit_with_parent() -> None:
    """End this process soon after the server's process ends, even in the middle of a derive
    (the socket tells only once we next read or write it)."""
    import threading

    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os._exit(0)

    threading.Thread(target=watch, daemon=True, name="parent-watch").start()


class CallFailed(GrammarkitError):
    """A worker operation raised a grammarkit error; `info` is what the page shows."""

    def __init__(self, info: dict):
        super().__init__(info.get("message", "failed"))
        self.info = info


class Worker:
    """One child process running `Work`, used by one call at a time (calls queue on a lock)."""

    OPS = frozenset({"warm", "check", "derive", "export", "tree", "pick", "node_box", "format",
                     "gallery", "backends", "sketch", "sketch_canvas"})

    def __init__(self, path: str, root: str, name: str = "worker"):
        self.path, self.root, self.name = path, root, name
        self._lock = threading.Lock()
        self._proc: Any = None
        self._conn: Any = None
        self.restarts = 0

    # -- process lifetime ------------------------------------------------------------------------
    def start(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            return
        ours, theirs = socket.socketpair()
        fd = theirs.fileno()
        proc = subprocess.Popen([sys.executable, "-m", "grammarkit_studio.worker", str(fd), self.path,
                                 self.root], pass_fds=(fd,), stdin=subprocess.DEVNULL,
                                close_fds=True, start_new_session=True)
        theirs.close()
        self._proc, self._conn = proc, Connection(ours.detach())

    def _end(self) -> None:
        proc, conn = self._proc, self._conn
        self._proc = self._conn = None
        if conn is not None:
            conn.close()
        if proc is not None and proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(2.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(2.0)

    def close(self) -> None:
        with self._lock:
            self._end()

    def interrupt(self) -> None:
        """End the process now, from another thread (a cancelled gallery); the call in progress
        gets a WorkerFailed and the next call starts a fresh process."""
        proc = self._proc
        if proc is not None and proc.poll() is None:
            proc.kill()

    @property
    def pid(self) -> int | None:
        return self._proc.pid if self._proc is not None else None

    # -- calls ---------------------------------------------------------------------------------------
    def call(self, op: str, budget: float, **kwargs: Any) -> Any:
        """Run `op` in the worker; its result, or CallFailed / BudgetExceeded / WorkerFailed."""
        if op not in self.OPS or op == "gallery":
            raise StudioError(f"unknown worker operation {op!r}")
        with self._lock:
            self.start()
            self._send(op, kwargs)
            status, value = self._receive(op, time.monotonic() + budget, budget)
        if status == "error":
            raise CallFailed(value)
        return value

    def stream(self, op: str, budget: float, on_item: Callable[[dict], None], **kwargs: Any) -> None:
        """Run a streaming operation (the gallery): `on_item` gets each item as it arrives."""
        with self._lock:
            self.start()
            self._send(op, kwargs)
            deadline = time.monotonic() + budget
            while True:
                status, value = self._receive(op, deadline, budget)
                if status == "item":
                    on_item(value)
                elif status == "end":
                    return
                elif status == "error":
                    raise CallFailed(value)

    def _send(self, op: str, kwargs: dict) -> None:
        try:
            self._conn.send((op, kwargs))
        except (OSError, ValueError):
            self._end()
            self.start()
            self._conn.send((op, kwargs))

    def _receive(self, op: str, deadline: float, budget: float) -> tuple[str, Any]:
        conn = self._conn
        try:
            if not conn.poll(max(0.0, deadline - time.monotonic())):
                self._end()
                self.restarts += 1
                raise BudgetExceeded(f"{op}: stopped after its time budget of {budget:g} s (the "
                                     "worker process was restarted; a grammar that needs longer "
                                     "can be given more with `grammarkit studio --budget SECONDS`)")
            return conn.recv()
        except (EOFError, OSError) as exc:
            code = self._proc.poll() if self._proc is not None else None
            self._end()
            self.restarts += 1
            why = "it was stopped" if code is not None and code < 0 else f"exit code {code}"
            raise WorkerFailed(f"{op}: the worker process ended ({why}); it was restarted") from exc


def _child_main(argv: list[str]) -> None:
    fd, path, root = int(argv[0]), argv[1], argv[2]
    conn = Connection(fd)
    # the child dies with the server: when the server's end closes, recv() raises EOFError
    _serve(conn, path, root)


if __name__ == "__main__":
    _child_main(sys.argv[1:])
