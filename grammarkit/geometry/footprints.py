"""Planar footprints: simple polygons as tuples of (x, y) points, with manifold3d CrossSection
doing the robust parts (clipping, insetting, decomposing).

Polygons are plain tuples so the split engine can keep the common case (rectangles) in pure
Python; CrossSection is used only when a polygon really is not a rectangle.
"""
from __future__ import annotations

import math
from typing import Iterable, Sequence

import manifold3d

Point = tuple[float, float]
Polygon = tuple[Point, ...]

__all__ = [
    "Polygon", "area", "bbox", "clip_rect", "convex_cover", "cross_section", "inset", "is_convex",
    "is_rectangle", "normalize", "polygons_of", "validate_polygon",
]

EPS = 1e-9


def area(poly: Sequence[Point]) -> float:
    """Signed area (positive: counter-clockwise)."""
    s = 0.0
    n = len(poly)
    for i in range(n):
        x0, y0 = poly[i]
        x1, y1 = poly[(i + 1) % n]
        s += x0 * y1 - x1 * y0
    return 0.5 * s


def bbox(poly: Sequence[Point]) -> tuple[float, float, float, float]:
    xs = [p[0] for p in poly]
    ys = [p[1] for p in poly]
    return min(xs), min(ys), max(xs), max(ys)


def _segments_cross(a: Point, b: Point, c: Point, d: Point) -> bool:
    def orient(p: Point, q: Point, r: Point) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    return (o1 * o2 < -EPS) and (o3 * o4 < -EPS)


MAX_VERTICES = 10_000  # per footprint or lot: bounds the crossing test's work (a clear error beyond);
# a fine outline of 10,000 vertices checks in ~0.2 s, the worst case (dense long spikes) ~10 s


