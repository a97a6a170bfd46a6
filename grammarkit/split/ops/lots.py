"""CGA's lot and massing operations on faces: the `setback` family, `shapeL`/`shapeU`/`shapeO`
and `innerRectangle` (docs/operations.md, "Setbacks").

A setback moves selected edges of a face inwards. The geometry is built from per-edge bands:
at every vertex the two neighbouring edges' offset lines (each edge moved inwards by its own
distance, 0 for edges that are not set back) meet in a point R; the band of an edge is the
quad (edge start, edge end, R at its end, R at its start), so neighbouring bands share the
line from the vertex to R (a mitre; CGA splits the corner of two set-back edges the same
way). The remainder is the face minus all bands (manifold3d's CrossSection booleans, robust
for concave faces and holes), and each band clipped to the face, minus the bands of earlier
edges (where large distances make bands overlap), is that edge's setback face.

Edge selectors classify an edge by its outward normal in the face's scope: `front` / `back`
(closest to -y / +y; also called `bottom` / `top`, the names CGA uses on a facade), `left` /
`right` (-x / +x), `side` (left or right), `south` / `north` / `west` / `east` (the outward
normal's direction in the world: -y / +y / -x / +x, grammarkit's world being z-up with +y
north), `all`, an index (the edge's position: the outer contour's edges from its first
point, then the holes'), and `remainder` (what is left of the face). Each edge goes to the
first selector that takes it; the edges of every selector but `remainder` are set back, and
the remainder is the same wherever `remainder:` stands (as in CGA).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Callable


from ...registry import Param
from ..shape import FACE, Shape
from ..turned import naming_axes
from .helpers import fp, manifold3d, not_a_face, operation, piece

if TYPE_CHECKING:  # pragma: no cover
    from manifold3d import CrossSection

__all__ = ["SETBACK_SELECTORS", "SHAPE_SELECTORS", "op_inner_rectangle", "op_setback", "op_setback_per_edge",
           "op_setback_to_area", "edge_shape", "edge_side", "per_edge_value", "op_shape_l", "op_shape_o", "op_shape_u"]

EPS = 1e-9
SETBACK_SELECTORS = ("front", "back", "left", "right", "top", "bottom", "side", "south", "north", "west", "east",
                     "all", "remainder", "<index>")
SHAPE_SELECTORS = ("shape", "remainder")


# -- edges -------------------------------------------------------------------------------------
def edges(s: Shape) -> list[tuple[tuple, tuple]]:
    """The face's edges (start, end) in scope coordinates: the outer contour, then the holes."""
    out = []
    for ring in s.contours():
        n = len(ring)
        for i in range(n):
            out.append((tuple(ring[i]), tuple(ring[(i + 1) % n])))
    return out


def _outward(p: tuple, q: tuple) -> tuple[float, float]:
    # the material is on the left of every contour edge (outer CCW, holes CW): outward is right
    dx, dy = q[0] - p[0], q[1] - p[1]
    ln = math.hypot(dx, dy) or 1.0
    return dy / ln, -dx / ln


def edge_names(s: Shape, p: tuple, q: tuple) -> set[str]:
    """The selector names of edge p -> q of face `s`."""
    nx, ny = _outward(p, q)
    names = {"all"}
    ax, ay = s.ax[0], s.ax[1]
    w = [nx * ax[k] + ny * ay[k] for k in range(3)]  # the outward normal in the world
    turned = naming_axes()  # a face turned out of its scope's xy plane (grammarkit/split/turned.py)
    if turned is not None:  # classified in the turned scope's quadrants, as CGA's selectors
        nx, ny, nz = (sum(w[k] * a[k] for k in range(3)) for a in turned)
        if abs(nz) > abs(nx) and abs(nz) > abs(ny):
            return names | {"top" if nz > 0 else "bottom"} | _world_names(w)
    if abs(ny) >= abs(nx):
        names |= {"front", "bottom"} if ny < 0 else {"back", "top"}
    else:
        names |= {"side", "right" if nx > 0 else "left"}
    return names | _world_names(w)


def _world_names(w: list) -> set[str]:
    names = set()
    if abs(w[1]) >= abs(w[0]) and abs(w[1]) >= abs(w[2]):
        names.add("north" if w[1] > 0 else "south")
    elif abs(w[0]) >= abs(w[2]):
        names.add("east" if w[0] > 0 else "west")
    return names


