"""What every executor is: the protocol back ends program against, and the helpers that the
local executor (grammarkit.run.executor) and the Dask executor (grammarkit.run.dask_executor)
both need. Neither executor imports the other's internals: both stand on this module.

An executor runs *sessions*: a state built once by `init(*args)` in every process that works
for the session, changed only by `update(fn, *args)` calls replayed in order, and `map(fn,
items)` calls whose results come back **in item order**, so results never depend on the number
of workers. An executor owns the worker processes (or the cluster) it starts and stops them in
`close()`.
"""
from __future__ import annotations

import os
import pickle
import sys
import traceback
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator, Protocol

__all__ = ["GUARD_HINT", "Executor", "Session", "WorkerError", "default_workers",
           "main_without_phantom_file", "portable_error", "refuse_in_worker_bootstrap"]

# What to do when worker processes cannot start because the main script runs again in them.
GUARD_HINT = ('a script that starts worker processes needs its top level under '
              '`if __name__ == "__main__":` (each spawned worker imports the main script again)')


class WorkerError(RuntimeError):
    """A worker process died or its function raised something that could not be sent back."""


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


class Session(Protocol):
    def update(self, fn: Callable[..., None], *args: Any) -> None: ...
    def map(self, fn: Callable[[Any, Any], Any], items: Iterable[Any]) -> Iterator[Any]: ...
    def close(self) -> None: ...


class Executor(Protocol):
    """What back ends use for parallel work (see the module docstring)."""

    workers: int

    def session(self, init: Callable[..., Any], *args: Any) -> Session: ...
    def close(self) -> None: ...


def refuse_in_worker_bootstrap() -> None:
    """Stop a main script that is running again inside a worker process being started (a script
    without the `if __name__ == "__main__":` guard): one line, no traceback, exit status 1, in
    the worker; the executor that started it then says what happened."""
    import multiprocessing

    # the flag multiprocessing's own check reads ("An attempt has been made to start a new
    # process before the current process has finished its bootstrapping phase")
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        raise SystemExit("grammarkit: this script is running again in a starting worker process; "
                         + GUARD_HINT)


def portable_error(exc: BaseException) -> BaseException:
    """`exc` if it survives pickling, else a WorkerError carrying its text."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # noqa: BLE001 - whatever pickling raises, the text is sent instead
        text = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        return WorkerError(text)


@contextmanager
def main_without_phantom_file() -> Iterator[None]:
    """Spawned children re-import the parent's main script from `__main__.__file__`. Code run
    from standard input or a notebook has a `__file__` that is no file ('<stdin>'), and the
    child would die looking for it: hide it while starting (the work never lives in it)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or os.path.isfile(path):
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path
