"""Roofs over planar footprints, as manifold3d solids in the footprint's local frame (z up).

Method (chosen for robustness over elegance): every roof is the footprint prism cut by
half-spaces, one inclined plane per roof face, with `Manifold.trim_by_plane`.

- Hip roof of a convex polygon: the prism intersected with, for every edge, the half-space
  below the plane rising from that edge at the roof angle. This is exactly the straight
  skeleton roof of a convex polygon.
- Hip roof of a non-convex polygon (L, U, T footprints): the polygon is covered by maximal
  convex pieces (`footprints.convex_cover`: cut along the edges at each reflex vertex, keep the
  pieces not contained in others; an L gives its two full-length wings) and the hip roofs of
  the pieces are united. For rectilinear footprints whose wings have equal depth this is the
  straight-skeleton roof; otherwise it is a plausible cross-hipped roof with valleys, always a
  closed manifold, never self-intersecting.
- Gable and shed roofs: the prism under two (one) inclined planes whose ridge runs along the
  requested local axis (`ridge="x"` or `"y"`), not along whatever edge happens to come first.
- Pyramid: the convex hull of the base and an apex over the bounding-box centre, clipped by the
  footprint prism (so a non-convex footprint gets a pyramid that does not overhang its notch).
- Mansard: a steep hip roof cut at a break height, topped by a shallow hip roof over the
  footprint inset by the steep part's run.

`overhang` offsets the footprint outwards (mitred corners) before building the roof; the eaves
are then a thin wedge. Every roof's eave ends in a `FASCIA`-high (2 cm) vertical band at z = 0,
not in a knife edge (which comes out of the booleans with pinched, non-manifold corners).
"""
from __future__ import annotations

import math

import manifold3d

from .footprints import Polygon, bbox, convex_cover, cross_section, is_convex, polygons_of

Manifold = manifold3d.Manifold

__all__ = ["edge_direction", "gable", "hip", "mansard", "pyramid", "shed", "overhung"]

# Trimming a prism by a plane through one of its bottom edges (every roof with an overhang:
# the eave planes start at z = 0) leaves zero-area sliver triangles and duplicated vertices
# where the prism's side wall collapsed. The mesh is still an index-level manifold, but any
# reader that welds vertices by position (trimesh, Blender, grammarkit's own load_mesh) sees
# a non-manifold edge. `Manifold.simplify` collapses edges shorter than this (model units).
CLEAN_EPS = 1e-6

# The upper roof of a mansard starts this far below the break, so the two halves overlap
# instead of sharing the break face exactly (a shared face leaves pinched corners).
MANSARD_OVERLAP = 1e-3


# Eaves end in a fascia this high (model units) instead of a knife edge: where a sloped plane
# meets the bottom face at zero thickness, the eave corners come out of manifold3d as pinched
# vertices, and whatever meets the edge in the building's union (the wall's corner edge on a
# hip line, a recess cut, a ledge) leaves pinched vertices or zero-volume slivers.
FASCIA = 0.02


def _fascia(overhang: float) -> float:
    return FASCIA


def _clean(solid: Manifold, lift: float = 0.0) -> Manifold:
    """Collapse sliver edges; with a fascia `lift`, squash z so that the roof keeps the height
    its angle gives without one (the slope gets a hair flatter: 45 degrees over a 6 m span
    becomes 44.8 with the 2 cm fascia), so `roofGable(45)` on 6 m is still 3 m high."""
    if lift > 0:
        top = solid.bounding_box()[5]
        if top > 2 * lift:
            solid = solid.scale((1.0, 1.0, (top - lift) / top))
    return solid.simplify(CLEAN_EPS)


def _check_angle(angle: float, lo: float = 0.0, hi: float = 89.0) -> float:
    if not (lo < angle <= hi):
        raise ValueError(f"roof angle must be in ({lo:g}, {hi:g}] degrees, got {angle:g}")
    return math.tan(math.radians(angle))


