"""Derivation paths as numbers: the labels of rules and block slots, and per-shape seeds.

Light on purpose (no geometry): the compiler labels its rules and slots with these while
`grammarkit check` and `grammarkit plugins` never import the engine's geometry.
"""
from __future__ import annotations

import zlib
from typing import Any

M64 = (1 << 64) - 1

__all__ = ["M64", "label_of", "mix"]


def mix(a: int, b: int) -> int:
    """A per-shape seed from the parent's seed and a path label.

    Python's hash of a tuple of ints is deterministic across processes (only str/bytes hashing
    is randomised) and costs ~0.1 us, against ~2 us for a splitmix64 in pure Python; the
    generator seeded with it (`random.Random`) scrambles the bits anyway.
    """
    return hash((a, b)) & M64


def label_of(*parts: Any) -> int:
    """A stable (process-independent) 32-bit label for a derivation path step."""
    return zlib.crc32("\x1f".join(map(str, parts)).encode())
