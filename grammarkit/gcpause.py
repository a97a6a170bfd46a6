"""`paused_gc()`: no cyclic garbage collection inside a block, restored as the caller had it.

Parsing, checking, deriving and the substructure enumeration allocate hundreds of thousands of
small objects that stay alive and form no reference cycles (tokens, IR models, shapes, hash
states); every allocation burst triggers a collection that walks all of them again, which
made `check` of a 500 KB file 1.5-3x slower than the work itself (benchmarks/bench_parse.py)
and doubled the substructure enumeration at 1,000 parts. Nested uses are fine; so are uses in
several threads: the collector resumes when the outermost block of the thread that paused it
ends (a thread that found it paused leaves it to that one).
"""
from __future__ import annotations

import contextlib
import gc
from typing import Iterator

__all__ = ["paused_gc"]


@contextlib.contextmanager
def paused_gc() -> Iterator[None]:
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