def overhung(poly: Polygon, overhang: float) -> list[Polygon]:
    """The footprint grown by `overhang` (mitred corners); several pieces only if it was odd."""
    if overhang < 0:
        raise ValueError(f"overhang must be >= 0, got {overhang:g}")
    if overhang == 0:
        return [poly]
    cs = cross_section(poly).offset(overhang, manifold3d.JoinType.Miter, 2.0)
    return polygons_of(cs)


def _keep_below(solid: Manifold, nx: float, ny: float, c: float, t: float, lift: float = 0.0) -> Manifold:
    """Keep z <= lift + t * (n . p - c) (the side under a plane rising at slope t away from a
    line at height `lift`)."""
    # condition: t*nx*x + t*ny*y - z >= t*c - lift
    vx, vy, vz = t * nx, t * ny, -1.0
    ln = math.sqrt(vx * vx + vy * vy + vz * vz)
    return solid.trim_by_plane((vx / ln, vy / ln, vz / ln), (t * c - lift) / ln)


# A convex footprint with more vertices than this gets its hip roof from one half-space
# intersection (scipy's Qhull) and one convex hull, O(n log n), instead of n plane trims of a
# solid that has O(n) faces, O(n^2): 1,000 vertices took 12 s of CPU that way, 3,000 about 2 min.
HULL_FROM_VERTICES = 48
# Footprints with more vertices than this are refused with a LimitError naming the rule: the
# non-convex cover (one convex piece per reflex vertex, united) grows faster than linearly.
MAX_ROOF_VERTICES = 4096
MAX_NONCONVEX_ROOF_VERTICES = 1024


def _check_vertices(poly: Polygon, convex: bool) -> None:
    from ..errors import LimitError

    limit = MAX_ROOF_VERTICES if convex else MAX_NONCONVEX_ROOF_VERTICES
    if len(poly) > limit:
        raise LimitError(f"the footprint has {len(poly):,} vertices; a roof is built on at most "
                         f"{limit:,} ({'convex' if convex else 'non-convex'} footprints)", None,
                         code="limit-roof-vertices",
                         hint="simplify the footprint (fewer, longer edges) before the roof")


def _hip_convex_hull(poly: Polygon, t: float, lift: float) -> Manifold:
    """The same solid as the plane trims below: prism walls, base and one rising plane per edge
    as half-spaces A x + b <= 0, intersected by Qhull; the convex hull of the corners."""
    import numpy as np
    from scipy.spatial import HalfspaceIntersection

    rows = []
    n = len(poly)
    cx = sum(p[0] for p in poly) / n
    cy = sum(p[1] for p in poly) / n
    for i in range(n):
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        dx, dy = bx - ax, by - ay
        ln = math.hypot(dx, dy)
        if ln < 1e-12:
            continue
        nx, ny = -dy / ln, dx / ln
        c = nx * ax + ny * ay
        rows.append((-nx, -ny, 0.0, c))  # wall: n . p >= c
        rows.append((-t * nx, -t * ny, 1.0, t * c - lift))  # z <= lift + t (n . p - c)
    rows.append((0.0, 0.0, -1.0, 0.0))  # z >= 0
    inside = np.array([cx, cy, min(lift, 1e-3) / 2 if lift > 0 else 1e-6])
    hs = HalfspaceIntersection(np.array(rows), inside)
    return Manifold.hull_points(hs.intersections.tolist())


def _hip_convex(poly: Polygon, t: float, lift: float = 0.0) -> Manifold:
    if len(poly) > HULL_FROM_VERTICES:
        from scipy.spatial import QhullError

        try:
            return _hip_convex_hull(poly, t, lift)
        except QhullError:
            pass  # a degenerate piece (its vertex mean on a wall): the plane trims handle it
    x0, y0, x1, y1 = bbox(poly)
    top = t * max(x1 - x0, y1 - y0) + 1.0 + lift
    solid = Manifold.extrude(cross_section(poly), top)
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        dx, dy = bx - ax, by - ay
        ln = math.hypot(dx, dy)
        if ln < 1e-12:
            continue
        nx, ny = -dy / ln, dx / ln  # inward normal of a counter-clockwise polygon
        solid = _keep_below(solid, nx, ny, nx * ax + ny * ay, t, lift)
    return solid


