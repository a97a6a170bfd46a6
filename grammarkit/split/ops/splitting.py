"""split, repeat (split's pattern sugar) and offset."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import AXES, EPS, axis_index, fp, lazy_module, manifold3d, number, operation, piece
from .layout import layout, split_geometry

np = lazy_module("numpy")
surfaces = lazy_module("grammarkit.geometry.surfaces")


@operation("split", (Param("axis", "axis", choices=AXES),), block="sizes",
           doc="Split the scope along an axis into absolute, relative and floating parts.")
def op_split(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    a = axis_index(args[0])
    length = s.sz[a]
    if length <= EPS:
        if a == 2 and s.kind == FACE:
            raise ValueError(f"split({args[0]}) on a face: faces are flat, split them along x or y")
        # a degenerate shape (the side of a volume extruded 0 high, a sliver face): as in CGA,
        # every part lies outside its empty extent, so there are none
        ctx.warn(f"split({args[0]}) in rule {s.rule_name!r} on a shape of size 0 along {args[0]}: "
                 "no parts (as in CGA)")
        return []
    if getattr(block, "fixed", False):
        # sizes read only attrs/consts: the layout depends on the length alone (floors of a facade)
        key = ("split-layout", id(block), length)
        parts = ctx.cache.get(key)
        if parts is None:
            parts = ctx.cache[key] = layout(ctx, s, block, length)
    else:
        parts = layout(ctx, s, block, length)
    out = []
    for slot, start, size in parts:
        c = split_geometry(s, a, start, size)
        if c is not None:
            out.append((c, slot))
    return out


@operation("repeat", (Param("axis", "axis", choices=AXES), Param("size"),
                      Param("separator", required=False, default=0.0)),
           doc="Repetition sugar: `repeat(x, 2) (A)*` or `repeat(x, 2, 0.3) (A B)* A`.")
def op_repeat(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`repeat(axis, size, separator) (A B)* C`: the compiler turns the pattern into split slots."""
    if number(args[1], "repeat size") <= 0:
        raise ValueError(f"repeat size must be > 0, got {args[1]!r}")
    if number(args[2], "repeat separator") < 0:
        raise ValueError(f"repeat separator must be >= 0, got {args[2]!r}")
    return op_split(ctx, s, (args[0],), block)


def offset_face(s: Shape, d: float, want_border: bool) -> tuple[Shape | None, list[Shape]]:
    """A face offset by `d` (negative: inset): the face inside, and the border ring when asked."""
    sx, sy = s.sz[0], s.sz[1]
    inside: Shape | None
    border: list[Shape] = []
    if s.poly is None and d <= 0:
        e = -d
        w, h = sx - 2 * e, sy - 2 * e
        inside = s.derived(s.world(e, e, 0.0), (w, h, 0.0), None) if w > EPS and h > EPS else None
        if want_border and e > EPS:
            if inside is None:
                border = [s.copy()]
            else:
                # one ring face (outer contour + clockwise hole): extruding it makes one solid
                ring = (((0.0, 0.0), (sx, 0.0), (sx, sy), (0.0, sy)),
                        ((e, e), (e, sy - e), (sx - e, sy - e), (sx - e, e)))
                border = [s.derived(s.o, (sx, sy, 0.0), ring)]
    else:
        whole = fp.cross_section(s.contours())
        grown = whole.offset(d, manifold3d.JoinType.Miter, 2.0)
        inside = None if grown.is_empty() else piece(s, grown, FACE)
        if want_border and abs(d) > EPS:
            ring = (whole - grown) if d < 0 else (grown - whole)
            ring_face = None if ring.is_empty() else piece(s, ring, FACE)
            if ring_face is not None:
                border = [ring_face]
    return inside, border


@operation("offset", (Param("distance"),), block="optional-selectors",
           selectors=("inside", "border"),
           doc="Inset (negative) a face; inside/border parts. On a volume, every face in its own plane (CGA).")
def op_offset(ctx: Any, s: Shape, args: Any, block: Any) -> Any:
    d = number(args[0], "offset distance")
    if s.kind == FACE:
        inside, border = offset_face(s, d, block is not None)
    else:
        inside, border = _offset_faces(s, d, block is not None)
    if block is None:
        return inside
    out = []
    for slot in block:
        if slot.sel == "inside" and inside is not None:
            out.append((inside, slot))
        elif slot.sel == "border":
            out.extend((b.copy() if i else b, slot) for i, b in enumerate(border))
    return out


def _offset_faces(s: Shape, d: float, want_border: bool) -> tuple[Shape | None, list[Shape]]:
    """CGA's offset on a volume: every face (comp(f)'s faces) offset in its own plane. The
    insides together (and the borders together) are the new geometry, an open mesh in the
    shape's scope (a surface part, as an open inserted asset is; comp(f) and extrude take its
    faces one by one)."""
    from .faces import faces_of

    insides, borders = [], []
    for _, f in faces_of(s):
        if f.sz[0] <= EPS or f.sz[1] <= EPS:
            continue
        inside, border = offset_face(f, d, want_border)
        if inside is not None:
            insides.append(inside)
        borders.extend(border)
    mesh_inside = _faces_mesh(s, insides)
    mesh_border = _faces_mesh(s, borders) if want_border else None
    return mesh_inside, [] if mesh_border is None else [mesh_border]


def _faces_mesh(s: Shape, faces: list[Shape]) -> Shape | None:
    """Face shapes as one open mesh shape in `s`'s scope (its bounding box the new scope)."""
    if not faces:
        return None
    A = np.asarray(s.ax, dtype=np.float64)
    parts, tris, n = [], [], 0
    for f in faces:
        V, F = surfaces.face_triangles(f.o, f.ax, f.sz, f.poly)
        parts.append((V - np.asarray(s.o, dtype=np.float64)) @ A.T)  # world -> s's scope
        tris.append(F + n)
        n += len(V)
    V, F = np.concatenate(parts), np.concatenate(tris)
    if not len(F):
        return None
    lo = V.min(axis=0)
    size = V.max(axis=0) - lo
    mesh = surfaces.SurfaceMesh(V - lo, F)
    return s.derived(s.world(*lo.tolist()), tuple(size.tolist()), None, VOLUME, solid=mesh)
