"""Operations that make geometry: footprint, extrude, taper, recess."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import EPS, face_only, fp, lazy_module, manifold3d, number, operation, rect_or_poly

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


@operation("extrude", (Param("height"),),
           doc="Extrude a face along its normal into a volume; on a volume, every face along its own "
               "normal (CGA).")
def op_extrude(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    h = number(args[0], "extrude height")
    if s.kind != FACE:
        return extrude_faces(s, h)
    if h < 0:
        # CGA extrudes against the normal: the volume lies below the face, [h, 0] along z
        z = s.ax[2]
        o = (s.o[0] + z[0] * h, s.o[1] + z[1] * h, s.o[2] + z[2] * h)
        v = s.derived(o, (s.sz[0], s.sz[1], -h), s.poly, VOLUME)
        # it lies inside the solid its face is a view of (if any): comp(f) of it is an opening
        # cut into that solid in the default mode (the engine's `_keep_comp_volume`)
        v.on = s.on
        return v
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


def _face_to_scope(f: Shape, s: Shape) -> list[list[float]]:
    """The affine map (3 x 4 rows) from face `f`'s scope coordinates to `s`'s."""
    A = s.ax
    d = [f.o[k] - s.o[k] for k in range(3)]
    return [[sum(A[r][k] * f.ax[i][k] for k in range(3)) for i in range(3)]
            + [sum(A[r][k] * d[k] for k in range(3))] for r in range(3)]


def extrude_faces(s: Shape, h: float) -> Shape | None:
    """CGA's extrude on a volume: every face (comp(f)'s faces) extruded along its own normal
    (h < 0: into the volume), the prisms together the shape's new geometry (the volume itself
    is not kept). Each face is grown by WELD in its plane before it is extruded, so the prisms of
    neighbouring faces, which would meet along an edge only, overlap and unite into one solid."""
    from ..engine import WELD
    from .faces import faces_of

    prisms = []
    for _, f in faces_of(s):
        if f.sz[0] <= EPS or f.sz[1] <= EPS or abs(h) <= EPS:
            continue
        section = fp.cross_section(f.contours()).offset(WELD, manifold3d.JoinType.Miter, 2.0)
        prism = manifold3d.Manifold.extrude(section, abs(h))
        if h < 0:
            prism = prism.translate((0.0, 0.0, h))
        prisms.append(prism.transform(_face_to_scope(f, s)))
    if not prisms:
        raise ValueError(f"extrude({h:g}) on a volume without faces of any size")
    solid = prisms[0] if len(prisms) == 1 else manifold3d.Manifold.batch_boolean(prisms, manifold3d.OpType.Add)
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    solid = solid.translate((-x0, -y0, -z0))
    return s.derived(s.world(x0, y0, z0), (x1 - x0, y1 - y0, z1 - z0), None, VOLUME, solid=solid)
