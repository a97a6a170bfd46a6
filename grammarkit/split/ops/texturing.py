"""CGA's texturing: `setupProjection`, `projectUV`, the UV operations, `texture` and the
`material.*` shape attributes (docs/cga.md, "Texturing").

Every CGA projection is planar: `setupProjection(k, scope.xy, w, h, wo, ho)` fixes, in world
space, an origin and two directions (a scope's or the world's), and uv = ((p - o)·a - wo) / w,
((p - o)·b - ho) / h for a point p. `projectUV(k)` bakes that projection into the shape's
geometry: from then on the UVs move with the geometry (`t`, `r`, `s`, `center`), while
splits, `comp` and the scope operations keep them where they are (the geometry does not move).

Because a projection is affine in the position and every later change of a shape's geometry
is affine too, the UVs of a shape are exactly an affine map of the *world* position of its
geometry: the shape carries that 2 x 4 matrix per uv set instead of per-vertex values, and the
exporter evaluates it at the final mesh's vertices (grammarkit/split/model.py). That is exact
through the final boolean (a union only clips faces, it never moves a point), and it needs no
vertex properties in manifold3d, so solids stay welded by position.

The state is one immutable `Texturing` object per shape (`Shape.tex`, None until a texturing
operation runs): copies share it, operations replace it.
"""
from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

from ... import confine
from ...registry import Param
from ..shape import Shape
from .helpers import hex_color, operation

__all__ = ["AXES", "MATERIAL_KEYS", "Texturing", "moved", "op_delete_uv", "op_normalize_uv", "op_project_uv",
           "op_rotate_uv", "op_scale_uv", "op_setup_projection", "op_texture", "op_tile_uv", "op_translate_uv",
           "set_material"]

# setupProjection's axes selectors: the origin (scope or world) and the axes taken as u and v
AXES = tuple(f"{o}.{a}{b}" for o in ("scope", "world") for a, b in
             (("x", "y"), ("x", "z"), ("y", "x"), ("y", "z"), ("z", "x"), ("z", "y")))
UV_SETS = 10  # CGA's uv sets 0..9 (0: colormap, 1: bumpmap, 2: dirtmap, ...)

# material.* attributes the exporter turns into glTF (others are kept in the material's extras)
MATERIAL_KEYS = ("name", "color.rgb", "color.r", "color.g", "color.b", "opacity", "colormap", "metallic",
                 "roughness", "doubleSided")

Mat = tuple  # 2 x 4 affine map, rows (u, v): ((a0, a1, a2, a3), (b0, b1, b2, b3))


class Texturing:
    """The texturing state of a shape: projections set up (per uv set), UVs baked into the
    geometry (per uv set, as affine maps of the world position) and material attributes."""

    __slots__ = ("proj", "uv", "mat")

    def __init__(self, proj: tuple = (), uv: tuple = (), mat: tuple = ()):
        self.proj = proj  # ((uv set, Mat), ...)
        self.uv = uv  # ((uv set, Mat), ...)
        self.mat = mat  # ((key, value), ...) sorted by key

    def replace(self, **kw: Any) -> "Texturing":
        return Texturing(kw.get("proj", self.proj), kw.get("uv", self.uv), kw.get("mat", self.mat))

    def get_uv(self, k: int) -> Mat | None:
        for i, m in self.uv:
            if i == k:
                return m
        return None

    def material(self) -> dict:
        return dict(self.mat)

    def key(self) -> tuple:
        """What makes two terminals' materials differ (the UV maps do not)."""
        return self.mat

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Texturing) and (self.proj, self.uv, self.mat) == (other.proj, other.uv, other.mat)

    def __hash__(self) -> int:
        return hash((self.proj, self.uv, self.mat))

    def __repr__(self) -> str:
        return f"Texturing(proj={dict(self.proj)}, uv={dict(self.uv)}, mat={dict(self.mat)})"


def _state(s: Shape) -> Texturing:
    return s.tex if s.tex is not None else Texturing()


def _with(pairs: tuple, k: Any, value: Any) -> tuple:
    out = tuple(p for p in pairs if p[0] != k)
    if value is not None:
        out = tuple(sorted(out + ((k, value),), key=lambda p: p[0]))
    return out


def _uv_set(v: Any, op: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v) or not 0 <= v < UV_SETS:
        raise ValueError(f"{op}: the uv set must be an integer 0..{UV_SETS - 1}, got {v!r}")
    return int(v)