def first_crossing(points: Sequence[Point], eps: float = 0.0) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of non-adjacent edges of the closed ring that cross
    properly (each edge's ends strictly on both sides of the other's line, beyond `eps`), or
    None.

    Near-linear for real outlines: the edges are bucketed into a uniform grid of about one
    cell per edge and only edges sharing a cell are compared, in numpy (the pairwise test was
    quadratic in Python: 31 s for a 5,000-vertex lot, issue 31). Work is bounded by
    MAX_VERTICES, not by time. Written here because no dependency of grammarkit offers a
    segment-intersection sweep (shapely is not one)."""
    import numpy as np

    ring = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(ring)
    if n > MAX_VERTICES:
        raise ValueError(f"the outline has {n:,} vertices; the limit is {MAX_VERTICES:,}")
    if n < 4:
        return None
    a, b = ring, np.roll(ring, -1, axis=0)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    origin = lo.min(axis=0)
    cells = max(1, int(math.sqrt(n)))
    size = np.maximum((hi.max(axis=0) - origin) / cells, 1e-300)
    c0 = np.clip(((lo - origin) / size).astype(np.int64), 0, cells - 1)
    c1 = np.clip(((hi - origin) / size).astype(np.int64), 0, cells - 1)
    span = (c1 - c0 + 1)
    # (cell, edge) entries: every cell of each edge's box (a long edge covers a row of cells)
    reps = span[:, 0] * span[:, 1]
    edge = np.repeat(np.arange(n), reps)
    k = np.arange(len(edge)) - np.repeat(np.cumsum(reps) - reps, reps)
    cx = c0[edge, 0] + k % span[edge, 0]
    cy = c0[edge, 1] + k // span[edge, 0]
    cell = cx * cells + cy
    order = np.lexsort((edge, cell))
    cell, edge = cell[order], edge[order]
    starts = np.flatnonzero(np.r_[True, cell[1:] != cell[:-1]])
    ends = np.r_[starts[1:], len(cell)]
    best: tuple[int, int] | None = None
    for s0, e0 in zip(starts.tolist(), ends.tolist()):
        if e0 - s0 < 2:
            continue
        es = edge[s0:e0]
        i, j = np.triu_indices(len(es), 1)
        i, j = es[i], es[j]  # i < j: the entries are sorted by edge within a cell
        keep = (j - i > 1) & ~((i == 0) & (j == n - 1))
        i, j = i[keep], j[keep]
        if not len(i):
            continue
        p, q, r, t = a[i], b[i], a[j], b[j]

        def orient(u, v, w):  # noqa: ANN001, ANN202 - arrays of points
            return (v[:, 0] - u[:, 0]) * (w[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (w[:, 0] - u[:, 0])

        hit = (orient(p, q, r) * orient(p, q, t) < -eps) & (orient(r, t, p) * orient(r, t, q) < -eps)
        if hit.any():
            pairs = sorted(zip(i[hit].tolist(), j[hit].tolist()))
            if best is None or pairs[0] < best:
                best = pairs[0]
    return best


def validate_polygon(points: Iterable[Sequence[float]]) -> Polygon:
    """A counter-clockwise simple polygon without repeated points, or ValueError saying why."""
    pts: list[Point] = []
    for p in points:
        if len(p) != 2:
            raise ValueError(f"footprint points must be (x, y) pairs, got {tuple(p)!r}")
        q = (float(p[0]), float(p[1]))
        if not all(math.isfinite(c) for c in q):
            raise ValueError("footprint has a non-finite coordinate")
        if not pts or abs(q[0] - pts[-1][0]) > EPS or abs(q[1] - pts[-1][1]) > EPS:
            pts.append(q)
    if len(pts) > 1 and abs(pts[0][0] - pts[-1][0]) <= EPS and abs(pts[0][1] - pts[-1][1]) <= EPS:
        pts.pop()
    if len(pts) < 3:
        raise ValueError(f"a footprint needs at least 3 distinct points, got {len(pts)}")
    a = area(pts)
    if abs(a) < 1e-9:
        raise ValueError("footprint has zero area")
    crossing = first_crossing(pts, eps=EPS)
    if crossing is not None:
        raise ValueError(f"footprint edges {crossing[0]} and {crossing[1]} cross: the polygon is not simple")
    if a < 0:
        pts.reverse()
        # keep the first edge the user wrote as the first edge (it orients comp faces)
        pts = pts[-2:] + pts[:-2]
    return tuple(pts)


def normalize(poly: Polygon) -> tuple[Polygon, tuple[float, float, float, float]]:
    """Shift a polygon so its bounding box starts at (0, 0); returns it and the old bbox."""
    x0, y0, x1, y1 = bbox(poly)
    return tuple((x - x0, y - y0) for x, y in poly), (x0, y0, x1, y1)


def is_rectangle(poly: Sequence[Point], sx: float, sy: float, tol: float = 1e-9) -> bool:
    """True if the (normalized) polygon is the axis-aligned rectangle [0,sx] x [0,sy]."""
    if len(poly) != 4:
        return False
    return abs(abs(area(poly)) - sx * sy) <= tol * max(1.0, sx * sy) and all(
        (abs(x) <= tol or abs(x - sx) <= tol) and (abs(y) <= tol or abs(y - sy) <= tol) for x, y in poly)


def is_convex(poly: Sequence[Point]) -> bool:
    n = len(poly)
    for i in range(n):
        ax, ay = poly[i]
        bx, by = poly[(i + 1) % n]
        cx, cy = poly[(i + 2) % n]
        if (bx - ax) * (cy - by) - (by - ay) * (cx - bx) < -1e-9:
            return False
    return True


def cross_section(polys: Polygon | Sequence[Polygon]) -> manifold3d.CrossSection:
    """A CrossSection from one polygon or several contours (outer CCW, holes CW)."""
    if polys and isinstance(polys[0][0], (int, float)):
        polys = [polys]  # type: ignore[list-item]
    return manifold3d.CrossSection([list(map(list, p)) for p in polys],
                                   manifold3d.FillRule.Positive)


def polygons_of(cs: manifold3d.CrossSection, min_area: float = 1e-9) -> list[Polygon]:
    """The outer contours of a CrossSection as polygons (holes are dropped by callers that
    only handle simple polygons; contours with negative area are holes)."""
    out = []
    for contour in cs.to_polygons():
        poly = tuple(map(tuple, contour.tolist()))
        if area(poly) > min_area:
            out.append(poly)
    return out


def clip_rect(poly: Polygon, x0: float, y0: float, x1: float, y1: float) -> manifold3d.CrossSection:
    """The part of a polygon inside an axis-aligned rectangle (possibly several pieces)."""
    rect = manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))
    return cross_section(poly) ^ rect


def inset(poly: Polygon, distance: float) -> manifold3d.CrossSection:
    """Offset a polygon by `distance` (negative: inwards) with mitred corners."""
    return cross_section(poly).offset(distance, manifold3d.JoinType.Miter, 2.0)


def convex_cover(poly: Polygon, max_depth: int = 6) -> list[Polygon]:
    """Convex pieces whose union is the polygon, each as large as possible.

    Every reflex vertex is resolved by cutting the polygon along the supporting lines of its two
    edges; pieces that are still non-convex are cut again. Of all convex pieces found, those
    contained in another are dropped. For rectilinear L/U/T footprints this yields the
    overlapping "wings" (an L gives its two full-length bars), which is what roof builders want:
    the union of the wings' hip roofs is the straight-skeleton roof of the L.
    """
    found: list[Polygon] = []

    def visit(p: Polygon, depth: int) -> None:
        if is_convex(p) or depth >= max_depth:
            found.append(p)
            return
        n = len(p)
        for i in range(n):
            a, b, c = p[i - 1], p[i], p[(i + 1) % n]
            cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
            if cross >= -1e-9:
                continue
            for (u, v) in ((a, b), (b, c)):
                for side in (1.0, -1.0):
                    for piece in polygons_of(_half_plane_clip(p, u, v, side)):
                        visit(piece, depth + 1)
            return

    visit(poly, 0)
    # drop pieces contained in another (compare via area of the intersection)
    unique: list[Polygon] = []
    for p in sorted(found, key=lambda q: -area(q)):
        cs = cross_section(p)
        a = cs.area()
        if any(abs((cross_section(q) ^ cs).area() - a) <= 1e-6 * max(1.0, a) for q in unique):
            continue
        unique.append(p)
    return unique


def _half_plane_clip(p: Polygon, u: Point, v: Point, side: float) -> manifold3d.CrossSection:
    """Part of polygon p on one side of the line through u and v (side=+1: left)."""
    x0, y0, x1, y1 = bbox(p)
    big = 4.0 * max(x1 - x0, y1 - y0, 1.0)
    dx, dy = v[0] - u[0], v[1] - u[1]
    ln = math.hypot(dx, dy)
    dx, dy = dx / ln, dy / ln
    nx, ny = -dy * side, dx * side
    cx, cy = u
    quad = ((cx - dx * big, cy - dy * big), (cx + dx * big, cy + dy * big),
            (cx + dx * big + nx * big, cy + dy * big + ny * big),
            (cx - dx * big + nx * big, cy - dy * big + ny * big))
    if area(quad) < 0:
        quad = tuple(reversed(quad))
    return cross_section(p) ^ cross_section(quad)