def _on_segment(x: float, y: float, a: tuple, b: tuple, eps: float = 1e-6) -> bool:
    dx, dy = b[0] - a[0], b[1] - a[1]
    ln2 = dx * dx + dy * dy
    if ln2 < 1e-24:
        return math.hypot(x - a[0], y - a[1]) <= eps
    u = ((x - a[0]) * dx + (y - a[1]) * dy) / ln2
    if u < -eps or u > 1 + eps:
        return False
    return abs((x - a[0]) * dy - (y - a[1]) * dx) / math.sqrt(ln2) <= eps


def _even(solid: Manifold, eaves: list[tuple], lift: float) -> Manifold:
    """CGA's `even`: the roof's ridge vertices (every vertex above the eaves that does not lie
    on an eave edge: the straight skeleton's nodes, the gable ends' apexes) moved to their
    average height, so the ridge is level; the faces around them are no longer planar (the
    mesh keeps its triangles). Every vertex moves vertically and the roof stays a height
    field over the footprint, so the solid stays closed and free of self-intersections."""
    import numpy as np

    mesh = solid.simplify(CLEAN_EPS).to_mesh()
    verts = np.array(mesh.vert_properties, dtype=np.float64)
    ridge = [i for i, (x, y, z) in enumerate(verts[:, :3])
             if z > lift + 1e-6 and not any(_on_segment(x, y, a, b) for a, b in eaves)]
    if len(ridge) < 2:
        return solid
    heights = verts[ridge, 2]
    if float(heights.max() - heights.min()) < 1e-9:
        return solid  # level already (a rectangle's hip or gable): nothing changes
    verts[ridge, 2] = float(heights.mean())
    out = Manifold(manifold3d.Mesh(vert_properties=verts.astype(np.float32),
                                   tri_verts=np.array(mesh.tri_verts, dtype=np.uint32)))
    if out.status() != manifold3d.Error.NoError or out.is_empty():
        raise ValueError("even=true made an invalid roof on this footprint")
    return out


def _edges(p: Polygon) -> list[tuple]:
    return [(p[i], p[(i + 1) % len(p)]) for i in range(len(p))]


def hip(poly: Polygon, angle: float, overhang: float = 0.0, even: bool = False) -> Manifold:
    """The hip roof; `even` (CGA's): the ridge level at the skeleton nodes' average height,
    on convex footprints (a non-convex one keeps its planar roof)."""
    t = _check_angle(angle)
    lift = _fascia(overhang)
    pieces = []
    for p in overhung(poly, overhang):
        _check_vertices(p, is_convex(p))
        if is_convex(p):
            piece = _hip_convex(p, t, lift)
            pieces.append(_even(piece, _edges(p), lift) if even else piece)
        else:
            pieces.extend(_hip_convex(c, t, lift) for c in convex_cover(p))
    if len(pieces) == 1:
        return _clean(pieces[0], lift)
    return _clean(Manifold.batch_boolean(pieces, manifold3d.OpType.Add), lift)


def gable(poly: Polygon, angle: float, overhang: float = 0.0, ridge: str = "x", *,
          overhang_y: float | None = None, index: int | None = None, even: bool = False) -> Manifold:
    """Two planes meeting in a horizontal ridge over the middle of the footprint.

    The ridge runs along local `ridge` ("x" or "y"; "auto": along the footprint's longest
    edge, CGA's automatic orientation on rectangles), or, when `index` is given, along edge
    `index` of the footprint (CGA's indexed gable). `overhang` grows the footprint across the
    ridge (CGA's overhangX, at the eaves) and `overhang_y` along it (CGA's overhangY, at the
    gable ends); without `overhang_y` the footprint grows by `overhang` all round.

    `even` (CGA's, ignored with `index` as in CGA): on a convex footprint, CGA's gable with its
    ridge level — every eave edge (an edge running closer to the ridge direction than across
    it) gets a plane rising from it at the angle, the gable ends stay vertical, and the ridge
    vertices are moved to their average height (`_even`). Eaves stay at the wall top, the ridge
    is level, the faces are no longer planar where the eaves are not parallel.
    """
    if index is None and ridge == "auto" and not is_convex(poly):
        return _gable_wings(poly, angle, overhang, overhang_y)
    direction = _direction(poly, ridge, index)
    if even and index is None:
        return _gable_even(poly, angle, overhang, direction, overhang_y)
    return _pitched(poly, angle, overhang, direction, both_sides=True, overhang_y=overhang_y)


