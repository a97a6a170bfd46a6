"""CGA's `geometry.*` queries on the shape being derived (`geometry.area`, `geometry.volume`,
`geometry.nVertices`, `geometry.isRectangular`), read as built-in names in expressions.

A face: its outline (holes subtract); a box or footprint prism: its closed surface; a general
solid (roof, taper, closed insert): its mesh; an open inserted mesh: its triangles (volume 0).
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..geometry import footprints as fp
from ..geometry.surfaces import SurfaceMesh
from .shape import FACE

__all__ = ["GEOMETRY_QUERIES"]


def _outline_area(s: Any) -> float:
    return abs(sum(fp.area(c) for c in s.contours())) if s.poly is not None else s.sz[0] * s.sz[1]


def _perimeter(s: Any) -> float:
    return sum(math.dist(c[i], c[(i + 1) % len(c)]) for c in s.contours() for i in range(len(c)))


def _mesh_area(m: SurfaceMesh) -> float:
    a, b, c = (m.V[m.F[:, k]] for k in range(3))
    return float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2)


def area(s: Any) -> float:
    if s.kind == FACE:
        return _outline_area(s)
    if isinstance(s.solid, SurfaceMesh):
        return _mesh_area(s.solid)
    if s.solid is not None:
        return float(s.solid.surface_area())
    return 2 * _outline_area(s) + _perimeter(s) * s.sz[2]


def volume(s: Any) -> float:
    if s.kind == FACE or isinstance(s.solid, SurfaceMesh):
        return 0.0
    if s.solid is not None:
        return float(s.solid.volume())
    return _outline_area(s) * s.sz[2]


def n_vertices(s: Any) -> int:
    if isinstance(s.solid, SurfaceMesh):
        return len(s.solid.V)
    if s.solid is not None:
        return int(s.solid.num_vert())
    n = sum(len(c) for c in s.contours())
    return n if s.kind == FACE else 2 * n


def is_rectangular(s: Any) -> bool:
    """A face or prism whose outline is one rectangle (CGA's geometry.isRectangular with its
    default tolerance)."""
    if s.solid is not None:
        return False
    if s.poly is None:
        return True
    if len(s.poly) != 1:
        return False
    ring = list(s.poly[0])
    # drop vertices on a straight line between their neighbours (a split leaves them)
    kept = [p for i, p in enumerate(ring)
            if abs((p[0] - ring[i - 1][0]) * (ring[(i + 1) % len(ring)][1] - p[1])
                   - (p[1] - ring[i - 1][1]) * (ring[(i + 1) % len(ring)][0] - p[0])) > 1e-9]
    return len(kept) == 4 and fp.is_rectangle(tuple(kept), s.sz[0], s.sz[1], 1e-6)


GEOMETRY_QUERIES: dict[str, Callable[[Any], Any]] = {
    "geometry.area": area, "geometry.volume": volume, "geometry.nVertices": n_vertices,
    "geometry.isRectangular": is_rectangular,
}
