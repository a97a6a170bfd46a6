"""Solids in a scope's frame: boxes, prisms, tapers and inserted meshes, as manifold3d objects.

A frame is an origin plus three orthonormal axes (the scope's x, y, z in world coordinates).
Solids are built in the frame's local coordinates and moved to world space with one affine
transform, which manifold3d applies lazily (so it costs nearly nothing).
"""
from __future__ import annotations

from typing import Sequence

import manifold3d

from .footprints import Polygon, cross_section

Vec = tuple[float, float, float]
Axes = tuple[Vec, Vec, Vec]

__all__ = ["box", "frame_matrix", "insert_fitted", "prism", "taper", "to_frame"]

Manifold = manifold3d.Manifold


def frame_matrix(origin: Vec, axes: Axes) -> list[list[float]]:
    """The 3x4 matrix mapping local (x, y, z) to world: columns are the axes, then the origin."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = axes
    ox, oy, oz = origin
    return [[ax, bx, cx, ox], [ay, by, cy, oy], [az, bz, cz, oz]]


def to_frame(solid: manifold3d.Manifold, origin: Vec, axes: Axes) -> manifold3d.Manifold:
    return solid.transform(frame_matrix(origin, axes))


def box(size: Vec, origin: Vec, axes: Axes, z0: float = 0.0) -> manifold3d.Manifold:
    """The scope box [0,sx] x [0,sy] x [z0, z0+sz] in world coordinates."""
    solid = Manifold.cube(size)
    if z0:
        solid = solid.translate((0.0, 0.0, z0))
    return solid.transform(frame_matrix(origin, axes))


def prism(poly: Polygon | Sequence[Polygon], height: float, z0: float = 0.0) -> manifold3d.Manifold:
    """A polygon (or contours with holes) extruded from z0 to z0+height, in local coordinates."""
    solid = Manifold.extrude(cross_section(poly), height)
    return solid.translate((0.0, 0.0, z0)) if z0 else solid


def taper(poly: Polygon, height: float, top_scale: float) -> manifold3d.Manifold:
    """Extrude with the top scaled about the polygon's centroid (0 gives a pyramid/cone)."""
    n = len(poly)
    cx = sum(p[0] for p in poly) / n
    cy = sum(p[1] for p in poly) / n
    centred = tuple((x - cx, y - cy) for x, y in poly)
    s = max(0.0, float(top_scale))
    solid = Manifold.extrude(cross_section(centred), height, 0, 0.0, (s, s))
    return solid.translate((cx, cy, 0.0))


def insert_fitted(solid: manifold3d.Manifold, size: Vec) -> tuple[manifold3d.Manifold, Vec]:
    """Scale a solid so its bounding box fills [0,sx] x [0,sy] x [0,sz].

    A zero size on an axis keeps the mesh's own proportion on that axis (scaled like the
    other axes), as CGA's `i()` does. Returns the solid and the resulting size.
    """
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    ext = (x1 - x0, y1 - y0, z1 - z0)
    given = [(s / e) for s, e in zip(size, ext) if s > 1e-12 and e > 1e-12]
    default = sum(given) / len(given) if given else 1.0
    scale = tuple((s / e) if (s > 1e-12 and e > 1e-12) else default for s, e in zip(size, ext))
    out = solid.translate((-x0, -y0, -z0)).scale(scale)
    return out, tuple(e * k for e, k in zip(ext, scale))  # type: ignore[return-value]
