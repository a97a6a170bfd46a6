"""Write-behind: a run's results go into its OutputFolder on a thread of the run's own.

Writing one result (its files as one atomic transaction, then its manifest line) is mostly
file-system work that releases the GIL, so doing it on a thread lets the next results be
derived meanwhile instead of waiting for it. `run_backend` owns one `WriteBehind` per folder
run: `put` hands a result over (blocking while the queue is full: at most `depth` results
and `max_bytes` of their files wait), `written()` returns the entries written since the last
call (so that callbacks run in the caller's thread), and `close()` writes what is queued and
joins the thread.

What holds whatever happens:

- Order: results are written one at a time, in the order handed over, by `OutputFolder.add`
  (the one writer), so manifest lines are in the same order as without the thread.
- A failed write (full disk, a folder gone read-only) stops the writing: nothing after it is
  written (the manifest stays a prefix), and the error is raised in the caller's thread by the
  next `put` or by `close`, as a `WriteStopped` naming the complete results.
- A stop (Ctrl-C, a spent --timeout, a back end's error): `close(abandon=...)` lets the result
  being written finish (each add is atomic; see grammarkit.run.writer), then either writes the
  rest of the queue (errors of the run: the work already done is kept) or drops it
  (`abandon=True`, a KeyboardInterrupt: the user wants the run to stop now; the dropped
  results are made again by the next run). A second Ctrl-C during that wait does not leave
  the thread writing while the folder's lock is released: `close` waits for the one add in
  progress (milliseconds) and raises the interrupt after it.

`GRAMMARKIT_WRITE_BEHIND=0` in the environment makes `run_backend` write synchronously in the
caller's thread (the behaviour before this module; benchmarks/bench_batch.py compares both).
"""
from __future__ import annotations

import os
import threading
from collections import deque
from typing import Any, Mapping

from .writer import WriteStopped

__all__ = ["WriteBehind", "write_behind_enabled"]

DEPTH = 16  # results waiting at most; enough to cover a slow write behind fast derives
MAX_BYTES = 64 << 20  # bytes of files waiting at most (one larger result still goes alone)


def write_behind_enabled() -> bool:
    """False when GRAMMARKIT_WRITE_BEHIND=0 (or "false"/"no"/"off"): write synchronously."""
    return os.environ.get("GRAMMARKIT_WRITE_BEHIND", "1").strip().lower() not in ("0", "false", "no", "off")


def _size(files: Mapping[str, bytes | str]) -> int:
    return sum(len(data) for data in files.values())


class WriteBehind:
    """The write-behind thread of one run into `folder` (an OutputFolder; see the module doc)."""

    def __init__(self, folder: Any, *, depth: int = DEPTH, max_bytes: int = MAX_BYTES):
        if depth < 1:
            raise ValueError(f"depth must be >= 1, got {depth}")
        self.folder, self.depth, self.max_bytes = folder, depth, max_bytes
        self.handed = 0  # results handed over by this run (written, being written or queued)
        self._cond = threading.Condition()
        self._jobs: deque[tuple[dict, Mapping[str, bytes | str], int]] = deque()
        self._bytes = 0
        self._written: list[dict] = []
        self._error: BaseException | None = None
        self._closing = False
        self._thread = threading.Thread(target=self._run, name="grammarkit-write-behind",
                                        daemon=True)
        self._thread.start()

    # -- the caller's side -------------------------------------------------------------------
    def put(self, entry: dict, files: Mapping[str, bytes | str]) -> None:
        """Queue one result's manifest `entry` and `files` (waits while the queue is full);
        raises the error of an earlier failed write."""
        size = _size(files)
        with self._cond:
            while True:
                self._raise_error()
                if self._closing:
                    raise RuntimeError("WriteBehind.put after close")
                if not self._jobs or (len(self._jobs) < self.depth
                                      and self._bytes + size <= self.max_bytes):
                    break
                self._cond.wait()
            self._jobs.append((entry, files, size))
            self._bytes += size
            self.handed += 1
            self._cond.notify_all()

    def written(self) -> list[dict]:
        """The entries written since the last call, in order."""
        with self._cond:
            out, self._written = self._written, []
        return out

    def close(self, abandon: bool = False) -> None:
        """Write what is queued (or, with `abandon`, only the result being written), stop the
        thread and raise the error of a failed write, if any. Closing twice is harmless."""
        with self._cond:
            self._closing = True
            if abandon:
                self._drop()
            self._cond.notify_all()
        interrupted: BaseException | None = None
        while self._thread.is_alive():
            try:
                self._thread.join()
            except KeyboardInterrupt as exc:  # see the module doc: the add in progress ends first
                interrupted = exc
                with self._cond:
                    self._drop()
        if interrupted is not None:
            raise interrupted
        with self._cond:
            self._raise_error()

    def _raise_error(self) -> None:
        if self._error is not None:
            raise self._error

    def _drop(self) -> None:
        """Forget the queued results (the one being written is not in the queue)."""
        self._jobs.clear()
        self._bytes = 0

    # -- the thread --------------------------------------------------------------------------
    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._jobs and not self._closing:
                    self._cond.wait()
                if not self._jobs:
                    return
                entry, files, size = self._jobs.popleft()
                self._bytes -= size
                self._cond.notify_all()  # room for the caller's next put
            error: BaseException | None = None
            try:
                self.folder.add(entry, files)
            except OSError as exc:  # a full disk, a folder gone read-only: the manifest stays a prefix
                error = WriteStopped(str(exc), self.folder.done)
            except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
                error = exc
            with self._cond:
                if error is not None:
                    self._error = error
                    self._drop()  # nothing after a failed write is written
                    self._cond.notify_all()
                    return
                self._written.append(entry)
