"""CGA's `geometry.*` queries on the shape being derived (`geometry.area`, `geometry.volume`,
`geometry.nVertices`, `geometry.isRectangular`, `geometry.isConcave`), read as built-in names in
expressions.

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


def _hull_area(points: np.ndarray) -> float:
    """The area of the convex hull of 2D points (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 9).tolist())))
    if len(pts) < 3:
        return 0.0

    def half(seq: list) -> list:
        out: list = []
        for q in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (q[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (q[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(q)
        return out[:-1]

    ring = half(pts) + half(pts[::-1])
    return abs(fp.area(tuple(ring)))


def _concave_region(area_: float, points: np.ndarray) -> bool:
    """A planar region is convex exactly when it fills its convex hull (holes and notches
    leave part of the hull uncovered); relative tolerance for float noise."""
    hull = _hull_area(points)
    return hull - area_ > 1e-6 * max(hull, 1e-12) + 1e-12


def _concave_faces_of_mesh(V: np.ndarray, F: np.ndarray) -> bool:
    """Whether a triangle mesh has a concave face: its triangles grouped into planar faces
    (edge-connected triangles of one plane), each face compared with its convex hull."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cross = np.cross(b - a, c - a)
    double = np.linalg.norm(cross, axis=1)
    keep = double > 1e-12
    normal = np.zeros_like(cross)
    normal[keep] = cross[keep] / double[keep, None]
    plane = np.round(np.column_stack([normal, (normal * a).sum(axis=1)]), 5)
    # planar faces = connected components of the graph "shares an edge and a plane"
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows: list[int] = []
    cols: list[int] = []
    by_edge: dict = {}
    for t, tri in enumerate(F.tolist()):
        if not keep[t]:
            continue
        for e in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            other = by_edge.setdefault((min(e), max(e)), t)
            if other != t and (plane[other] == plane[t]).all():
                rows.append(t)
                cols.append(other)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(F), len(F)))
    _, label = connected_components(graph, directed=False)
    faces: dict[int, list[int]] = {}
    for t in np.flatnonzero(keep).tolist():
        faces.setdefault(int(label[t]), []).append(t)
    for tris in faces.values():
        n = normal[tris[0]]
        u = np.cross(n, (1.0, 0.0, 0.0) if abs(n[0]) < 0.9 else (0.0, 1.0, 0.0))
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        pts = V[F[tris].ravel()]
        if _concave_region(float(double[tris].sum() / 2), np.column_stack([pts @ u, pts @ w])):
            return True
    return False


def is_concave(s: Any) -> bool:
    """CGA's geometry.isConcave: whether the shape has a concave face (a face with a notch or
    a hole). A face or footprint prism: its outline (a prism's sides are rectangles); a solid
    or an inserted mesh: each of its planar faces."""
    if isinstance(s.solid, SurfaceMesh):
        return _concave_faces_of_mesh(np.asarray(s.solid.V, float), np.asarray(s.solid.F))
    if s.solid is not None:
        mesh = s.solid.to_mesh()
        V = np.asarray(mesh.vert_properties, float)[:, :3]
        return _concave_faces_of_mesh(V, np.asarray(mesh.tri_verts, np.int64))
    if s.poly is None:
        return False
    points = np.asarray([p for c in s.contours() for p in c], float)
    return _concave_region(_outline_area(s), points)


GEOMETRY_QUERIES: dict[str, Callable[[Any], Any]] = {
    "geometry.area": area, "geometry.volume": volume, "geometry.nVertices": n_vertices,
    "geometry.isRectangular": is_rectangular, "geometry.isConcave": is_concave,
}
