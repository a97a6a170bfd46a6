""""Did you mean ...?" hints: known names ordered closest first (difflib)."""
from __future__ import annotations

import difflib
import re
import functools
from typing import Any, Iterable

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


def near_miss_distance(name: str) -> int:
    """How many edits still make `name` a typo of a rule: 2, but fewer for short names (every
    one-letter name is one edit from every other: `A --> B` names a leaf B, not a misspelt A),
    so one-letter and two-letter names only match ignoring case, three-letter names within one
    edit."""
    return min(NEAR_MISS_DISTANCE, max(0, len(name) - 2))


def _renumbered(a: str, b: str) -> bool:
    """`R7629` and `R1629`, `Floor2` and `Floor3`: names that differ only in their digits are
    different numbered rules, not a typo of each other."""
    return _DIGITS.sub("", a) == _DIGITS.sub("", b)


_DIGITS = re.compile(r"[0-9]+")


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
    case, or within NEAR_MISS_DISTANCE edits. The edit distance is computed only for names
    that pass a cheap necessary condition (lengths within 2, and character counts within 2:
    the "bag distance" is a lower bound of the edit distance), so a query stays fast and
    memory stays linear even for grammars of 60,000 rules (numpy filters those in one pass)."""

    _NUMPY_FROM = 64  # more names than this: filter with numpy (imported lazily)

    def __init__(self, known: Iterable[str]):
        self.known = frozenset(known)
        self._names = sorted(self.known)
        self._folded: dict[str, list[str]] = {}
        for k in self._names:
            self._folded.setdefault(k.casefold(), []).append(k)
        self._matrix: Any = None  # (lengths, character histograms) for the numpy filter
        self._answers: dict[str, list[str]] = {}  # a misspelling often repeats

    def __call__(self, name: str) -> list[str]:
        """Near misses of `name`, closest first (ties in sorted order); [] for a known name."""
        if name in self.known:
            return []
        if name not in self._answers:
            same_case = [k for k in self._folded.get(name.casefold(), ()) if k != name]
            allowed = near_miss_distance(name)
            scored = sorted((edit_distance(name, k), k) for k in self._candidates(name))
            near = [k for d, k in scored if d <= allowed and k not in same_case and not _renumbered(name, k)]
            self._answers[name] = same_case + near
        return list(self._answers[name])

    def _candidates(self, name: str) -> list[str]:
        limit = NEAR_MISS_DISTANCE
        if len(self._names) <= self._NUMPY_FROM:
            return [k for k in self._names if abs(len(k) - len(name)) <= limit]
        import numpy as np

        if self._matrix is None:
            lengths = np.array([len(k) for k in self._names], dtype=np.int64)
            codes = _COLUMN[np.frombuffer("".join(self._names).encode("utf-8", "replace"), dtype=np.uint8)]
            if len(codes) != int(lengths.sum()):  # non-ASCII names: count them one by one
                codes = np.array([_ALPHABET.get(ch, len(_ALPHABET)) for k in self._names for ch in k],
                                 dtype=np.int64)
            width = len(_ALPHABET) + 1
            rows = np.repeat(np.arange(len(self._names)), lengths)
            hist = np.bincount(rows * width + codes, minlength=len(self._names) * width)
            self._matrix = (lengths, hist.reshape(len(self._names), width).astype(np.int16))
        lengths, hist = self._matrix
        close = np.flatnonzero(np.abs(lengths - len(name)) <= limit)
        h = np.zeros(hist.shape[1], dtype=np.int16)
        for ch in name:
            h[_ALPHABET.get(ch, len(_ALPHABET))] += 1
        diff = hist[close] - h
        # bag distance = max(characters in excess, characters missing); total = excess - missing
        excess = np.maximum(diff, 0).sum(axis=1)
        missing = excess - diff.sum(axis=1)
        keep = close[np.maximum(excess, missing) <= limit]
        return [self._names[i] for i in keep.tolist()]


# the characters of names (`[A-Za-z_][A-Za-z0-9_]*`); any other shares the last column
_ALPHABET = {ch: i for i, ch in enumerate("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")}


def _column_table() -> Any:
    import numpy as np

    table = np.full(256, len(_ALPHABET), dtype=np.int64)
    for ch, col in _ALPHABET.items():
        table[ord(ch)] = col
    return table


class _LazyColumn:
    """`_COLUMN[bytes]`: the histogram column of each byte (numpy, built on first use)."""

    table: Any = None

    def __getitem__(self, codes: Any) -> Any:
        if _LazyColumn.table is None:
            _LazyColumn.table = _column_table()
        return _LazyColumn.table[codes]


_COLUMN = _LazyColumn()
