"""CGA's `splitArea(axis) { area: A | ~area: B }*`: a face split along a scope axis into
parts of given *areas* (docs/operations.md, "splitArea").

The sizes are laid out by split's own code (`grammarkit.split.ops.layout`), in area units
instead of lengths: absolute areas, relative ones (`'0.3`: that share of the face's area),
floating ones sharing what is left, repeat groups with split's repetition count (and its
limit, `limits.max_repeat`). Each part's area interval [a0, a1] is then turned into the
interval [t0, t1] along the axis where the face's area left of t is a0 and a1: the cut
positions.

The area left of t, A(t), is exact and piecewise quadratic: between two consecutive vertex
coordinates along the axis the face's width across it changes linearly, so A is a quadratic
there, known from three samples (manifold3d clips the face), and each cut position solves it.
"""
from __future__ import annotations

import math
from bisect import bisect_right
from typing import Any


from ...registry import Param
from ..shape import FACE, Shape
from .helpers import axis_index, fp, manifold3d, not_a_face, operation
from .layout import layout, split_geometry

__all__ = ["op_split_area", "AreaProfile"]

EPS = 1e-9


class AreaProfile:
    """The area of a region left of (below) a coordinate along x (axis 0) or y (axis 1)."""

    def __init__(self, contours: tuple, axis: int, length: float):
        self.region = fp.cross_section(contours)
        self.axis = axis
        self.length = length
        coords = sorted({min(max(p[axis], 0.0), length) for ring in contours for p in ring} | {0.0, length})
        self.breaks = coords
        self.areas = [self.left_of(t) for t in coords]
        self.total = self.areas[-1]

    def left_of(self, t: float) -> float:
        if t <= 0:
            return 0.0
        big = 2 * self.length + 1.0
        if self.axis == 0:
            box = manifold3d.CrossSection.square((t + big, 3 * big)).translate((-big, -big))
        else:
            box = manifold3d.CrossSection.square((3 * big, t + big)).translate((-big, -big))
        return (self.region ^ box).area()

    def position(self, a: float) -> float:
        """The coordinate t with left_of(t) == a (the first such t where the face is empty)."""
        if a <= 0:
            return 0.0
        if a >= self.total:
            return self.length
        k = max(0, min(bisect_right(self.areas, a) - 1, len(self.breaks) - 2))
        while k > 0 and self.areas[k] >= a:  # an interval where the area grows past a
            k -= 1
        b0, b1 = self.breaks[k], self.breaks[k + 1]
        a0, a1 = self.areas[k], self.areas[k + 1]
        h = b1 - b0
        if h <= EPS:
            return b0
        am = self.left_of(b0 + h / 2)
        # A(b0 + u h) = a0 + p u + q u^2 on u in [0, 1], from the three samples
        q = 2 * (a1 + a0 - 2 * am)
        p = a1 - a0 - q
        target = a - a0
        if abs(q) < 1e-12 * max(1.0, abs(p)):
            u = target / p if abs(p) > 0 else 0.0
        else:
            disc = max(p * p + 4 * q * target, 0.0)
            u = (-p + math.sqrt(disc)) / (2 * q)
            if not (-1e-9 <= u <= 1 + 1e-9):
                u = (-p - math.sqrt(disc)) / (2 * q)
        return b0 + min(max(u, 0.0), 1.0) * h


@operation("splitArea", (Param("axis", "axis", choices=("x", "y")),
                         Param("adjust_mode", "axis", required=False, default="adjust",
                               choices=("adjust", "noAdjust"),
                               doc="adjust: each part's scope fits its geometry; noAdjust: the "
                                   "parts' scopes tile the parent's")),
           block="sizes",
           doc="Split a face along an axis into parts of the given areas (absolute, 'relative, "
               "~floating, repeat groups: split's sizes, in area units).")
def op_split_area(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`splitArea(axis, adjust_mode) { area: A | ... }`: parts of the given areas."""
    a = axis_index(args[0])
    mode = str(args[1]) if len(args) > 1 else "adjust"
    if mode not in ("adjust", "noAdjust"):
        raise ValueError(f"splitArea adjust mode must be adjust or noAdjust, got {mode!r}")
    if s.kind != FACE:
        raise ValueError(not_a_face(s, "splitArea"))
    if a == 2:
        raise ValueError("splitArea(z) on a face: faces are flat, split them along x or y")
    length = s.sz[a]
    if length <= EPS or s.sz[1 - a] <= EPS:
        raise ValueError(f"splitArea({args[0]}) on a face of size 0")
    profile = AreaProfile(s.contours(), a, length)
    if profile.total <= EPS:
        raise ValueError("splitArea() on a face of area 0")
    out = []
    for slot, start, size in layout(ctx, s, block, profile.total):
        t0, t1 = profile.position(start), profile.position(start + size)
        if t1 - t0 <= EPS:
            continue
        c = split_geometry(s, a, t0, t1 - t0)
        if c is None:
            continue
        if mode == "noAdjust":
            c = _slab_scope(s, a, t0, t1)
            if c is None:
                continue
        out.append((c, slot))
    return out


def _slab_scope(s: Shape, a: int, t0: float, t1: float) -> Shape | None:
    """CGA's noAdjust: the part's scope is the slab [t0, t1] of the parent's scope (no gaps
    between the parts' scopes), its geometry the face clipped to it."""
    x0, y0, x1, y1 = (t0, 0.0, t1, s.sz[1]) if a == 0 else (0.0, t0, s.sz[0], t1)
    cs = fp.cross_section(s.contours()) ^ manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))
    if cs.is_empty():
        return None
    contours = []
    for ring in cs.to_polygons():
        poly = tuple((x - x0, y - y0) for x, y in ring.tolist())
        if abs(fp.area(poly)) > EPS:
            contours.append(poly)
    if not contours:
        return None
    sx, sy = x1 - x0, y1 - y0
    rect = len(contours) == 1 and fp.is_rectangle(contours[0], sx, sy, 1e-7)
    return s.derived(s.world(x0, y0, 0.0), (sx, sy, 0.0), None if rect else tuple(contours), FACE)