def select_edges(s: Shape, block: Any) -> tuple[list[Any], list[tuple]]:
    """(the slot each edge goes to, or None), the edges: the first slot that selects it."""
    es = edges(s)
    chosen: list[Any] = [None] * len(es)
    n = len(es)
    for i, (p, q) in enumerate(es):
        names = edge_names(s, p, q)
        for slot in block:
            sel = slot.sel
            if sel == "remainder":
                continue
            if (sel % n == i) if type(sel) is int else sel in names:
                chosen[i] = slot
                break
    return chosen, es


# -- the geometry ------------------------------------------------------------------------------
def _meet(p: tuple, n1: tuple, d1: float, v: tuple, n2: tuple, d2: float) -> tuple[float, float] | None:
    """The point on both lines {x: (x - p)·n1 = d1} and {x: (x - v)·n2 = d2}, or None if parallel."""
    det = n1[0] * n2[1] - n1[1] * n2[0]
    if abs(det) < 1e-9:
        return None
    c1 = d1 + p[0] * n1[0] + p[1] * n1[1]
    c2 = d2 + v[0] * n2[0] + v[1] * n2[1]
    return ((c1 * n2[1] - c2 * n1[1]) / det, (n1[0] * c2 - n2[0] * c1) / det)


def setback_geometry(s: Shape, dist: list[float]) -> tuple[CrossSection, list[CrossSection | None]]:
    """(remainder, band of every edge or None) for per-edge distances `dist` (0: not set back)."""
    face = fp.cross_section(s.contours())
    bands: list[CrossSection | None] = []
    k = 0
    for ring in s.contours():
        n = len(ring)
        inward = [(-x, -y) for x, y in ((_outward(ring[i], ring[(i + 1) % n])) for i in range(n))]
        d = dist[k:k + n]
        # R at the start of edge i: where edge i-1's and edge i's offset lines meet
        starts, ends = [], []
        for i in range(n):
            a, b = (i - 1) % n, i
            v = ring[i]
            r = _meet(ring[a], inward[a], d[a], v, inward[b], d[b])
            if r is None or math.hypot(r[0] - v[0], r[1] - v[1]) > 50 * max(d[a], d[b], EPS):
                # (nearly) parallel neighbours: each band ends square at the vertex
                ends.append((v[0] + inward[a][0] * d[a], v[1] + inward[a][1] * d[a]))
                starts.append((v[0] + inward[b][0] * d[b], v[1] + inward[b][1] * d[b]))
            else:
                ends.append(r)
                starts.append(r)
        for i in range(n):
            if d[i] <= EPS:
                bands.append(None)
                continue
            p, q = ring[i], ring[(i + 1) % n]
            quad = [list(p), list(q), list(ends[(i + 1) % n]), list(starts[i])]
            band = manifold3d.CrossSection([quad], manifold3d.FillRule.NonZero) ^ face
            bands.append(None if band.is_empty() else band)
        k += n
    used = [b for b in bands if b is not None]
    remainder = face - manifold3d.CrossSection.batch_boolean(used, manifold3d.OpType.Add) if used else face
    # where bands overlap (distances larger than the face allows) an edge keeps what earlier
    # edges did not take
    taken: CrossSection | None = None
    for i, b in enumerate(bands):
        if b is None:
            continue
        own = b if taken is None else b - taken
        taken = b if taken is None else taken + b
        bands[i] = None if own.is_empty() or own.area() < 1e-9 else own
    return remainder, bands