def _whole_edge(a: tuple, b: tuple, poly: Polygon, eps: float = 1e-6) -> bool:
    n = len(poly)
    return any({(round(a[0] / eps), round(a[1] / eps)), (round(b[0] / eps), round(b[1] / eps))}
               == {(round(poly[i][0] / eps), round(poly[i][1] / eps)),
                   (round(poly[(i + 1) % n][0] / eps), round(poly[(i + 1) % n][1] / eps))} for i in range(n))


def _gable_wings(poly: Polygon, angle: float, overhang: float, overhang_y: float | None) -> Manifold:
    """CGA's unindexed gable on a non-convex footprint (L, T, U): not one ridge across the
    bounding box but one per wing, as CityEngine's skeleton-based gable. Each maximal convex
    wing (`convex_cover`) is gabled along its longest edge; a wing's end edge is a vertical
    gable only where it is a whole edge of the footprint (the end of an arm), and hipped where
    the wing runs on along a longer outline edge (into the other wing); the union is the roof.
    A negative `overhang_y` moves the gable ends in (a positive one is not applied here)."""
    t = _check_angle(angle)
    lift = _fascia(overhang)
    parts = []
    for grown in overhung(poly, overhang):
        _check_vertices(grown, False)
        for piece in convex_cover(grown):
            n = len(piece)
            longest = max(range(n), key=lambda i: (round(math.dist(piece[i], piece[(i + 1) % n]), 9), -i))
            ux, uy = edge_direction(piece, longest)
            x0, y0, x1, y1 = bbox(piece)
            solid = Manifold.extrude(cross_section(piece), t * max(x1 - x0, y1 - y0) + 1.0 + lift)
            for i in range(n):
                a, b = piece[i], piece[(i + 1) % n]
                dx, dy = b[0] - a[0], b[1] - a[1]
                ln = math.hypot(dx, dy)
                if ln < 1e-12:
                    continue
                nx, ny = -dy / ln, dx / ln
                if abs(dx * ux + dy * uy) < abs(-dx * uy + dy * ux) and _whole_edge(a, b, grown):
                    if overhang_y is not None and overhang_y < 0:
                        solid = solid.trim_by_plane((nx, ny, 0.0), nx * a[0] + ny * a[1] - overhang_y)
                    continue  # the end of an arm: a vertical gable
                solid = _keep_below(solid, nx, ny, nx * a[0] + ny * a[1], t, lift)
            parts.append(solid)
    if not parts:
        raise ValueError("the footprint leaves no roof")
    return _clean(parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add), lift)


def _gable_even(poly: Polygon, angle: float, overhang: float, direction: tuple,
                overhang_y: float | None) -> Manifold:
    t = _check_angle(angle)
    lift = _fascia(overhang)
    ux, uy, _ = direction
    if overhang_y is None:
        pieces = overhung(poly, overhang)
    else:
        pieces = [_turned(p, ux, uy, back=True) for p in _grow_axes(_turned(poly, ux, uy), overhang_y, overhang)]
    parts = []
    for p in pieces:
        if not is_convex(p):  # CGA's even is for convex faces: the planar gable elsewhere
            parts.append(_pitched(p, angle, 0.0, direction, both_sides=True, overhang_y=None))
            continue
        eaves = []
        x0, y0, x1, y1 = bbox(p)
        solid = Manifold.extrude(cross_section(p), t * max(x1 - x0, y1 - y0) + 1.0 + lift)
        for a, b in _edges(p):
            dx, dy = b[0] - a[0], b[1] - a[1]
            ln = math.hypot(dx, dy)
            if ln < 1e-12 or abs(dx * ux + dy * uy) < abs(-dx * uy + dy * ux):
                continue  # a gable end: vertical
            nx, ny = -dy / ln, dx / ln
            solid = _keep_below(solid, nx, ny, nx * a[0] + ny * a[1], t, lift)
            eaves.append((a, b))
        parts.append(_even(solid, eaves, lift))
    return _clean(parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add), lift)


