"""CGA's `convexify(max_length = 0)` (docs/operations.md, "convexify"): a face's geometry split
into convex faces, which `comp(f)` then hands out one by one.

Hertel-Mehlhorn: triangulate the face (manifold3d's triangulation, holes included), then drop
diagonals, longest first, wherever the two pieces on either side merge into a convex polygon;
at most four times the optimal number of pieces. With `max_length` > 0 only split lines
shorter than it are kept (CGA: "only split lines shorter than maxLength are applied, one
resulting face may still be concave"): longer diagonals are dropped whether or not the merge
is convex. Pieces are merged only across a single shared edge, so every piece stays a simple
polygon. Written by hand because no permissively licensed Python library offers a convex
partition (CGAL's is GPL, shapely has none).
"""
from __future__ import annotations

import math
from typing import Any


from ...registry import Param
from ..shape import FACE, Shape
from .helpers import lazy_module, manifold3d, operation

np = lazy_module("numpy")

__all__ = ["convex_pieces", "op_convexify"]

MAX_VERTICES = 5_000  # the O(n^2) merge loop is bounded by this


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _convex(loop: list[int], P: np.ndarray) -> bool:
    n = len(loop)
    return all(_cross(P[loop[i - 1]], P[loop[i]], P[loop[(i + 1) % n]]) >= -1e-9 for i in range(n))


def _edges(loop: list[int]) -> list[tuple[int, int]]:
    return [(loop[i], loop[(i + 1) % len(loop)]) for i in range(len(loop))]


def convex_pieces(contours: tuple, max_length: float = 0.0) -> list[list[tuple[float, float]]]:
    """Convex (counter-clockwise) polygons that tile the region (outer contours CCW, holes CW)."""
    rings = [np.asarray(c, dtype=np.float64) for c in contours if len(c) >= 3]
    P = np.concatenate(rings)
    if len(P) > MAX_VERTICES:
        raise ValueError(f"convexify of a face with {len(P)} vertices (more than {MAX_VERTICES})")
    tris = np.asarray(manifold3d.triangulate(rings), dtype=np.int64).reshape(-1, 3)
    pieces: dict[int, list[int]] = {}
    for i, (a, b, c) in enumerate(tris.tolist()):
        if _cross(P[a], P[b], P[c]) < 0:
            b, c = c, b
        if abs(_cross(P[a], P[b], P[c])) > 1e-14:
            pieces[i] = [a, b, c]
    # the diagonals: edges two pieces share; longest first (deterministic order on ties)
    owner: dict[tuple[int, int], int] = {}
    for pid, loop in pieces.items():
        for u, v in _edges(loop):
            owner[(u, v)] = pid
    diagonals = sorted({(min(u, v), max(u, v)) for (u, v) in owner if (v, u) in owner},
                       key=lambda e: (-float(np.linalg.norm(P[e[0]] - P[e[1]])), e))
    for u, v in diagonals:
        a, b = owner.get((u, v)), owner.get((v, u))
        if a is None or b is None or a == b:
            continue
        A, B = pieces[a], pieces[b]
        shared = {(min(x, y), max(x, y)) for x, y in _edges(A)} & {(min(x, y), max(x, y)) for x, y in _edges(B)}
        if len(shared) != 1:
            continue
        # A has the edge u -> v, B the edge v -> u: A from v round to u, then B's inside of u..v
        i = A.index(v)
        A2 = A[i:] + A[:i]
        j = B.index(u)
        B2 = B[j:] + B[:j]
        merged = A2 + B2[1:-1]
        long_line = max_length > 0 and float(np.linalg.norm(P[u] - P[v])) >= max_length
        if not (long_line or _convex(merged, P)):
            continue
        del pieces[b]
        pieces[a] = merged
        owner.pop((u, v), None)
        owner.pop((v, u), None)
        for e in _edges(merged):
            owner[e] = a
    return [[(float(P[k][0]), float(P[k][1])) for k in loop] for _pid, loop in sorted(pieces.items())]


@operation("convexify", (Param("max_length", required=False, default=0.0,
                               doc="keep only split lines shorter than this (0: all)"),),
           doc="Split a face's geometry into convex faces (Hertel-Mehlhorn); comp(f) hands "
               "them out one by one.")
def op_convexify(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`convexify(max_length = 0)`: the face's geometry as convex pieces (one shape; `comp(f)`
    gives each piece its own face). A volume is left as it is, with a warning."""
    ml = args[0] if args else 0.0
    if isinstance(ml, bool) or not isinstance(ml, (int, float)) or not math.isfinite(ml) or ml < 0:
        raise ValueError(f"convexify(): the maximum length must be a number >= 0, got {ml!r}")
    if s.kind != FACE:
        ctx.warn(f"rule {s.rule_name!r}: convexify() of a volume leaves it as it is (faces only)")
        return s
    pieces = convex_pieces(s.contours(), float(ml))
    c = s
    c.poly = tuple(tuple(p) for p in pieces) if len(pieces) > 1 else (s.poly if not pieces else (tuple(pieces[0]),))
    return c