def _edge_face(s: Shape, cs: CrossSection, p: tuple, q: tuple) -> Shape | None:
    """A setback face: x along its edge, y inwards, z the face normal (scope fitted to it)."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    ln = math.hypot(dx, dy)
    if ln < EPS:
        return None
    ux, uy = dx / ln, dy / ln
    contours = []
    for ring in cs.to_polygons():
        pts = tuple(((x - p[0]) * ux + (y - p[1]) * uy, -(x - p[0]) * uy + (y - p[1]) * ux) for x, y in ring.tolist())
        if abs(fp.area(pts)) > 1e-9:
            contours.append(pts)
    if not contours:
        return None
    x0 = min(x for c in contours for x, _ in c)
    y0 = min(y for c in contours for _, y in c)
    x1 = max(x for c in contours for x, _ in c)
    y1 = max(y for c in contours for _, y in c)
    poly = tuple(tuple((x - x0, y - y0) for x, y in c) for c in contours)
    ex, ey, ez = s.ax
    nx = tuple(ux * ex[k] + uy * ey[k] for k in range(3))
    ny = tuple(-uy * ex[k] + ux * ey[k] for k in range(3))
    ox, oy = p[0] + x0 * ux - y0 * uy, p[1] + x0 * uy + y0 * ux
    sx, sy = x1 - x0, y1 - y0
    rect = len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7)
    return s.derived(s.world(ox, oy, 0.0), (sx, sy, 0.0), None if rect else poly, FACE, ax=(nx, ny, ez))


def _fitted(s: Shape, cs: CrossSection) -> Shape | None:
    """A face from a CrossSection in `s`'s scope coordinates, keeping `s`'s axes."""
    return None if cs.is_empty() else piece(s, cs, FACE)


def _distance(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{what} must be a finite number, got {v!r}")
    if v < 0:
        raise ValueError(f"{what} must be >= 0, got {v:g}")
    return float(v)


def _face_only(s: Shape, op: str) -> None:
    if s.kind != FACE:
        raise ValueError(not_a_face(s, op))


def _setback(s: Shape, block: Any, dist_of: Callable[[int, tuple, tuple], float], op: str) -> list:
    _face_only(s, op)
    chosen, es = select_edges(s, block)
    dist = [dist_of(i, p, q) if chosen[i] is not None else 0.0 for i, (p, q) in enumerate(es)]
    remainder, bands = setback_geometry(s, dist)
    out = []
    n = len(es)
    for i, slot in enumerate(chosen):
        if slot is not None and bands[i] is not None:
            c = _edge_face(s, bands[i], *es[i])
            if c is not None:
                out.append((c, slot, i, n))
    rest = [slot for slot in block if slot.sel == "remainder"]
    if rest:
        pieces = [p for p in _pieces(remainder)]
        for j, part in enumerate(pieces):
            c = _fitted(s, part)
            if c is not None:
                out.append((c, rest[0], j, len(pieces)))
    return out


def _pieces(cs: CrossSection) -> list[CrossSection]:
    """The connected parts of a region (a setback can cut a face in two)."""
    return [p for p in cs.decompose() if p.area() > 1e-9] if not cs.is_empty() else []


@operation("setback", (Param("distance"),), block="selectors", selectors=SETBACK_SELECTORS,
           doc="Move the selected edges of a face inwards: a face per edge, and the remainder.")
def op_setback(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`setback(d) { front: A | remainder: B }`: the selected edges moved in by d."""
    d = _distance(args[0], "setback() distance")
    return _setback(s, block, lambda i, p, q: d, "setback")


SIDES = ("front", "back", "right", "left")


def edge_side(s: Shape, p: tuple, q: tuple) -> str:
    """The one side of front/back/right/left an edge belongs to (the selectors partition the
    edges: front/back where the outward normal is closer to -y/+y, else right/left)."""
    names = edge_names(s, p, q)
    return next(side for side in SIDES if side in names)