def shed(poly: Polygon, angle: float, overhang: float = 0.0, ridge: str = "x", *,
         index: int | None = None) -> Manifold:
    """One plane rising from the low side: min y for ridge x, min x for ridge y, or, when
    `index` is given, from edge `index` of the footprint towards the inside (CGA's roofShed)."""
    return _pitched(poly, angle, overhang, _direction(poly, ridge, index), both_sides=False,
                    overhang_y=None)


def edge_direction(poly: Polygon, index: int) -> tuple[float, float]:
    """The unit direction of edge `index` (modulo the number of edges) of a polygon; a
    zero-length edge takes the next edge that has a length."""
    n = len(poly)
    for k in range(n):
        i = (int(index) + k) % n
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        ln = math.hypot(bx - ax, by - ay)
        if ln > 1e-12:
            return (bx - ax) / ln, (by - ay) / ln
    raise ValueError("the footprint has no edge of non-zero length")


def _direction(poly: Polygon, ridge: str, index: int | None) -> tuple[float, float, int | None]:
    """(ux, uy, edge): the ridge's direction u (the planes rise along v = u turned 90 degrees
    counter-clockwise, the inward normal of a counter-clockwise edge along u)."""
    if index is not None:
        ux, uy = edge_direction(poly, index)
        return ux, uy, int(index) % len(poly)
    if ridge == "auto":
        # CGA orients an unindexed gable by itself, from its straight skeleton: on a rectangle
        # the ridge runs along the long sides. Here: along the longest edge (the first of
        # equally long ones), which is that on rectangles and follows the outline's main
        # direction on other footprints, whatever the scope's orientation.
        n = len(poly)
        longest = max(range(n), key=lambda i: (round(math.hypot(poly[(i + 1) % n][0] - poly[i][0],
                                                                  poly[(i + 1) % n][1] - poly[i][1]), 9), -i))
        ux, uy = edge_direction(poly, longest)
        return ux, uy, None
    return (1.0, 0.0, None) if ridge == "x" else (0.0, -1.0, None)


def _turned(poly: Polygon, ux: float, uy: float, back: bool = False) -> Polygon:
    """The polygon in the frame (u, v = (-uy, ux)) (or back from it)."""
    if back:
        return [(x * ux - y * uy, x * uy + y * ux) for x, y in poly]
    return [(x * ux + y * uy, -x * uy + y * ux) for x, y in poly]


def _grow_axes(poly: Polygon, along_x: float, along_y: float) -> list[Polygon]:
    """The polygon grown (or, negative, shrunk) by `along_x` along x and by `along_y` along y:
    the Minkowski sum with the segment [-d, d] on each axis in turn (exact: the polygon plus
    every edge swept along the segment), or the erosion by it (the polygon intersected with
    its two shifted copies; exact for convex footprints, which CGA's indexed roofs require)."""
    cs = cross_section(poly)
    for d, (dx, dy) in ((along_x, (1.0, 0.0)), (along_y, (0.0, 1.0))):
        if abs(d) < 1e-12 or cs.is_empty():
            continue
        if d < 0:
            e = -d
            cs = cs ^ cs.translate((dx * e, dy * e)) ^ cs.translate((-dx * e, -dy * e))
            continue
        swept = [cs]
        for ring in cs.to_polygons():
            pts = ring.tolist()
            for i in range(len(pts)):
                (ax, ay), (bx, by) = pts[i], pts[(i + 1) % len(pts)]
                quad = [(ax - dx * d, ay - dy * d), (ax + dx * d, ay + dy * d),
                        (bx + dx * d, by + dy * d), (bx - dx * d, by - dy * d)]
                hull = manifold3d.CrossSection.hull_points(quad)
                if not hull.is_empty():
                    swept.append(hull)
        cs = manifold3d.CrossSection.batch_boolean(swept, manifold3d.OpType.Add)
    return polygons_of(cs, 1e-9) if not cs.is_empty() else []


