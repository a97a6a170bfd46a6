"""Open surfaces: the geometry of face terminals, recess reveals and open inserted meshes.

A split model emits two layers (docs/language.md, "Solids and surfaces"): the *solid*, one
watertight manifold, and the *surface layer*: faces that are not views of an emitted solid
(a lot left as a face, the faces of a volume that `comp(f)` consumed, an inserted mesh that is
not closed). Surfaces have no inside, so they never enter a boolean; they are kept as plain
triangles in world coordinates, each with the tag of the terminal it belongs to.

`SurfaceMesh` is an open triangle mesh in a shape's scope coordinates. It offers the few
methods of `manifold3d.Manifold` the split operations use on a shape's `solid` (bounding box,
translate, scale, transform, trim by plane), so an open inserted asset can be moved, scaled
and split like a closed one.
"""
from __future__ import annotations

from typing import Any, Sequence

import manifold3d
import numpy as np

__all__ = ["SurfaceMesh", "face_triangles", "reveal_triangles", "clip_by_plane", "unit_normals"]

Vec = tuple[float, float, float]


def _to_world(pts: np.ndarray, o: Vec, ax: tuple) -> np.ndarray:
    """(n, 3) scope coordinates -> world coordinates."""
    M = np.asarray(ax, dtype=np.float64)  # rows: the scope's x, y, z axes in world coordinates
    return pts @ M + np.asarray(o, dtype=np.float64)


