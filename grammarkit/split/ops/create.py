"""Operations that make geometry: footprint, extrude, taper, recess."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import face_only, fp, manifold3d, number, operation, rect_or_poly, lazy_module

geometry_solids = lazy_module("grammarkit.geometry.solids")


@operation("footprint", (Param("shape", "any", doc="rect(w, d), lshape(...), polygon(...)"),),
           doc="Replace the scope's geometry by a planar footprint polygon (xy plane).")
def op_footprint(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    shape = args[0]
    if not isinstance(shape, (tuple, list)) or not shape:
        raise ValueError("footprint() needs a polygon such as rect(20, 12) or polygon(0, 0, 8, 0, 8, 6)")
    poly = fp.validate_polygon(shape)
    norm, (x0, y0, x1, y1) = fp.normalize(poly)
    sx, sy = x1 - x0, y1 - y0
    o = s.world(x0, y0, 0.0)
    return s.derived(o, (sx, sy, 0.0), rect_or_poly((norm,), sx, sy), FACE)


@operation("extrude", (Param("height"),), doc="Extrude a face along its normal into a volume.")
def op_extrude(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    h = number(args[0], "extrude height")
    face_only(s, "extrude")
    if h < 0:
        # CGA extrudes against the normal: the volume lies below the face, [h, 0] along z
        z = s.ax[2]
        o = (s.o[0] + z[0] * h, s.o[1] + z[1] * h, s.o[2] + z[2] * h)
        return s.derived(o, (s.sz[0], s.sz[1], -h), s.poly, VOLUME)
    # extrude(0) makes a volume without thickness (comp(f) gives its faces; as a terminal it
    # is left out of the solid with a warning)
    return s.derived(s.o, (s.sz[0], s.sz[1], h), s.poly, VOLUME)


@operation("taper", (Param("height"), Param("top_scale", required=False, default=0.0)),
           doc="Extrude a face, scaling the top about the centroid (0: to a point).")
def op_taper(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    h = number(args[0], "taper height")
    k = number(args[1], "taper top_scale")
    face_only(s, "taper")
    if h <= 0 or k < 0:
        raise ValueError(f"taper needs height > 0 and top_scale >= 0, got {h:g}, {k:g}")
    polys = s.contours()
    solids = [geometry_solids.taper(p, h, k) for p in polys if fp.area(p) > 0]
    solid = solids[0] if len(solids) == 1 else manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
    return s.derived(s.o, (s.sz[0], s.sz[1], h), None, VOLUME, solid=solid)


@operation("recess", (Param("depth"),),
           doc="Cut the face `depth` into the solid below it (windows, doors); the face "
               "moves to the bottom of the recess.")
def op_recess(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    d = number(args[0], "recess depth")
    face_only(s, "recess")
    if d <= 0:
        raise ValueError(f"recess depth must be > 0, got {d:g}")
    return ctx.recess(s, d)