def _pitched(poly: Polygon, angle: float, overhang: float, direction: tuple, *, both_sides: bool,
             overhang_y: float | None) -> Manifold:
    """Planes rising at `angle` across the ridge direction u: from both extreme lines of the
    footprint along v (gable) or from the low one (shed). The footprint is extruded above the highest point, then trimmed under each plane."""
    t = _check_angle(angle)
    lift = _fascia(overhang)
    ux, uy, _edge = direction
    vx, vy = -uy, ux
    if overhang_y is None:
        pieces = overhung(poly, overhang)
    else:
        # grow in the ridge's frame: overhang across the ridge (v), overhang_y along it (u)
        pieces = [_turned(p, ux, uy, back=True) for p in _grow_axes(_turned(poly, ux, uy), overhang_y, overhang)]
        if not pieces:
            raise ValueError(f"the overhangs ({overhang:g}, {overhang_y:g}) leave no roof")
    parts = []
    for p in pieces:
        # the low line is the footprint's extreme along v: for a convex footprint and an
        # indexed shed, the line of the indexed edge itself (v is its inward normal)
        vs = [vx * x + vy * y for x, y in p]
        v0, v1 = min(vs), max(vs)
        span = v1 - v0
        solid = Manifold.extrude(cross_section(p), t * span * (0.5 if both_sides else 1.0) + 1.0 + lift)
        solid = _keep_below(solid, vx, vy, v0, t, lift)
        if both_sides:
            solid = _keep_below(solid, -vx, -vy, -v1, t, lift)
        parts.append(solid)
    return _clean(parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add), lift)


def pyramid(poly: Polygon, angle: float, overhang: float = 0.0) -> Manifold:
    t = _check_angle(angle)
    parts = []
    for p in overhung(poly, overhang):
        x0, y0, x1, y1 = bbox(p)
        h = t * min(x1 - x0, y1 - y0) / 2
        lift = _fascia(overhang)
        h += lift
        pts = [(x, y, 0.0) for x, y in p] + [((x0 + x1) / 2, (y0 + y1) / 2, h)]
        if lift:
            pts += [(x, y, lift) for x, y in p]
        solid = Manifold.hull_points(pts)
        if not is_convex(p):
            solid = solid ^ Manifold.extrude(cross_section(p), h + 1.0)
        parts.append(solid)
    return _clean(parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add),
                  _fascia(overhang))


def mansard(poly: Polygon, angle: float, height: float, top_angle: float = 15.0,
            overhang: float = 0.0) -> Manifold:
    """A steep lower roof up to `height`, then a shallow hip over what is left on top."""
    t = _check_angle(angle)
    if height <= 0:
        raise ValueError(f"mansard break height must be > 0, got {height:g}")
    lower = hip(poly, angle, overhang).trim_by_plane((0.0, 0.0, -1.0), -height)
    if top_angle <= 0:
        return _clean(lower)
    run = height / t
    parts = [lower]
    for p in overhung(poly, overhang):
        for q in polygons_of(cross_section(p).offset(-run, manifold3d.JoinType.Miter, 2.0), 1e-6):
            parts.append(hip(q, top_angle).translate((0.0, 0.0, height - MANSARD_OVERLAP)))
    return _clean(parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add))


def keep_below_plane(solid: Manifold, nx: float, ny: float, c: float, slope: float, base: float = 0.0) -> Manifold:
    """The part of `solid` under the plane that starts at height `base` on the line
    {p: (nx, ny) . p = c} and rises at `slope` (rise over run) towards +(nx, ny): what a
    roof plane or a zoning envelope's slanted side keeps (grammarkit/split/ops/envelope.py)."""
    return _keep_below(solid, nx, ny, c, slope, base)