def _finite(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{what} must be a finite number, got {v!r}")
    return float(v)


@operation("setupProjection", (Param("uvset"), Param("axes", "axis", choices=AXES),
                               Param("width"), Param("height"),
                               Param("width_offset", required=False, default=0.0),
                               Param("height_offset", required=False, default=0.0)),
           doc="A planar texture projection for a uv set: origin and u/v axes of the scope or "
               "the world, a texture tile of width x height world units.")
def op_setup_projection(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`setupProjection(uvset, scope.xy, w, h, wo = 0, ho = 0)`: a planar projection for uv
    set `uvset` from the scope's (or the world's) origin along two of its axes, a texture
    tile `w` x `h` world units (negative: mirrored), shifted by `wo`, `ho` world units."""
    k = _uv_set(args[0], "setupProjection()")
    axes = str(args[1])
    if axes not in AXES:
        raise ValueError(f"setupProjection(): axes must be one of {', '.join(AXES)}, got {axes!r}")
    w = _finite(args[2], "setupProjection(): the texture width")
    h = _finite(args[3], "setupProjection(): the texture height")
    wo = _finite(args[4], "setupProjection(): the width offset") if len(args) > 4 else 0.0
    ho = _finite(args[5], "setupProjection(): the height offset") if len(args) > 5 else 0.0
    if abs(w) < 1e-12 or abs(h) < 1e-12:
        raise ValueError(f"setupProjection(): the texture size must not be 0, got {w:g} x {h:g}")
    frame, pair = axes.split(".")
    if frame == "scope":
        origin, basis = s.o, s.ax
    else:
        origin, basis = (0.0, 0.0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    rows = []
    for letter, size, off in ((pair[0], w, wo), (pair[1], h, ho)):
        a = basis["xyz".index(letter)]
        d = sum(a[i] * origin[i] for i in range(3))
        rows.append((a[0] / size, a[1] / size, a[2] / size, (-d - off) / size))
    st = _state(s)
    c = s
    c.tex = st.replace(proj=_with(st.proj, k, tuple(rows)))
    return c


@operation("projectUV", (Param("uvset"),),
           doc="Bake the uv set's projection into the shape's texture coordinates.")
def op_project_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`projectUV(uvset)`: bake the projection of `uvset` into the shape's geometry."""
    k = _uv_set(args[0], "projectUV()")
    st = _state(s)
    m = dict(st.proj).get(k)
    if m is None:
        # CGA leaves the shape without texture coordinates then; a warning says why
        ctx.warn(f"rule {s.rule_name!r}: projectUV({k}) without setupProjection({k}, ...): no texture "
                 "coordinates made")
        return s
    c = s
    c.tex = st.replace(uv=_with(st.uv, k, m))
    return c


def _no_uvs(ctx: Any, s: Shape, k: int, op: str) -> Shape:
    """A uv operation on a shape without texture coordinates in set `k` changes nothing, as in
    CityEngine (an inserted asset's own UVs are not kept yet): a warning, not the end of the
    whole model (issue 26: one tileUV() on an asset aborted candler)."""
    ctx.warn(f"rule {s.rule_name!r}: {op}: the shape has no texture coordinates in uv set {k} "
             f"(projectUV({k}) first); nothing changed")
    return s


def _uv_affine(ctx: Any, s: Shape, k: int, op: str, a: tuple) -> Shape:
    """Compose the baked uv map of set `k` with the 2 x 3 affine map `a` of the uv plane."""
    st = _state(s)
    m = st.get_uv(k)
    if m is None:
        return _no_uvs(ctx, s, k, op)
    (a00, a01, a02), (a10, a11, a12) = a
    u, v = m
    new = (tuple(a00 * u[i] + a01 * v[i] + (a02 if i == 3 else 0.0) for i in range(4)),
           tuple(a10 * u[i] + a11 * v[i] + (a12 if i == 3 else 0.0) for i in range(4)))
    c = s
    c.tex = st.replace(uv=_with(st.uv, k, new))
    return c


@operation("translateUV", (Param("uvset"), Param("u"), Param("v")),
           doc="Shift the texture coordinates of a uv set (texture units).")
def op_translate_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`translateUV(uvset, du, dv)`: add (du, dv) to the texture coordinates (texture units)."""
    k = _uv_set(args[0], "translateUV()")
    du, dv = (_finite(v, "translateUV()") for v in args[1:3])
    return _uv_affine(ctx, s, k, "translateUV()", ((1.0, 0.0, du), (0.0, 1.0, dv)))


@operation("scaleUV", (Param("uvset"), Param("u"), Param("v")),
           doc="Scale the texture coordinates of a uv set.")
def op_scale_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`scaleUV(uvset, fu, fv)`: multiply the texture coordinates by (fu, fv)."""
    k = _uv_set(args[0], "scaleUV()")
    fu, fv = (_finite(v, "scaleUV()") for v in args[1:3])
    return _uv_affine(ctx, s, k, "scaleUV()", ((fu, 0.0, 0.0), (0.0, fv, 0.0)))


@operation("rotateUV", (Param("uvset"), Param("angle")),
           doc="Turn the texture coordinates of a uv set about the uv origin (degrees).")
def op_rotate_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`rotateUV(uvset, degrees)`: turn the texture coordinates about the uv origin."""
    k = _uv_set(args[0], "rotateUV()")
    a = math.radians(_finite(args[1], "rotateUV()"))
    c, sn = math.cos(a), math.sin(a)
    return _uv_affine(ctx, s, k, "rotateUV()", ((c, -sn, 0.0), (sn, c, 0.0)))


@operation("deleteUV", (Param("uvset"),), doc="Remove the texture coordinates of a uv set.")
def op_delete_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`deleteUV(uvset)`: the shape has no texture coordinates in that set any more."""
    k = _uv_set(args[0], "deleteUV()")
    st = _state(s)
    c = s
    c.tex = st.replace(uv=_with(st.uv, k, None))
    return c


@operation("texture", (Param("path", "string"),),
           doc="The colour texture (CGA's material.colormap) of the shape; makes no UVs.")
def op_texture(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`texture(path)`: CGA's short form of `set(material.colormap, path)` (no UVs made)."""
    return set_material(ctx, s, "material.colormap", args[0])


def _unit(v: Any, key: str) -> float:
    x = _finite(v, f"set({key}, ...)")
    if not 0.0 <= x <= 1.0:
        raise ValueError(f"set({key}, ...): the value must be in [0, 1], got {x:g}")
    return x


def set_material(ctx: Any, s: Shape, key: str, value: Any) -> Shape:
    """`set(material.<key>, value)`: a CGA material attribute of the shape (and what is
    derived from it). `name` and the colour are grammarkit's `material()`/`color()` tags; the
    rest is kept per shape and becomes the glTF material (docs/cga.md, "Texturing")."""

    sub = key[len("material."):]
    c = s
    if sub == "name":
        c.material = str(value)
        return c
    if sub in ("color.rgb", "color"):
        c.color = hex_color(value)
        return c
    if sub in ("color.r", "color.g", "color.b"):
        x = _unit(value, key)
        h = (s.color or "#ffffff").lstrip("#")  # CGA's default colour is white
        rgb = [h[0:2], h[2:4], h[4:6]]
        rgb["rgb".index(sub[-1])] = f"{round(x * 255):02x}"
        c.color = "#" + "".join(rgb)
        return c
    st = _state(s)
    if sub in ("opacity", "metallic", "roughness"):
        value = _unit(value, key)
    elif sub == "doubleSided":
        value = bool(value)
    elif sub.endswith("map"):
        value = str(value)
        if value and not value.startswith("builtin:"):  # before _is_file: tells no existence
            confine.check(value, base=ctx.base_dir or ".", what="texture file")
        if value and not value.startswith("builtin:") and not _is_file(value, ctx.base_dir or "."):
            ctx.warn(f"set({key}, ...): texture file not found: {value} (the material is exported "
                     "without it)")
        value = value or None  # "" clears the map, as in CGA
    elif isinstance(value, tuple):
        raise ValueError(f"set({key}, ...): the value must be a number, a string or a boolean")
    c.tex = st.replace(mat=_with(st.mat, sub, value))
    return c


@lru_cache(maxsize=256)
def _is_file(path: str, base: str) -> bool:
    """Whether a texture file exists (asked once per path: facades set the same map thousands
    of times; a file appearing during a derivation is not looked for again)."""
    from pathlib import Path

    p = Path(path) if Path(path).is_absolute() else Path(base) / path
    return p.is_file()


def moved(s: Shape, o: tuple, ax: tuple, f: tuple = (1.0, 1.0, 1.0)) -> None:
    """`s`'s geometry was moved from the frame (o, ax) to its current scope, scaled by `f` per
    scope axis (s()): its baked UVs move along (uv(p_new) = uv_old(p_old))."""
    st = s.tex
    if st is None or not st.uv:
        return
    if ax == s.ax and f == (1.0, 1.0, 1.0):
        # a translation by d (t, center): uv(p) = M (p - d), only the constant column changes
        if o == s.o:
            return
        d = (s.o[0] - o[0], s.o[1] - o[1], s.o[2] - o[2])
        s.tex = st.replace(uv=tuple((k, tuple((r[0], r[1], r[2], r[3] - r[0] * d[0] - r[1] * d[1] - r[2] * d[2])
                                              for r in m)) for k, m in st.uv))
        return
    # p_old = o + A diag(1/f) A'^T (p_new - o')  ->  a 4 x 4 affine map T; new Mat = Mat @ T
    A, B = ax, s.ax
    inv = [1.0 / x if abs(x) > 1e-12 else 1.0 for x in f]
    L = [[sum(A[i][r] * inv[i] * B[i][c] for i in range(3)) for c in range(3)] for r in range(3)]
    t = [o[r] - sum(L[r][c] * s.o[c] for c in range(3)) for r in range(3)]
    uv = []
    for k, (u, v) in st.uv:
        rows = []
        for row in (u, v):
            lin = tuple(sum(row[r] * L[r][c] for r in range(3)) for c in range(3))
            rows.append((*lin, row[3] + sum(row[r] * t[r] for r in range(3))))
        uv.append((k, tuple(rows)))
    s.tex = st.replace(uv=tuple(uv))


def _world_points(s: Shape) -> list[tuple]:
    """The vertices of the shape's geometry in world coordinates (a face's outline, a volume's
    mesh or its footprint prism)."""
    if s.kind == "F":
        return [s.world(x, y, 0.0) for c in s.contours() for x, y in c]
    from ...geometry.surfaces import SurfaceMesh

    if isinstance(s.solid, SurfaceMesh):
        return [s.world(*map(float, v)) for v in s.solid.V]
    if s.solid is not None:
        import numpy as np

        V = np.asarray(s.solid.to_mesh().vert_properties, dtype=float)[:, :3]
        return [s.world(*map(float, v)) for v in V]
    return [s.world(x, y, z) for c in s.contours() for x, y in c for z in (0.0, s.sz[2])]


def _uv_range(s: Shape, m: Mat) -> tuple[tuple[float, float], tuple[float, float]]:
    """(min, max) of u and of v over the shape's geometry under the uv map `m`."""
    pts = _world_points(s)
    if not pts:
        return (0.0, 0.0), (0.0, 0.0)
    out = []
    for row in m:
        vals = [row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + row[3] for p in pts]
        out.append((min(vals), max(vals)))
    return out[0], out[1]


@operation("tileUV", (Param("uvset"), Param("width"), Param("height")),
           doc="Rescale the texture coordinates so a texture tile spans width x height world "
               "units (negative: mirrored; 0: the axis is left as it is).")
def op_tile_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`tileUV(uvset, w, h)`: rescale the texture coordinates so that one texture tile spans
    `w` x `h` world units along u and v (negative: mirrored; 0: that axis is left as it is).
    The uv map is affine, so a world unit along the surface is 1 / |grad u| uv units: u is
    scaled by 1 / (w |grad u|) about u = 0 (CGA keeps the uv origin)."""
    k = _uv_set(args[0], "tileUV()")
    w = _finite(args[1], "tileUV(): the texture width")
    h = _finite(args[2], "tileUV(): the texture height")
    m = _state(s).get_uv(k)
    if m is None:
        return _no_uvs(ctx, s, k, "tileUV()")
    f = []
    for row, size in zip(m, (w, h)):
        grad = math.sqrt(row[0] ** 2 + row[1] ** 2 + row[2] ** 2)
        f.append(1.0 if abs(size) < 1e-12 or grad < 1e-15 else 1.0 / (size * grad))
    return _uv_affine(ctx, s, k, "tileUV()", ((f[0], 0.0, 0.0), (0.0, f[1], 0.0)))


NORMALIZE_AXES = ("uv", "u", "v")
NORMALIZE_MODES = ("separatePerFace", "collectiveAllFaces")


@operation("normalizeUV", (Param("uvset"), Param("axes", "axis", choices=("uv", "u", "v")),
                           Param("mode", "axis", choices=("separatePerFace", "collectiveAllFaces"))),
           doc="Shift and scale the texture coordinates to span [0, 1] over the shape.")
def op_normalize_uv(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`normalizeUV(uvset, uv|u|v, separatePerFace|collectiveAllFaces)`: shift and scale the
    texture coordinates so they span [0, 1] over the shape's geometry along u and/or v. A
    shape's UVs are one affine map, so both modes normalise over the whole shape (exact for a
    face, which is one face; on a volume `separatePerFace` is read as `collectiveAllFaces`)."""
    k = _uv_set(args[0], "normalizeUV()")
    which, mode = str(args[1]), str(args[2])
    if which not in NORMALIZE_AXES:
        raise ValueError(f"normalizeUV(): the axes must be one of {', '.join(NORMALIZE_AXES)}, got {which!r}")
    if mode not in NORMALIZE_MODES:
        raise ValueError(f"normalizeUV(): the mode must be one of {', '.join(NORMALIZE_MODES)}, got {mode!r}")
    m = _state(s).get_uv(k)
    if m is None:
        return _no_uvs(ctx, s, k, "normalizeUV()")  # as tileUV(): a warning, not the end
    a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    for i, (lo, hi) in enumerate(_uv_range(s, m)):
        if "uv"[i] in which and hi - lo > 1e-12:
            a[i][i], a[i][2] = 1.0 / (hi - lo), -lo / (hi - lo)
    return _uv_affine(ctx, s, k, "normalizeUV()", (tuple(a[0]), tuple(a[1])))
