"""CGA's `envelope(direction, maxHeight, baseHeight, angle, ...)`: the building envelope of a
lot, i.e. the largest volume zoning allows (docs/operations.md, "envelope").

The face is extruded to `maxHeight` along its normal (CGA: sealed horizontally there); then,
for every edge, the side rises vertically up to the edge's base height and from there leans
inwards at the edge's slope angle (degrees from the horizontal; 90: the side stays vertical;
0: the envelope is cut flat at the base height). Each slanted side is a half-space, and the
envelope is the extrusion intersected with them (manifold3d's `trim_by_plane`, through
`grammarkit.geometry.roofs.keep_below_plane`): a closed, watertight solid for any footprint,
convex or not, with holes.

Which base height and angle an edge gets: `envelope` takes them per side, as CGA does —
front, back, right, left (an edge is classified by its outward normal in the face's scope,
like setback's selectors: CGA's street.front/back/left/right fall back to these when the lot
has no street attributes, as grammarkit lots never do); sides not given keep base height 0
and angle 90 (vertical), as in CGA. `envelopePerEdge` takes them per edge instead (CGA's
`envelope(direction, maxHeight, baseHeights, angles)`): two expressions the split compiler
hands over unevaluated (`expr` parameters), evaluated on every edge's own shape
(`grammarkit.split.lots.edge_shape`: `comp.index`, `comp.sel` the edge's side, `scope.sx`
its length), or arrays of one value per edge in face-edge order.
"""
from __future__ import annotations

import math
from typing import Any, Callable


from .lots import SIDES, edge_side, edges, per_edge_value
from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import fp, lazy_module, manifold3d, operation

geometry_roofs = lazy_module("grammarkit.geometry.roofs")

__all__ = ["envelope_solid", "op_envelope", "op_envelope_per_edge"]

EPS = 1e-9
# Base heights below this are raised to it: a slanted side that starts at the ground edge
# meets the bottom in a knife edge, which comes out of the booleans with pinched vertices
# (the same reason roofs end in grammarkit.geometry.roofs.FASCIA).
MIN_BASE = 0.02


def _number(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{what} must be a finite number, got {v!r}")
    return float(v)


def _check(base: float, angle: float, where: str) -> tuple[float, float]:
    if base < 0:
        raise ValueError(f"envelope base height of {where} must be >= 0, got {base:g}")
    if not 0 <= angle <= 90:
        raise ValueError(f"envelope angle of {where} must be in [0, 90] degrees, got {angle:g}")
    return base, angle


def envelope_solid(contours: tuple, max_height: float, sides: list[tuple[float, float]]) -> manifold3d.Manifold:
    """The envelope over a face (contours in its plane, z along its normal): `sides` gives
    (base height, angle) for every edge, outer contour first, then the holes."""
    solid = manifold3d.Manifold.extrude(fp.cross_section(contours), max_height)
    k = 0
    for ring in contours:
        n = len(ring)
        for i in range(n):
            base, angle = sides[k]
            k += 1
            if angle >= 90 - 1e-9 or base >= max_height:
                continue  # a vertical side: the extrusion's own wall
            (ax, ay), (bx, by) = ring[i], ring[(i + 1) % n]
            ln = math.hypot(bx - ax, by - ay)
            if ln < EPS:
                continue
            nx, ny = -(by - ay) / ln, (bx - ax) / ln  # inward: the face lies left of its edges
            solid = geometry_roofs.keep_below_plane(solid, nx, ny, nx * ax + ny * ay, math.tan(math.radians(angle)),
                                     max(base, MIN_BASE))
    return solid.simplify(1e-6)


def _envelope(s: Shape, direction: Any, max_height: Any, side_of: Callable[[int, tuple, tuple], tuple]) -> Shape:
    d = str(direction)
    if d not in ("normal", "worldUp"):
        raise ValueError(f"envelope direction must be normal or worldUp, got {d!r}")
    if s.kind != FACE:
        raise ValueError("envelope() needs a face (a lot, or a face from comp(f)), got a volume")
    if d == "worldUp" and s.ax[2][2] < 1 - 1e-6:
        raise ValueError("envelope(worldUp, ...) on a face that is not horizontal (its normal is not "
                         "the world's up) is not supported; use normal")
    h = _number(max_height, "envelope max height")
    if h <= 0:
        raise ValueError(f"envelope max height must be > 0, got {h:g}")
    sides = [side_of(i, p, q) for i, (p, q) in enumerate(edges(s))]
    solid = envelope_solid(s.contours(), h, sides)
    if solid.is_empty() or solid.volume() <= EPS:
        raise ValueError("envelope() left no volume (the base heights and angles cut everything away)")
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    return s.derived(s.world(x0, y0, z0), (x1 - x0, y1 - y0, z1 - z0), None, VOLUME,
                     solid=solid.translate((-x0, -y0, -z0)))


@operation("envelope", (Param("direction", "axis", choices=("normal", "worldUp")), Param("max_height"),
                        Param("front_base"), Param("front_angle"),
                        Param("back_base", required=False, default=0.0),
                        Param("back_angle", required=False, default=90.0),
                        Param("right_base", required=False, default=0.0),
                        Param("right_angle", required=False, default=90.0),
                        Param("left_base", required=False, default=0.0),
                        Param("left_angle", required=False, default=90.0)),
           doc="The zoning envelope of a face: extruded to max_height, each side vertical up to "
               "its base height, then leaning inwards at its angle (degrees; 90: vertical).")
def op_envelope(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`envelope(direction, max_height, front_base, front_angle, back_base, back_angle,
    right_base, right_angle, left_base, left_angle)`."""
    given = {}
    for j, side in enumerate(SIDES):
        base, angle = args[2 + 2 * j], args[3 + 2 * j]
        given[side] = _check(_number(base, f"envelope {side} base height"),
                             _number(angle, f"envelope {side} angle"), f"the {side} edges")

    def side_of(i: int, p: tuple, q: tuple) -> tuple[float, float]:
        return given[edge_side(s, p, q)]
    return _envelope(s, args[0], args[1], side_of)


@operation("envelopePerEdge", (Param("direction", "axis", choices=("normal", "worldUp")), Param("max_height"),
                               Param("base_height", "expr",
                                     doc="evaluated on every edge (comp.index, comp.sel, scope.sx), "
                                         "or an array of one value per edge"),
                               Param("angle", "expr", doc="likewise, degrees (90: vertical)")),
           doc="envelope() with the base height and angle given per edge (CGA's "
               "envelope(direction, maxHeight, baseHeights, angles)).")
def op_envelope_per_edge(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`envelopePerEdge(direction, max_height, base_height, angle)`: the base height and angle
    evaluated for every edge (or taken from arrays of one value per edge)."""
    base_of, angle_of = args[2], args[3]
    n = len(edges(s)) if s.kind == FACE else 0

    def side_of(i: int, p: tuple, q: tuple) -> tuple[float, float]:
        base = per_edge_value(base_of, s, i, p, q, n, "envelopePerEdge() base height")
        angle = per_edge_value(angle_of, s, i, p, q, n, "envelopePerEdge() angle")
        return _check(_number(base, f"envelopePerEdge() base height of edge {i}"),
                      _number(angle, f"envelopePerEdge() angle of edge {i}"), f"edge {i}")
    return _envelope(s, args[0], args[1], side_of)
