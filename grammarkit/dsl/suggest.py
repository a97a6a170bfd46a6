""""Did you mean ...?" hints: known names ordered closest first (difflib)."""
from __future__ import annotations

import difflib
import functools
from typing import Iterable

__all__ = ["NearMisses", "closest_first", "edit_distance", "known_hint"]


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


NEAR_MISS_DISTANCE = 2  # issue 32: a rule name within 2 edits (or equal ignoring case) is a typo


def edit_distance(a: str, b: str, limit: int = NEAR_MISS_DISTANCE) -> int:
    """Levenshtein distance of `a` and `b`, or `limit + 1` once it is known to exceed `limit`
    (a banded dynamic programme: O(len * limit))."""
    if abs(len(a) - len(b)) > limit:
        return limit + 1
    prev = list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        cur = [i] + [limit + 1] * len(b)
        lo, hi = max(1, i - limit), min(len(b), i + limit)
        for j in range(lo, hi + 1):
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (ca != b[j - 1]))
        if min(cur) > limit:
            return limit + 1
        prev = cur
    return min(prev[-1], limit + 1)


class NearMisses:
    """The names of `known` that a misspelt `name` was probably meant to be: equal ignoring
    case, or within NEAR_MISS_DISTANCE edits. Built once per set of names: each name is indexed
    by the strings left after deleting up to two of its characters (symmetric deletion), so a
    query looks at a few candidates, not at every name, even for grammars of 60,000 rules."""

    def __init__(self, known: Iterable[str]):
        self.known = frozenset(known)
        self._folded: dict[str, list[str]] = {}
        self._deletes: dict[str, set[str]] | None = None  # built on the first query
        for k in sorted(self.known):
            self._folded.setdefault(k.casefold(), []).append(k)

    def _index(self) -> dict[str, set[str]]:
        if self._deletes is None:
            self._deletes = {}
            for k in self.known:
                for variant in _deletions(k):
                    self._deletes.setdefault(variant, set()).add(k)
        return self._deletes

    def __call__(self, name: str) -> list[str]:
        """Near misses of `name`, closest first (ties in sorted order); [] for a known name."""
        if name in self.known:
            return []
        same_case = [k for k in self._folded.get(name.casefold(), ()) if k != name]
        index = self._index()
        candidates: set[str] = set()
        for variant in _deletions(name):
            candidates |= index.get(variant, set())
        scored = sorted((edit_distance(name, k), k) for k in candidates)
        near = [k for d, k in scored if d <= NEAR_MISS_DISTANCE and k not in same_case]
        return same_case + near


def _deletions(word: str, depth: int = NEAR_MISS_DISTANCE) -> set[str]:
    """`word` and every string made by deleting up to `depth` of its characters."""
    out = {word}
    frontier = {word}
    for _ in range(depth):
        frontier = {w[:i] + w[i + 1:] for w in frontier for i in range(len(w))}
        out |= frontier
    return out