def edge_shape(s: Shape, i: int, p: tuple, q: tuple, n: int) -> Shape:
    """Edge i of n of face `s` as a shape of its own, for per-edge expressions: x along the
    edge (`scope.sx` its length), z the face's normal, `comp.index` / `comp.total` the edge's
    index and the number of edges, `comp.sel` its side (front, back, right or left)."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    ln = math.hypot(dx, dy)
    ux, uy = (dx / ln, dy / ln) if ln > EPS else (1.0, 0.0)
    ex, ey, ez = s.ax
    ax = (tuple(ux * ex[k] + uy * ey[k] for k in range(3)), tuple(-uy * ex[k] + ux * ey[k] for k in range(3)), ez)
    edge = s.derived(s.world(p[0], p[1], 0.0), (ln, 0.0, 0.0), None, FACE, ax=ax)
    edge.si, edge.st = i, n
    edge.csel = edge_side(s, p, q)
    return edge


def per_edge_value(f: Callable, s: Shape, i: int, p: tuple, q: tuple, n: int, what: str) -> Any:
    """An `expr` argument evaluated for edge i on the edge's shape (`edge_shape`). A value that
    is an array (a tuple: `(1, 2, 3)`, CGA's float[]) gives one value per edge in face-edge
    order (`edges`): the edge's element is taken."""
    v = f(edge_shape(s, i, p, q, n))
    if isinstance(v, (tuple, list)):
        if len(v) != n:
            raise ValueError(f"{what}: an array of {len(v)} value(s) for a face of {n} edges "
                             "(one value per edge, in face-edge order)")
        v = v[i]
    return v


@operation("setbackPerEdge", (Param("distance", "expr"),), block="selectors", selectors=SETBACK_SELECTORS,
           doc="setback() with the distance evaluated on every edge (comp.index: the edge's index, "
               "comp.sel: its side), or an array of one distance per edge.")
def op_setback_per_edge(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`setbackPerEdge(expr) { ... }`: the distance evaluated for every edge on the edge itself
    (`edge_shape`: `scope.sx` is its length, `comp.index` its index, `comp.sel` its side), or
    taken from an array of one distance per edge."""
    f = args[0]
    n = len(edges(s))

    def dist(i: int, p: tuple, q: tuple) -> float:
        return _distance(per_edge_value(f, s, i, p, q, n, "setbackPerEdge() distance"),
                         f"setbackPerEdge() distance of edge {i}")
    return _setback(s, block, dist, "setbackPerEdge")


@operation("setbackToArea", (Param("area"),), block="selectors", selectors=SETBACK_SELECTORS,
           doc="setback() with the distance that leaves a remainder of the given area.")
def op_setback_to_area(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`setbackToArea(area) { ... }`: the selected edges moved in by one distance such that the
    remainder has the given area (bisection)."""
    target = _distance(args[0], "setbackToArea() area")
    _face_only(s, "setbackToArea")
    chosen, es = select_edges(s, block)
    face_area = fp.cross_section(s.contours()).area()
    if target >= face_area or not any(c is not None for c in chosen):
        d = 0.0
    else:
        lo, hi = 0.0, max(s.sz[0], s.sz[1])
        for _ in range(50):  # the remainder's area falls monotonically with the distance
            mid = 0.5 * (lo + hi)
            rem, _b = setback_geometry(s, [mid if c is not None else 0.0 for c in chosen])
            lo, hi = (mid, hi) if rem.area() > target else (lo, mid)
        d = 0.5 * (lo + hi)
    return _setback(s, block, lambda i, p, q: d, "setbackToArea")


# -- shapeL / shapeU / shapeO ------------------------------------------------------------------
def _shape_op(name: str, sides: tuple[str, ...]):
    def op(ctx: Any, s: Shape, args: Any, block: Any) -> list:
        widths = {side: _distance(v, f"{name}() {side} width") for side, v in zip(sides, args)}
        _face_only(s, name)
        es = edges(s)
        dist = []
        for p, q in es:
            names = edge_names(s, p, q)
            dist.append(next((widths[side] for side in sides if side in names), 0.0))
        remainder, bands = setback_geometry(s, dist)
        used = [b for b in bands if b is not None]
        wing = manifold3d.CrossSection.batch_boolean(used, manifold3d.OpType.Add) if used else manifold3d.CrossSection()
        out = []
        for slot in block:
            if slot.sel == "shape":
                pieces = _pieces(wing)
            elif slot.sel == "remainder":
                pieces = _pieces(remainder)
            else:
                continue
            for j, part in enumerate(pieces):
                c = _fitted(s, part)
                if c is not None:
                    out.append((c, slot, j, len(pieces)))
        return out
    op.__name__ = f"op_{name}"
    op.__doc__ = (f"`{name}({', '.join(w + '_width' for w in sides)}) {{ shape: A | remainder: B }}`: "
                  f"a setback of the {', '.join(sides)} edges; `shape` is the wings as one face.")
    return op


op_shape_l = operation("shapeL", (Param("front_width"), Param("left_width")), block="selectors",
           selectors=("shape", "remainder"), doc="An L-shaped footprint: front and left wings.")(_shape_op("shapeL", ("front", "left")))
op_shape_u = operation("shapeU", (Param("front_width"), Param("right_width"), Param("left_width")), block="selectors",
           selectors=("shape", "remainder"), doc="A U-shaped footprint: front, right and left wings.")(_shape_op("shapeU", ("front", "right", "left")))
op_shape_o = operation("shapeO", (Param("front_width"), Param("right_width"), Param("back_width"), Param("left_width")),
           block="selectors", selectors=("shape", "remainder"),
           doc="An O-shaped footprint: wings along all four sides around a court.")(_shape_op("shapeO", ("front", "right", "back", "left")))


# -- innerRectangle ----------------------------------------------------------------------------
#: innerRectangle's candidate rectangles from numpy arrays instead of Python loops over up to
#: 39^4 / 4 of them (the same candidates in the same order, so the same rectangle); False
#: restores the loops (benchmarks/bench_prt.py --prior).
NUMPY_INNER_RECTANGLE = True


def largest_rectangle(contours: tuple, c: float, sn: float) -> tuple[float, float, float, float] | None:
    """The largest rectangle inside the region, with sides along (c, sn) and (-sn, c): (x0, y0,
    x1, y1) in that turned frame. Exact over the candidate coordinates of the region's vertices
    (the optimum of a polygon's largest inscribed rectangle touches vertices or edges; this
    search takes vertex coordinates, exact for rectilinear faces, plus a grid), each candidate
    checked by containment (manifold3d), largest first."""
    pts = [(x * c + y * sn, -x * sn + y * c) for ring in contours for x, y in ring]
    turned = fp.cross_section(tuple(tuple((x * c + y * sn, -x * sn + y * c) for x, y in ring)
                                    for ring in contours))
    xs = sorted({round(p[0], 9) for p in pts})
    ys = sorted({round(p[1], 9) for p in pts})
    if len(xs) > 24 or len(ys) > 24:  # bound the O(n^4) search: keep evenly spaced candidates
        xs = sorted({xs[round(k * (len(xs) - 1) / 23)] for k in range(24)})
        ys = sorted({ys[round(k * (len(ys) - 1) / 23)] for k in range(24)})
    # a slanted edge's optimum touches it between vertices: a grid of 16 steps adds candidates
    # (so the result is within a grid step of the optimum for non-rectilinear faces)
    xs = sorted(set(xs) | {xs[0] + (xs[-1] - xs[0]) * k / 16 for k in range(1, 16)})
    ys = sorted(set(ys) | {ys[0] + (ys[-1] - ys[0]) * k / 16 for k in range(1, 16)})
    total = turned.area() * (1 + 1e-6)
    rings = [tuple((x * c + y * sn, -x * sn + y * c) for x, y in ring) for ring in contours]
    inside = {(x, y): _inside(x, y, rings) for x in xs for y in ys}  # corners must be in the face
    order = _candidates_numpy(xs, ys, total, inside) if NUMPY_INNER_RECTANGLE else _candidates(xs, ys, total, inside)
    for a, x0, y0, x1, y1 in order:
        rect = manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))
        if (rect - turned).area() < 1e-7 * max(a, 1.0):
            return (x0, y0, x1, y1)
    return None


