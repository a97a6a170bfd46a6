"""Implementations of the built-in split operations (bound to the specs in operations.py).

The contract is the plugins' one (grammarkit.hookspecs: OperationContext, ShapeView,
BlockSlot), and these functions use nothing else: `apply(ctx, shape, args, block)` where
`ctx` is the derivation's OperationContext, `args` the evaluated arguments in the spec's
parameter order (defaults filled in; variadic extras appended), and `block` the compiled block
slots or None. A non-block operation returns the (new or modified) shape to continue with, or
None to delete it. A block operation returns a list of `(child_shape, slot)`; each child then
runs its slot's body (the engine numbers them: `split.index`, `split.total`). Raise
ValueError for bad arguments: the engine turns it into a DerivationError naming the rule and
the call's source position.
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Any

import manifold3d

from ..dsl.binding import parse_color
from ..geometry import footprints as fp
from ..geometry import roofs
from ..geometry.solids import insert_fitted, taper as taper_solid
from .assets import builtin_asset, load_asset, load_asset_mesh
from .engine import rotation
from .scope_ops import (
    op_align_scope_to_axes, op_align_scope_to_geometry, op_mirror, op_mirror_scope, op_reverse_normals,
    op_rotate_scope,
)
from .shape import FACE, VOLUME, Shape
from .lots import (
    op_inner_rectangle, op_setback, op_setback_per_edge, op_setback_to_area, op_shape_l, op_shape_o, op_shape_u,
)
from .occlusion import op_label
from .scatter import op_scatter
from .convexify import op_convexify
from .strings import cga_str
from .texturing import (
    moved, op_delete_uv, op_normalize_uv, op_project_uv, op_rotate_uv, op_scale_uv, op_setup_projection, op_texture,
    op_tile_uv, op_translate_uv, set_material,
)

Manifold = manifold3d.Manifold
AXIS = {"x": 0, "y": 1, "z": 2}
EPS = 1e-9


def _axis(value: Any) -> int:
    try:
        return AXIS[str(value)]
    except KeyError:
        raise ValueError(f"axis must be x, y or z, got {value!r}") from None


def _num(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} must be finite, got {v}")
    return v


def _face_only(s: Shape, op: str) -> None:
    if s.kind != FACE:
        raise ValueError(f"{op}() needs a face (e.g. from footprint() or comp(f)), got a volume")


def _rect_or_poly(poly: Any, sx: float, sy: float) -> Any:
    """Keep `poly` only when it is not just the scope rectangle (the fast path)."""
    if poly is None:
        return None
    if len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7):
        return None
    return poly


def _piece(s: Shape, cs: manifold3d.CrossSection, kind: str, extra_o: tuple[float, float] = (0.0, 0.0)):
    """A child shape from a CrossSection given in `s`'s scope coordinates (normalized bbox)."""
    contours = []
    for ring in cs.to_polygons():
        poly = tuple(map(tuple, ring.tolist()))
        if abs(fp.area(poly)) > 1e-9:
            contours.append(poly)
    if not contours:
        return None
    pts = [p for c in contours for p in c]
    x0 = min(p[0] for p in pts)
    y0 = min(p[1] for p in pts)
    x1 = max(p[0] for p in pts)
    y1 = max(p[1] for p in pts)
    shifted = tuple(tuple((x - x0, y - y0) for x, y in c) for c in contours)
    sx, sy = x1 - x0, y1 - y0
    o = s.world(x0 + extra_o[0], y0 + extra_o[1], 0.0)
    return s.derived(o, (sx, sy, s.sz[2] if kind == VOLUME else 0.0), _rect_or_poly(shifted, sx, sy), kind)


