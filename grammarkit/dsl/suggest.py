""""Did you mean ...?" hints: known names ordered closest first (difflib)."""
from __future__ import annotations

import difflib
import functools
from typing import Iterable

__all__ = ["closest_first", "known_hint"]


def closest_first(name: str, known: Iterable[str]) -> list[str]:
    return list(_closest_first(name, frozenset(known)))


@functools.lru_cache(maxsize=4096)
def _closest_first(name: str, known: frozenset[str]) -> tuple[str, ...]:
    # cached: a file with many misspellings of one name against many known names stays fast
    ordered = sorted(known)
    close = difflib.get_close_matches(name, ordered, n=3, cutoff=0.5)
    return tuple(close + [k for k in ordered if k not in close])


def known_hint(kind: str, name: str, known: Iterable[str], limit: int = 100) -> str | None:
    """`did you mean 'best'? known KIND: a, b, c` (the prefix only when one is close)."""
    ordered = closest_first(name, known)
    if not ordered:
        return f"there are no {kind}"
    shown = ", ".join(ordered[:limit]) + (", ..." if len(ordered) > limit else "")
    best = ordered[0]
    close = difflib.SequenceMatcher(None, name, best).ratio() >= 0.5
    prefix = f"did you mean '{best}'? " if close else ""
    return f"{prefix}known {kind}: {shown}"