def _candidates(xs: list, ys: list, total: float, inside: dict) -> Any:
    """The rectangles over the candidate coordinates whose corners are in the face, largest
    first (ties: by the corners' coordinates, descending), as Python loops."""
    cand = []
    for i, x0 in enumerate(xs):
        for x1 in xs[i + 1:]:
            for j, y0 in enumerate(ys):
                for y1 in ys[j + 1:]:
                    a = (x1 - x0) * (y1 - y0)
                    if a > 1e-9 and a <= total:
                        cand.append((a, x0, y0, x1, y1))
    cand.sort(reverse=True)
    for a, x0, y0, x1, y1 in cand:
        if inside[(x0, y0)] and inside[(x1, y0)] and inside[(x0, y1)] and inside[(x1, y1)]:
            yield a, x0, y0, x1, y1


def _candidates_numpy(xs: list, ys: list, total: float, inside: dict) -> Any:
    """_candidates' rectangles in its order, from arrays (up to 39^4 / 4 candidates: the loops
    took most of a second per face)."""
    import numpy as np

    X, Y = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
    i0, i1 = np.triu_indices(len(X), 1)
    j0, j1 = np.triu_indices(len(Y), 1)
    inn = np.array([[inside[(x, y)] for y in ys] for x in xs], dtype=bool).reshape(len(X), len(Y))
    xi = np.repeat(np.arange(len(i0)), len(j0))
    yj = np.tile(np.arange(len(j0)), len(i0))
    a0, a1, b0, b1 = i0[xi], i1[xi], j0[yj], j1[yj]
    area = (X[a1] - X[a0]) * (Y[b1] - Y[b0])
    keep = (area > 1e-9) & (area <= total) & inn[a0, b0] & inn[a1, b0] & inn[a0, b1] & inn[a1, b1]
    a0, a1, b0, b1, area = a0[keep], a1[keep], b0[keep], b1[keep], area[keep]
    # descending by (area, x0, y0, x1, y1), as the tuples' reverse sort
    order = np.lexsort((-Y[b1], -X[a1], -Y[b0], -X[a0], -area))
    for k in order.tolist():
        yield float(area[k]), xs[a0[k]], ys[b0[k]], xs[a1[k]], ys[b1[k]]


