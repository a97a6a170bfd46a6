"""Scope operations that turn the scope but not the geometry (CGA's alignScopeToGeometry,
alignScopeToAxes, rotateScope).

grammarkit's faces and prisms keep their outline in the scope's xy plane with z the normal
(the extrusion direction), so these operations turn the scope **about its z axis** only: the
new scope is the bounding box of the unchanged geometry in the turned frame (CGA does the
same). Turning about another axis would take a face's outline out of its scope plane; that is
refused with an error naming the operation.
"""
from __future__ import annotations

import math
from typing import Any

from ..geometry import footprints as fp
from .shape import Shape

__all__ = ["op_align_scope_to_geometry", "op_align_scope_to_axes", "op_reverse_normals", "op_rotate_scope",
           "turn_scope"]

EPS = 1e-9


def _rect_or_poly(poly: Any, sx: float, sy: float) -> Any:
    if len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7):
        return None
    return poly


def turn_scope(s: Shape, ux: float, uy: float) -> Shape:
    """`s` with its scope turned about z so that the new x axis is (ux, uy) in the old scope's
    xy coordinates (a unit vector); the geometry stays where it is in the world."""
    if abs(ux - 1.0) < 1e-12 and abs(uy) < 1e-12:
        return s
    ex, ey, ez = s.ax
    nx = tuple(ux * ex[k] + uy * ey[k] for k in range(3))
    ny = tuple(-uy * ex[k] + ux * ey[k] for k in range(3))

    def to_new(x: float, y: float) -> tuple[float, float]:
        return x * ux + y * uy, -x * uy + y * ux
    rings = [[to_new(x, y) for x, y in c] for c in s.contours()]
    c = s.copy()
    if s.solid is not None:
        # a general solid (roof, insert): turn it with the scope, then re-fit the box to it
        m = [[ux, uy, 0.0, 0.0], [-uy, ux, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
        solid = s.solid.transform(m)
        x0, y0, z0, x1, y1, z1 = solid.bounding_box()
        c.solid = solid.translate((-x0, -y0, -z0))
        c.o = tuple(s.o[k] + nx[k] * x0 + ny[k] * y0 + ez[k] * z0 for k in range(3))  # type: ignore[assignment]
        c.sz = (x1 - x0, y1 - y0, z1 - z0)
        c.ax = (nx, ny, ez)  # type: ignore[assignment]
        c.poly = None
        return c
    pts = [p for r in rings for p in r]
    x0 = min(p[0] for p in pts)
    y0 = min(p[1] for p in pts)
    x1 = max(p[0] for p in pts)
    y1 = max(p[1] for p in pts)
    poly = tuple(tuple((x - x0, y - y0) for x, y in r) for r in rings)
    c.o = tuple(s.o[k] + nx[k] * x0 + ny[k] * y0 for k in range(3))  # type: ignore[assignment]
    c.ax = (nx, ny, ez)  # type: ignore[assignment]
    c.sz = (x1 - x0, y1 - y0, s.sz[2])
    c.poly = _rect_or_poly(poly, x1 - x0, y1 - y0)
    return c


def op_align_scope_to_geometry(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`alignScopeToGeometry(edge)`: x along edge `edge` of the outline (its outer contour, in
    order; negative counts from the end, as in CGA), along the `"longest"` edge, or along the
    `"lowest"` one (CGA's world.lowest: the lowest midpoint in the world; the longest of those
    at that height)."""
    edge = args[0]
    ring = s.contours()[0]
    n = len(ring)
    lengths = [math.dist(ring[i], ring[(i + 1) % n]) for i in range(n)]
    if isinstance(edge, str):
        if edge == "longest":
            i = max(range(n), key=lambda k: (round(lengths[k], 9), -k))
        elif edge == "lowest":
            def height(k: int) -> float:
                (x0, y0), (x1, y1) = ring[k], ring[(k + 1) % n]
                return s.world((x0 + x1) / 2, (y0 + y1) / 2, 0.0)[2]
            i = min((k for k in range(n) if lengths[k] >= EPS),
                    key=lambda k: (round(height(k), 6), -round(lengths[k], 9), k))
        else:
            raise ValueError(f"alignScopeToGeometry(): edge must be a number, \"longest\" or \"lowest\", "
                             f"got {edge!r}")
    elif isinstance(edge, bool) or not isinstance(edge, (int, float)) or not float(edge).is_integer():
        raise ValueError(f"alignScopeToGeometry(): edge must be a whole number, got {edge!r}")
    else:
        i = int(edge) % n
    if lengths[i] < EPS:
        raise ValueError(f"alignScopeToGeometry(): edge {i} has no length")
    (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
    return turn_scope(s, (x1 - x0) / lengths[i], (y1 - y0) / lengths[i])


def _z_is_vertical(s: Shape, what: str) -> None:
    if abs(abs(s.ax[2][2]) - 1.0) > 1e-6:
        raise ValueError(f"{what} turns the scope about its z axis, which must be vertical here "
                         "(a horizontal face or a volume standing up)")


def op_align_scope_to_axes(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`alignScopeToAxes()`: x along the world x axis (projected), for a scope whose z is
    vertical (a lot, a volume standing on it)."""
    _z_is_vertical(s, "alignScopeToAxes()")
    ex, ey, _ = s.ax
    # the world x axis in the scope's xy coordinates
    ux, uy = ex[0], ey[0]
    ln = math.hypot(ux, uy)
    if ln < EPS:
        return s
    return turn_scope(s, ux / ln, uy / ln)


def op_rotate_scope(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`rotateScope(0, 0, angle)`: turn the scope about its z axis by `angle` degrees (the
    geometry stays); rotations about x or y are refused."""
    rx, ry, rz = (float(v) for v in args[:3])
    if abs(rx) > EPS or abs(ry) > EPS:
        raise ValueError("rotateScope() turns the scope about its z axis only: the x and y angles "
                         f"must be 0, got ({rx:g}, {ry:g}, {rz:g})")
    a = math.radians(rz)
    return turn_scope(s, math.cos(a), math.sin(a))


def op_reverse_normals(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `reverseNormals`: a face turned to look the other way (x kept, y and z reversed:
    the scope is mirrored across its x axis, the outline stays in place); an open mesh's
    triangles flipped. A closed volume keeps its outside (turning it inside out would break
    the solid), with a warning."""
    from ..geometry.surfaces import SurfaceMesh
    from .shape import FACE

    if isinstance(s.solid, SurfaceMesh):
        c = s.copy()
        c.solid = SurfaceMesh(s.solid.V, s.solid.F[:, ::-1])
        return c
    if s.kind != FACE:
        ctx.warn(f"reverseNormals in rule {s.rule_name!r}: a closed volume keeps its outside "
                 "(it stays a watertight solid)")
        return s
    ex, ey, ez = s.ax
    sy = s.sz[1]
    c = s.copy()
    c.o = tuple(s.o[k] + ey[k] * sy for k in range(3))  # type: ignore[assignment]
    c.ax = (ex, tuple(-v for v in ey), tuple(-v for v in ez))  # type: ignore[assignment]
    if s.poly is not None:
        c.poly = tuple(tuple(reversed([(x, sy - y) for x, y in ring])) for ring in s.poly)
    c.on = None  # it no longer faces out of its volume
    return c