# -- geometry creation -------------------------------------------------------------------------
def op_footprint(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    shape = args[0]
    if not isinstance(shape, (tuple, list)) or not shape:
        raise ValueError("footprint() needs a polygon such as rect(20, 12) or polygon(0, 0, 8, 0, 8, 6)")
    poly = fp.validate_polygon(shape)
    norm, (x0, y0, x1, y1) = fp.normalize(poly)
    sx, sy = x1 - x0, y1 - y0
    o = s.world(x0, y0, 0.0)
    return s.derived(o, (sx, sy, 0.0), _rect_or_poly((norm,), sx, sy), FACE)


def op_extrude(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    h = _num(args[0], "extrude height")
    _face_only(s, "extrude")
    if h < 0:
        # CGA extrudes against the normal: the volume lies below the face, [h, 0] along z
        z = s.ax[2]
        o = (s.o[0] + z[0] * h, s.o[1] + z[1] * h, s.o[2] + z[2] * h)
        return s.derived(o, (s.sz[0], s.sz[1], -h), s.poly, VOLUME)
    # extrude(0) makes a volume without thickness (comp(f) gives its faces; as a terminal it
    # is left out of the solid with a warning)
    return s.derived(s.o, (s.sz[0], s.sz[1], h), s.poly, VOLUME)


def op_taper(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    h = _num(args[0], "taper height")
    k = _num(args[1], "taper top_scale")
    _face_only(s, "taper")
    if h <= 0 or k < 0:
        raise ValueError(f"taper needs height > 0 and top_scale >= 0, got {h:g}, {k:g}")
    polys = s.contours()
    solids = [taper_solid(p, h, k) for p in polys if fp.area(p) > 0]
    solid = solids[0] if len(solids) == 1 else Manifold.batch_boolean(solids, manifold3d.OpType.Add)
    return s.derived(s.o, (s.sz[0], s.sz[1], h), None, VOLUME, solid=solid)


def op_recess(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    d = _num(args[0], "recess depth")
    _face_only(s, "recess")
    if d <= 0:
        raise ValueError(f"recess depth must be > 0, got {d:g}")
    return ctx.recess(s, d)


# -- comp: grammarkit/split/comp.py --------------------------------------------------------
from .comp import op_comp  # noqa: E402
# -- splitArea: grammarkit/split/area_split.py (it uses split's layout below, at call time) --
from .area_split import op_split_area  # noqa: E402
from .envelope import op_envelope, op_envelope_per_edge  # noqa: E402


# -- split -----------------------------------------------------------------------------------
def layout(ctx: Any, s: Shape, items: tuple, length: float) -> list[tuple[Any, float, float]]:
    """Positions of split parts along an axis of `length`: a list of (slot, start, size).

    Absolute sizes are fixed, relative ones are fractions of the whole length, floating ones
    share what is left in proportion to their nominal sizes. Each repeat group takes the
    repetition count that best fits (rounding when the group can stretch, as many as fit when
    it cannot). When fixed parts do not fit, the part crossing the end is clipped and later
    parts are dropped; parts of size <= 0 are skipped.
    """
    flat: list[tuple[Any, bool, float]] = []
    _expand(ctx, s, items, length, length, flat)
    fixed = 0.0
    weight = 0.0
    for _, floating, v in flat:
        if floating:
            weight += v
        else:
            fixed += v
    rest = length - fixed
    k = rest / weight if (weight > 0 and rest > 0) else 0.0
    out = []
    pos = 0.0
    end = length + 1e-9
    for slot, floating, v in flat:
        size = v * k if floating else v
        if size <= EPS:
            continue
        if pos + size > end:
            size = length - pos
            if size > EPS:
                out.append((slot, pos, size))
            break
        out.append((slot, pos, size))
        pos += size
    return out


def _sizes(ctx: Any, s: Shape, items: tuple, total: float) -> list[tuple[Any, str, float]]:
    out = []
    for it in items:
        if it.mode == "repeat":
            out.append((it, "repeat", 0.0))
            continue
        v = it.size(s)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"split size must be a number, got {v!r}")
        if not math.isfinite(v):
            raise ValueError(f"split size must be finite, got {v!r}")
        if v < 0:
            # CGA makes no part for a negative size and lays out the rest as if it were not
            # there; so do we, but say so (it is almost always a mistake in the rule)
            where = f"{it.span}: " if getattr(it, "span", None) is not None else ""
            ctx.warn(f"{where}split size {v:g} is negative in rule {s.rule_name!r}: that part "
                     "is skipped (as in CGA)")
            v = 0.0
        if it.mode == "rel":
            v *= total
        out.append((it, it.mode, float(v)))
    return out


def _nominal(ctx: Any, s: Shape, items: tuple, total: float) -> tuple[float, bool]:
    """Length of one instance of a repeat group at nominal sizes, and whether it can stretch."""
    n = 0.0
    stretch = False
    for it, mode, v in _sizes(ctx, s, items, total):
        if mode == "repeat":
            m, st = _nominal(ctx, s, it.items, total)
            n += m
            stretch = stretch or st
        else:
            n += v
            stretch = stretch or mode == "float"
    return n, stretch


def _expand(ctx: Any, s: Shape, items: tuple, avail: float, total: float, flat: list) -> None:
    sized = _sizes(ctx, s, items, total)
    fixed = sum(v for _, mode, v in sized if mode in ("abs", "rel"))
    floating = sum(v for _, mode, v in sized if mode == "float")
    reps = [(it, *_nominal(ctx, s, it.items, total)) for it, mode, _ in sized if mode == "repeat"]
    counts: dict[int, int] = {}
    if reps:
        room = avail - fixed - floating
        nominal = sum(n for _, n, _ in reps)
        stretch = any(st for _, _, st in reps)
        if nominal <= EPS:
            raise ValueError("a repeat group needs a positive total size")
        ratio = room / nominal if room > 0 else 0.0
        n = int(math.floor(ratio + 0.5)) if stretch else int(math.floor(ratio + 1e-9))
        # CGA repeats zero times when the other parts of the block already fill the space
        # (`{ ~w: W | d: Wall }* | ~w: W` on 1.5 w is one W); a block that is nothing but
        # repeat groups still makes one instance (clipped), as CGA's `{ 2: A }*` on 1 does.
        if n < 1 and len(reps) == len(sized):
            n = 1
        n = max(n, 0)
        if n > ctx.limits.max_repeat:
            from ..errors import LimitError
            raise LimitError(
                f"repeat limit exceeded: {n} repetitions > {ctx.limits.max_repeat} "
                f"(in rule {s.rule_name!r}, length {avail:g} / group size {nominal:g})",
                reps[0][0].span, code="limit-repeat")
        for it, nom, _ in reps:
            counts[id(it)] = n
        share = {id(it): (max(room, 0.0) * nom / nominal / n if n else 0.0) for it, nom, _ in reps}
    for it, mode, v in sized:
        if mode == "repeat":
            for _ in range(counts[id(it)]):
                _expand(ctx, s, it.items, share[id(it)], total, flat)
        else:
            flat.append((it, mode == "float", v))


def _split_geometry(s: Shape, a: int, start: float, size: float) -> Shape | None:
    ax = s.ax[a]
    o = (s.o[0] + ax[0] * start, s.o[1] + ax[1] * start, s.o[2] + ax[2] * start)
    sz = list(s.sz)
    sz[a] = size
    if s.solid is not None:
        normal = [0.0, 0.0, 0.0]
        normal[a] = 1.0
        trimmed = s.solid.trim_by_plane(tuple(normal), start)
        normal[a] = -1.0
        trimmed = trimmed.trim_by_plane(tuple(normal), -(start + size))
        shift = [0.0, 0.0, 0.0]
        shift[a] = -start
        trimmed = trimmed.translate(tuple(shift))
        if trimmed.is_empty():
            return None
        return s.derived(o, tuple(sz), None, s.kind, solid=trimmed)
    if s.poly is None or a == 2:
        return s.derived(o, tuple(sz), s.poly)
    x0, y0, x1, y1 = (start, 0.0, start + size, s.sz[1]) if a == 0 else (0.0, start, s.sz[0], start + size)
    cs = fp.cross_section(s.poly) ^ Manifold_rect(x0, y0, x1, y1)
    if cs.is_empty():
        return None
    return _piece(s, cs, s.kind)


def Manifold_rect(x0: float, y0: float, x1: float, y1: float) -> manifold3d.CrossSection:
    return manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))


def op_split(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    a = _axis(args[0])
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
        c = _split_geometry(s, a, start, size)
        if c is not None:
            out.append((c, slot))
    return out


# -- offset ----------------------------------------------------------------------------------
def op_offset(ctx: Any, s: Shape, args: Any, block: Any) -> Any:
    d = _num(args[0], "offset distance")
    _face_only(s, "offset")
    sx, sy = s.sz[0], s.sz[1]
    inside: Shape | None
    border: list[Shape] = []
    if s.poly is None and d <= 0:
        e = -d
        w, h = sx - 2 * e, sy - 2 * e
        inside = s.derived(s.world(e, e, 0.0), (w, h, 0.0), None) if w > EPS and h > EPS else None
        if block is not None and e > EPS:
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
        inside = None if grown.is_empty() else _piece(s, grown, FACE)
        if block is not None and abs(d) > EPS:
            ring = (whole - grown) if d < 0 else (grown - whole)
            piece = None if ring.is_empty() else _piece(s, ring, FACE)
            if piece is not None:
                border = [piece]
    if block is None:
        return inside
    out = []
    for slot in block:
        if slot.sel == "inside" and inside is not None:
            out.append((inside, slot))
        elif slot.sel == "border":
            out.extend((b.copy() if i else b, slot) for i, b in enumerate(border))
    return out


# -- roofs -----------------------------------------------------------------------------------
def _roof(s: Shape, build: Any, name: str) -> Shape:
    _face_only(s, name)
    if s.sz[0] <= EPS or s.sz[1] <= EPS:
        raise ValueError(f"{name}() on an empty face")
    polys = [p for p in s.contours() if fp.area(p) > 0]
    solids = [build(p) for p in polys]
    solid = solids[0] if len(solids) == 1 else Manifold.batch_boolean(solids, manifold3d.OpType.Add)
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
    return int(math.floor(_num(v, "edge index")))


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


def op_roof_gable(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, ridge = _num(args[0], "angle"), _num(args[1], "overhang"), _ridge(args[2], auto=True)
    over_y = None if args[3] is None else _num(args[3], "overhang_y")
    index, vt = _index(args[4]), _value_type(args[5])
    even = _flag(args[6], "even")

    def build(p: Any, angle: float) -> Any:
        return roofs.gable(p, angle, over, ridge, overhang_y=over_y, index=index, even=even)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofGable")


def op_roof_hip(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, vt = _num(args[0], "angle"), _num(args[1], "overhang"), _value_type(args[2])
    even = _flag(args[3], "even")

    def build(p: Any, angle: float) -> Any:
        return roofs.hip(p, angle, over, even)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofHip")


def op_roof_pyramid(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    angle, over = _num(args[0], "angle"), _num(args[1], "overhang")
    return _roof(s, lambda p: roofs.pyramid(p, angle, over), "roofPyramid")


def op_roof_shed(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    value, over, ridge = _num(args[0], "angle"), _num(args[1], "overhang"), _ridge(args[2])
    index, vt = _index(args[3]), _value_type(args[4])

    def build(p: Any, angle: float) -> Any:
        return roofs.shed(p, angle, over, ridge, index=index)
    return _roof(s, lambda p: build(p, _pitch(value, vt, build, p)), "roofShed")


def op_roof_mansard(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    angle, height = _num(args[0], "angle"), _num(args[1], "height")
    top, over = _num(args[2], "top_angle"), _num(args[3], "overhang")
    return _roof(s, lambda p: roofs.mansard(p, angle, height, top, over), "roofMansard")


# -- transformations -------------------------------------------------------------------------
def op_t(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    x, y, z = (_num(v, "t()") for v in args[:3])
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = s.ax
    o0 = s.o
    c = s
    c.o = (s.o[0] + a0 * x + b0 * y + c0 * z, s.o[1] + a1 * x + b1 * y + c1 * z,
           s.o[2] + a2 * x + b2 * y + c2 * z)
    if c.on is not None and (x or y or z):
        c.on = None  # a face moved off its volume is a surface of its own
    if c.tex is not None:
        moved(c, o0, c.ax)  # baked UVs move with the geometry
    return c


def op_r(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    rx, ry, rz = (_num(v, "r()") for v in args[:3])
    R = rotation(rx, ry, rz)
    ax = s.ax
    # new axis j = sum_i R[i][j] * old axis i  (the rotation is expressed in scope coordinates)
    new = tuple(tuple(sum(R[i][j] * ax[i][k] for i in range(3)) for k in range(3)) for j in range(3))
    c = s
    c.ax = new  # type: ignore[assignment]
    if c.on is not None and (rx or ry or rz):
        c.on = None
    if c.tex is not None:
        moved(c, c.o, ax)
    return c


def op_s(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    new = tuple(_num(v, "s()") for v in args[:3])
    if any(v < 0 for v in new):
        raise ValueError(f"s() sizes must be >= 0, got {new}")
    old = s.sz
    f = tuple((n / o) if o > EPS else 1.0 for n, o in zip(new, old))
    c = s.copy()
    c.sz = new  # type: ignore[assignment]
    if s.poly is not None:
        c.poly = tuple(tuple((x * f[0], y * f[1]) for x, y in p) for p in s.poly)
    if s.solid is not None:
        c.solid = s.solid.scale(f)
    if s.kind == FACE and new[2] > EPS and s.poly is None:
        c.kind = VOLUME  # a face given a depth becomes a box (e.g. to insert a mesh in it)
    if c.tex is not None:
        moved(c, s.o, s.ax, f)
    return c


def op_center(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    axes = str(args[0])
    if not axes or any(ch not in "xyz" for ch in axes):
        raise ValueError(f"center() takes a combination of x, y, z, got {axes!r}")
    eo, eax, esz = s.entry or (s.o, s.ax, s.sz)
    pc = [eo[k] + sum(eax[i][k] * esz[i] / 2 for i in range(3)) for k in range(3)]
    cc = [s.o[k] + sum(s.ax[i][k] * s.sz[i] / 2 for i in range(3)) for k in range(3)]
    d = [pc[k] - cc[k] for k in range(3)]
    o = list(s.o)
    for ch in axes:
        a = s.ax[AXIS[ch]]
        t = d[0] * a[0] + d[1] * a[1] + d[2] * a[2]
        for k in range(3):
            o[k] += a[k] * t
    c = s
    if c.on is not None and tuple(o) != s.o:
        c.on = None
    o0 = c.o
    c.o = tuple(o)  # type: ignore[assignment]
    if c.tex is not None:
        moved(c, o0, c.ax)
    return c


def fitted_size(extent: tuple, size: tuple) -> tuple[float, float, float]:
    """The size an asset of bounding box `extent` gets in a scope of `size`: the scope's size,
    except that a zero size keeps the asset's proportion on that axis (scaled like the others),
    as CGA's `i()` does (the same rule as grammarkit.geometry.solids.insert_fitted)."""
    given = [s / e for s, e in zip(size, extent) if s > 1e-12 and e > 1e-12]
    default = sum(given) / len(given) if given else 1.0
    return tuple(s if (s > 1e-12 and e > 1e-12) else e * default  # type: ignore[return-value]
                 for s, e in zip(size, extent))


def _trimmed(solid: Any, s: Shape) -> Any:
    """Clip an inserted solid or surface by the shape's trim planes (CGA: the bisector planes
    at the corners of the faces comp(f) made; a cornice inserted along a facade is mitred at
    the building's corners). The planes are in world coordinates; the solid is in the scope's."""
    for point, normal in s.trims:
        ln = [sum(normal[k] * s.ax[i][k] for k in range(3)) for i in range(3)]  # world -> scope
        lp = [sum((point[k] - s.o[k]) * s.ax[i][k] for k in range(3)) for i in range(3)]
        offset = ln[0] * lp[0] + ln[1] * lp[1] + ln[2] * lp[2]
        x0, y0, z0, x1, y1, z1 = solid.bounding_box()
        # the lowest value of dot(n, p) over the bounding box: nothing to cut when it is kept
        low = sum(min(n * a, n * b) for n, a, b in zip(ln, (x0, y0, z0), (x1, y1, z1)))
        if low >= offset - 1e-9:
            continue
        solid = solid.trim_by_plane(tuple(ln), offset)
    return solid


def op_insert(ctx: Any, s: Shape, args: Any, block: Any) -> Shape | None:
    rel = str(args[0])  # the compiler made constant paths absolute (relative to their file)
    fit = str(args[1]) if len(args) > 1 else "scale"
    if rel.startswith("builtin:"):
        asset = builtin_asset(rel)
        path = Path(rel)
    else:
        path = Path(rel) if Path(rel).is_absolute() else (Path(ctx.base_dir or ".") / rel).resolve()
        if not path.is_file():
            raise ValueError(f"i(): mesh file not found: {path}")
        asset = load_asset(str(path)) if fit == "scale" else None
    if fit == "scale":  # the built-in fit, on the manifold directly (no mesh round trip)
        solid, size = insert_fitted(asset, s.sz)
        if s.trims and s.trim_on:
            solid = _trimmed(solid, s)
            if solid.is_empty():
                return None  # trimmed away entirely
        return _untextured(s.derived(s.o, size, None, VOLUME, solid=solid))
    if rel.startswith("builtin:"):
        raise ValueError(f"i(): fit {fit!r} needs a mesh file, not the built-in {rel!r}")
    fits = ctx.registries.fits if ctx.registries is not None else {}
    spec = fits.get(fit)
    if spec is None or spec.fit is None:
        raise ValueError(f"i(): unknown fit {fit!r}; known fits: {', '.join(sorted(fits)) or 'none'}")
    from ..geometry.convert import to_manifold

    mesh = load_asset_mesh(str(path)).copy()
    lo = mesh.bounds[0]
    mesh.apply_translation(-lo)  # the asset's bounding box minimum at the origin
    target = fitted_size(tuple(float(e) for e in mesh.extents), s.sz)
    out = spec.fit(mesh, target)
    solid = to_manifold(out, what=f"{path.name} fitted by {fit!r} (plugin {spec.plugin or '?'})")
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    size = (x1 - x0, y1 - y0, z1 - z0)
    if not all(math.isfinite(v) for v in size) or min(size) < 0:
        raise ValueError(f"fit {fit!r} returned an empty or broken mesh for {path.name}")
    return _untextured(s.derived(s.o, size, None, VOLUME, solid=solid.translate((-x0, -y0, -z0))))


def _untextured(s: Shape) -> Shape:
    """An inserted mesh is new geometry: the UVs baked into the shape it replaces are not its
    own (grammarkit does not read assets' UVs; the material attributes stay)."""
    if s.tex is not None and s.tex.uv:
        s.tex = s.tex.replace(uv=())
    return s


# -- tags ------------------------------------------------------------------------------------
@lru_cache(maxsize=1024)
def _hex_color(v: Any) -> str:
    color = parse_color(v)
    if color is None:
        raise ValueError(f"color must be '#rrggbb' or '#rgb', got {str(v).strip()!r}")
    return color


def op_color(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    c = s
    c.color = _hex_color(args[0])
    return c


def op_material(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    c = s
    c.material = str(args[0])
    return c


def op_set(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `set(attr, value)`: the shape and its descendants see the new value; other shapes
    keep theirs (each shape carries its values, shared until one is changed)."""
    key, value = str(args[0]), args[1]
    if key.startswith("material."):
        return set_material(ctx, s, key, value)
    if isinstance(value, tuple):
        raise ValueError(f"set({key}, ...): the value must be a number, a string or a boolean")
    c = s
    c.values = {**s.values, key: value}
    return c


def op_trim(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`trim(false)` / `trim(true)`: whether `i()` clips inserts by the trim planes (CGA's
    `set(trim.vertical, ...)`), for this shape and what is derived from it."""
    c = s
    c.trim_on = bool(args[0])
    return c


def op_report(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `report(key, value)`: the value is collected under the key (Model.reports: count,
    sum, mean, min, max of numbers; counts of strings)."""
    key, value = args[0], args[1]
    if not isinstance(key, str) or not key:
        raise ValueError(f"report(): the key must be a non-empty string, got {key!r}")
    if isinstance(value, tuple):
        raise ValueError(f"report({key!r}, ...): the value must be a number, a string or a boolean")
    ctx.report(key, value)
    return s


def op_print(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `print(value)`: a message of the derivation (Model.messages, printed by `grammarkit
    derive`), `Rule: value` with the value as CGA's str() writes it; the shape is unchanged."""
    value = args[0]
    if isinstance(value, tuple):
        raise ValueError("print(): the value must be a number, a string or a boolean")
    ctx.message(f"{s.rule_name}: {cga_str(value)}")
    return s


BUILTIN_APPLY = {
    "footprint": op_footprint, "extrude": op_extrude, "taper": op_taper, "recess": op_recess,
    "comp": op_comp, "split": op_split, "offset": op_offset,
    "roofGable": op_roof_gable, "roofHip": op_roof_hip, "roofPyramid": op_roof_pyramid,
    "roofShed": op_roof_shed, "roofMansard": op_roof_mansard,
    "t": op_t, "r": op_r, "s": op_s, "center": op_center, "i": op_insert,
    "color": op_color, "material": op_material, "set": op_set,
    "alignScopeToGeometry": op_align_scope_to_geometry, "alignScopeToAxes": op_align_scope_to_axes,
    "rotateScope": op_rotate_scope, "report": op_report, "reverseNormals": op_reverse_normals,
    "mirrorScope": op_mirror_scope, "mirrorGeometry": op_mirror,
    "trim": op_trim,
    "setupProjection": op_setup_projection, "projectUV": op_project_uv, "texture": op_texture,
    "translateUV": op_translate_uv, "scaleUV": op_scale_uv, "rotateUV": op_rotate_uv,
    "deleteUV": op_delete_uv, "tileUV": op_tile_uv, "normalizeUV": op_normalize_uv,
    "setback": op_setback, "setbackPerEdge": op_setback_per_edge, "setbackToArea": op_setback_to_area,
    "shapeL": op_shape_l, "shapeU": op_shape_u, "shapeO": op_shape_o, "innerRectangle": op_inner_rectangle,
    "splitArea": op_split_area, "envelope": op_envelope, "envelopePerEdge": op_envelope_per_edge,
    "label": op_label, "scatter": op_scatter, "print": op_print,
    "convexify": op_convexify,
}


def op_repeat(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    """`repeat(axis, size, separator) (A B)* C`: the compiler turns the pattern into split slots."""
    if _num(args[1], "repeat size") <= 0:
        raise ValueError(f"repeat size must be > 0, got {args[1]!r}")
    if _num(args[2], "repeat separator") < 0:
        raise ValueError(f"repeat separator must be >= 0, got {args[2]!r}")
    return op_split(ctx, s, (args[0],), block)


BUILTIN_APPLY["repeat"] = op_repeat