def _inside(x: float, y: float, rings: list) -> bool:
    """Whether (x, y) is in the region or on its boundary (within 1e-7)."""
    odd = False
    for ring in rings:
        n = len(ring)
        for i in range(n):
            (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
            dx, dy = x1 - x0, y1 - y0
            ln2 = dx * dx + dy * dy
            t = ((x - x0) * dx + (y - y0) * dy) / ln2 if ln2 > 0 else 0.0
            t = min(1.0, max(0.0, t))
            if (x0 + t * dx - x) ** 2 + (y0 + t * dy - y) ** 2 < 1e-14:
                return True  # on the boundary
            if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * dx / dy:
                odd = not odd
    return odd


@operation("innerRectangle", (Param("align", "axis", required=False, default="scope",
                                    choices=("scope", "edge")),),
           block="selectors", selectors=("shape", "remainder"),
           doc="The largest rectangle in a face (aligned to the scope or to an edge), and the rest.")
def op_inner_rectangle(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`innerRectangle(scope | edge) { shape: A | remainder: B }`: the largest rectangle in the
    face, aligned to the scope (or, `edge`, to whichever edge gives the largest one)."""
    mode = str(args[0])
    _face_only(s, "innerRectangle")
    contours = s.contours()
    dirs = [(1.0, 0.0)]
    if mode == "edge":
        dirs = []
        seen = set()
        for p, q in edges(s):
            ln = math.hypot(q[0] - p[0], q[1] - p[1])
            # a rectangle along an edge is one along any edge at a multiple of 90 degrees to it
            turn = round(math.degrees(math.atan2(q[1] - p[1], q[0] - p[0])) % 90.0, 6) % 90.0
            if ln > EPS and turn not in seen:
                seen.add(turn)
                dirs.append(((q[0] - p[0]) / ln, (q[1] - p[1]) / ln))
    best = None
    for c, sn in dirs:
        r = largest_rectangle(contours, c, sn)
        if r is not None and (best is None or (r[2] - r[0]) * (r[3] - r[1]) > best[0]):
            best = ((r[2] - r[0]) * (r[3] - r[1]), r, c, sn)
    out = []
    if best is None:
        return out
    _a, (x0, y0, x1, y1), c, sn = best
    ex, ey, ez = s.ax
    nx = tuple(c * ex[k] + sn * ey[k] for k in range(3))
    ny = tuple(-sn * ex[k] + c * ey[k] for k in range(3))
    ox, oy = x0 * c - y0 * sn, x0 * sn + y0 * c  # back to scope coordinates
    for slot in block:
        if slot.sel == "shape":
            out.append((s.derived(s.world(ox, oy, 0.0), (x1 - x0, y1 - y0, 0.0), None, FACE, ax=(nx, ny, ez)),
                        slot, 0, 1))
        elif slot.sel == "remainder":
            rect = manifold3d.CrossSection([[[ox, oy], [ox + (x1 - x0) * c, oy + (x1 - x0) * sn],
                                  [ox + (x1 - x0) * c - (y1 - y0) * sn, oy + (x1 - x0) * sn + (y1 - y0) * c],
                                  [ox - (y1 - y0) * sn, oy + (y1 - y0) * c]]], manifold3d.FillRule.NonZero)
            rest = fp.cross_section(contours) - rect
            pieces = _pieces(rest)
            for j, part in enumerate(pieces):
                f = _fitted(s, part)
                if f is not None:
                    out.append((f, slot, j, len(pieces)))
    return out
