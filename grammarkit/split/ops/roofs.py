"""The roof operations: roofGable, roofHip, roofPyramid, roofShed, roofMansard."""
from __future__ import annotations

import math
from typing import Any

from ...registry import Param
from ..shape import VOLUME, Shape
from .helpers import EPS, face_only, fp, lazy_module, manifold3d, number, operation

roofs = lazy_module("grammarkit.geometry.roofs")


def _roof(s: Shape, build: Any, name: str) -> Shape:
    face_only(s, name)
    if s.sz[0] <= EPS or s.sz[1] <= EPS:
        raise ValueError(f"{name}() on an empty face")
    polys = [p for p in s.contours() if fp.area(p) > 0]
    solids = [build(p) for p in polys]
    solid = solids[0] if len(solids) == 1 else manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    if not all(math.isfinite(v) for v in (x0, y0, z0, x1, y1, z1)) or z1 - z0 <= EPS:
        raise ValueError(f"{name}() produced an empty roof")
    solid = solid.translate((-x0, -y0, -z0))
    return s.derived(s.world(x0, y0, z0), (x1 - x0, y1 - y0, z1 - z0), None, VOLUME, solid=solid)


def _flag(v: Any, what: str) -> bool:
    if not isinstance(v, bool):
        raise ValueError(f"{what} must be true or false, got {v!r}")
    return v


def _ridge(v: Any, auto: bool = False) -> str:
    v = str(v)
    if v not in (("x", "y", "auto") if auto else ("x", "y")):
        raise ValueError(f"ridge must be x{', y or auto' if auto else ' or y'}, got {v!r}")
    return v


def _index(v: Any) -> int | None:
    """An edge index argument: None (not given) or an integer (CGA's float index, floored;
    taken modulo the number of edges by the roof)."""
    if v is None:
        return None
    return int(math.floor(number(v, "edge index")))


def _value_type(v: Any) -> str:
    v = str(v)
    if v not in ("byAngle", "byHeight"):
        raise ValueError(f"value_type must be byAngle or byHeight, got {v!r}")
    return v


def _pitch(value: float, value_type: str, build: Any, p: Any) -> float:
    """The roof angle: `value` itself (byAngle), or (byHeight) the angle whose roof over `p`
    is `value` high. Every roof here is linear in tan(angle) (height = tan(angle) x the
    horizontal run from the eave to the top), so the run is measured on the 45-degree roof."""
    if value_type == "byAngle":
        return value
    if value <= 0:
        raise ValueError(f"roof height must be > 0, got {value:g}")
    x0, y0, z0, x1, y1, z1 = build(p, 45.0).bounding_box()
    run = z1 - z0
    if not math.isfinite(run) or run <= EPS:
        raise ValueError("the footprint is too small for a roof")
    angle = math.degrees(math.atan(value / run))
    if angle > 89.0:
        raise ValueError(f"a roof {value:g} high over a run of {run:g} is steeper than 89 degrees")
    return angle


@operation("roofGable", (Param("angle", doc="the roof planes' angle (degrees), or their height with value_type=byHeight"),
                         Param("overhang", required=False, default=0.0,
                               doc="at the eaves, across the ridge (CGA's overhangX)"),
                         Param("ridge", "axis", required=False, default="x", choices=("x", "y", "auto"),
                               doc="the scope axis the ridge runs along, or auto: along the longest "
                                   "edge (CGA's automatic orientation on rectangles)"),
                         Param("overhang_y", required=False, default=None,
                               doc="at the gable ends, along the ridge (CGA's overhangY; may be "
                                   "negative); not given: the overhang all round"),
                         Param("index", required=False, default=None,
                               doc="the ridge runs along this edge of the face (CGA's index)"),
                         Param("value_type", "axis", required=False, default="byAngle",
                               choices=("byAngle", "byHeight")),
                         Param("even", "any", required=False, default=False,
                               doc="CGA's even: planes from every eave edge, the ridge level "
                                   "(non-planar faces where the eaves are not parallel)")),
           doc="Gable roof over a footprint face; ridge along the given scope axis or edge index.")
def op_roof_gable(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, ridge = number(args[0], "angle"), number(args[1], "overhang"), _ridge(args[2], auto=True)
    over_y = None if args[3] is None else number(args[3], "overhang_y")
    index, vt = _index(args[4]), _value_type(args[5])
    even = _flag(args[6], "even")

    def build(p: Any, angle: float) -> Any:
        return roofs.gable(p, angle, over, ridge, overhang_y=over_y, index=index, even=even)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofGable")


@operation("roofHip", (Param("angle", doc="degrees, or the height with value_type=byHeight"),
                       Param("overhang", required=False, default=0.0),
                       Param("value_type", "axis", required=False, default="byAngle",
                             choices=("byAngle", "byHeight")),
                       Param("even", "any", required=False, default=False,
                             doc="CGA's even: the ridge level at the skeleton nodes' average "
                                 "height (non-planar faces)")),
           doc="Hip roof: every edge slopes at the angle (or up to the height).")
def op_roof_hip(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, vt = number(args[0], "angle"), number(args[1], "overhang"), _value_type(args[2])
    even = _flag(args[3], "even")

    def build(p: Any, angle: float) -> Any:
        return roofs.hip(p, angle, over, even)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofHip")


@operation("roofPyramid", (Param("angle"), Param("overhang", required=False, default=0.0)),
           doc="Pyramid roof with its apex over the face centroid.")
def op_roof_pyramid(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    angle, over = number(args[0], "angle"), number(args[1], "overhang")
    return _roof(s, lambda p: roofs.pyramid(p, angle, over), "roofPyramid")


@operation("roofShed", (Param("angle", doc="degrees, or the height with value_type=byHeight"),
                        Param("overhang", required=False, default=0.0),
                        Param("ridge", "axis", required=False, default="x", choices=("x", "y")),
                        Param("index", required=False, default=None,
                              doc="the roof rises from this edge of the face (CGA's index)"),
                        Param("value_type", "axis", required=False, default="byAngle",
                              choices=("byAngle", "byHeight"))),
           doc="Shed (mono-pitch) roof rising towards +ridge-normal, or from edge `index`.")
def op_roof_shed(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, ridge = number(args[0], "angle"), number(args[1], "overhang"), _ridge(args[2])
    index, vt = _index(args[3]), _value_type(args[4])

    def build(p: Any, angle: float) -> Any:
        return roofs.shed(p, angle, over, ridge, index=index)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofShed")


@operation("roofMansard", (Param("angle"), Param("height"),
                           Param("top_angle", required=False, default=15.0),
                           Param("overhang", required=False, default=0.0)),
           doc="Mansard roof: steep hip sides up to `height`, then a shallow hip on top.")
def op_roof_mansard(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    angle, height = number(args[0], "angle"), number(args[1], "height")
    top, over = number(args[2], "top_angle"), number(args[3], "overhang")
    return _roof(s, lambda p: roofs.mansard(p, angle, height, top, over), "roofMansard")