def unit_normals(V: np.ndarray, F: np.ndarray, eps: float = 1e-12
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(which triangles have area: cross product longer than `eps`, their unit normals, every
    triangle's twice area): what the closing of open meshes and the occlusion slabs of open
    surfaces both start from."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    ln = np.linalg.norm(n, axis=1)
    keep = ln > eps
    return keep, n[keep] / ln[keep, None], ln


def face_triangles(o: Vec, ax: tuple, sz: Vec, poly: Any) -> tuple[np.ndarray, np.ndarray]:
    """World vertices and triangles (counter-clockwise about the face normal, the scope's z)
    of a face: the scope rectangle when `poly` is None, else its contours (holes clockwise)."""
    if poly is None:
        sx, sy = sz[0], sz[1]
        pts = np.array([[0.0, 0.0, 0.0], [sx, 0.0, 0.0], [sx, sy, 0.0], [0.0, sy, 0.0]])
        tris = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
        return _to_world(pts, o, ax), tris
    rings = [np.asarray(c, dtype=np.float64).reshape(-1, 2) for c in poly if len(c) >= 3]
    if not rings:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    # manifold3d's triangulator: contours with holes (even-odd by winding), indices into the
    # concatenated contour points
    tris = np.asarray(manifold3d.triangulate(rings), dtype=np.int64).reshape(-1, 3)
    flat = np.concatenate(rings)
    pts = np.column_stack([flat, np.zeros(len(flat))])
    return _to_world(pts, o, ax), tris


def reveal_triangles(o: Vec, ax: tuple, sz: Vec, poly: Any, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """The side walls of a recess of `depth` below a face (z from 0 down to -depth), facing
    into the opening: what a recess shows when there is no solid behind the face to cut."""
    if poly is None:
        sx, sy = sz[0], sz[1]
        rings = [((0.0, 0.0), (sx, 0.0), (sx, sy), (0.0, sy))]
    else:
        rings = [c for c in poly if len(c) >= 3]
    verts: list[list[float]] = []
    tris: list[list[int]] = []
    for ring in rings:
        n = len(ring)
        for i in range(n):
            (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
            if abs(x1 - x0) + abs(y1 - y0) < 1e-12:
                continue
            k = len(verts)
            verts += [[x0, y0, 0.0], [x1, y1, 0.0], [x1, y1, -depth], [x0, y0, -depth]]
            # the outer contour runs counter-clockwise: its inside (the opening) is on the left
            # of each edge, and (a, b, c), (a, c, d) has the normal (-ey, ex) * depth, to the
            # left; holes run clockwise and get walls facing the opening around them the same way
            tris += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return _to_world(np.asarray(verts), o, ax), np.asarray(tris, dtype=np.int64)


def clip_by_plane(V: np.ndarray, F: np.ndarray, normal: Sequence[float], offset: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Keep the part of a triangle mesh where `dot(normal, p) >= offset` (triangles crossing
    the plane are cut; no cap is added: the result is open)."""
    if len(F) == 0:
        return V, F
    n = np.asarray(normal, dtype=np.float64)
    d = V @ n - offset
    inside = d >= -1e-12
    tri_in = inside[F]
    keep_all = tri_in.all(axis=1)
    cross = tri_in.any(axis=1) & ~keep_all
    out_v = [V]
    out_f = [F[keep_all]]
    nv = len(V)
    new_pts: list[np.ndarray] = []
    new_tris: list[list[int]] = []
    for tri in F[cross]:
        ds = d[tri]
        poly: list[Any] = []
        for a in range(3):
            b = (a + 1) % 3
            ia, ib = tri[a], tri[b]
            if ds[a] >= -1e-12:
                poly.append(int(ia))
            if (ds[a] >= -1e-12) != (ds[b] >= -1e-12):
                t = ds[a] / (ds[a] - ds[b])
                new_pts.append(V[ia] + t * (V[ib] - V[ia]))
                poly.append(nv + len(new_pts) - 1)
        for k in range(1, len(poly) - 1):
            new_tris.append([poly[0], poly[k], poly[k + 1]])
    if new_pts:
        out_v.append(np.asarray(new_pts))
    if new_tris:
        out_f.append(np.asarray(new_tris, dtype=np.int64))
    V2 = np.concatenate(out_v)
    F2 = np.concatenate(out_f) if out_f else np.zeros((0, 3), dtype=np.int64)
    # drop the vertices no triangle uses
    used, inv = np.unique(F2, return_inverse=True)
    return V2[used], inv.reshape(-1, 3)


class SurfaceMesh:
    """An open triangle mesh in scope coordinates, standing in for a Manifold on a shape.

    Immutable: every method returns a new SurfaceMesh. `original_id()` is -1 like a Manifold
    that is not an original; the engine never unites these, it emits them as surfaces."""

    __slots__ = ("V", "F")

    def __init__(self, V: np.ndarray, F: np.ndarray):
        self.V = np.asarray(V, dtype=np.float64).reshape(-1, 3)
        self.F = np.asarray(F, dtype=np.int64).reshape(-1, 3)

    def bounding_box(self) -> tuple[float, float, float, float, float, float]:
        if len(self.V) == 0:
            return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        lo, hi = self.V.min(axis=0), self.V.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]), float(hi[1]), float(hi[2]))

    def is_empty(self) -> bool:
        return len(self.F) == 0

    def num_tri(self) -> int:
        return len(self.F)

    def translate(self, t: Sequence[float]) -> "SurfaceMesh":
        return SurfaceMesh(self.V + np.asarray(t, dtype=np.float64), self.F)

    def scale(self, f: Sequence[float]) -> "SurfaceMesh":
        f = np.asarray(f, dtype=np.float64)
        F = self.F if np.prod(f) >= 0 else self.F[:, ::-1]  # a mirror keeps the faces' sides
        return SurfaceMesh(self.V * f, F)

    def transform(self, m: Sequence[Sequence[float]]) -> "SurfaceMesh":
        M = np.asarray(m, dtype=np.float64)
        F = self.F if np.linalg.det(M[:3, :3]) >= 0 else self.F[:, ::-1]
        return SurfaceMesh(self.V @ M[:3, :3].T + M[:3, 3], F)

    def trim_by_plane(self, normal: Sequence[float], offset: float) -> "SurfaceMesh":
        """As Manifold.trim_by_plane: keep where dot(normal, p) >= offset."""
        return SurfaceMesh(*clip_by_plane(self.V, self.F, normal, offset))

    def world(self, o: Vec, ax: tuple) -> np.ndarray:
        return _to_world(self.V, o, ax)

    def __repr__(self) -> str:
        return f"SurfaceMesh({len(self.V)} vertices, {len(self.F)} triangles)"
