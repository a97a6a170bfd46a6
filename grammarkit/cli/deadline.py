"""`--timeout` as a hard stop: code that never returns to the run layer (a plugin operation or
back end stuck in a loop or a sleep) is interrupted too.

The run layer checks its time budget between steps and results (grammarkit/run), which gives
the most precise message but cannot stop a step that never ends. Past the budget plus a short
grace, a SIGALRM handler raises a LimitError in the main thread (Python runs it at the next
bytecode, so a sleep or a pure-Python loop is interrupted). Code stuck inside C that never
returns to Python cannot be interrupted that way: a watchdog thread then ends the process with
the same message and exit status 1. Files are only ever replaced by an atomic rename
(grammarkit.run.writer), so neither way leaves a half-written output.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Iterator

from ..errors import LimitError

GRACE = 1.0  # seconds the run layer gets to stop by itself, with its own message
HARD_GRACE = 10.0  # then seconds the interrupted code gets to unwind before the process ends


def _message(timeout: float) -> str:
    return (f"the run's time budget (--timeout {timeout:g} s) is spent: stopped a step that "
            "did not return (an operation, function or back end that runs too long)")


@contextlib.contextmanager
def hard_deadline(timeout: float | None) -> Iterator[None]:
    """Stop the code in this block `timeout` (+ grace) seconds from now, whatever it does."""
    if timeout is None:
        yield
        return
    use_alarm = hasattr(signal, "SIGALRM") and threading.current_thread() is threading.main_thread()
    done = threading.Event()

    def watchdog() -> None:
        if not done.wait(timeout + GRACE + HARD_GRACE):
            sys.stderr.write(f"error: {_message(timeout)}\n")
            sys.stderr.flush()
            os._exit(1)

    threading.Thread(target=watchdog, name="grammarkit-timeout", daemon=True).start()
    previous = None
    if use_alarm:
        def on_alarm(signum: int, frame: object) -> None:
            raise LimitError(_message(timeout), None, code="timeout")

        previous = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, timeout + GRACE)
    try:
        yield
    finally:
        done.set()
        if use_alarm:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
