"""Scope transformations: t, r, rotate (CGA's, in any coordinate system), s, center."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import AXIS, EPS, number, operation, rotation
from .texturing import moved


@operation("t", (Param("x"), Param("y"), Param("z")), doc="Translate the scope (scope axes).")
def op_t(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    x, y, z = (number(v, "t()") for v in args[:3])
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


@operation("r", (Param("x"), Param("y"), Param("z")), doc="Rotate the scope (degrees, XYZ).")
def op_r(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    rx, ry, rz = (number(v, "r()") for v in args[:3])
    R = rotation(rx, ry, rz)
    # new axis j = sum_i R[i][j] * old axis i  (the rotation is expressed in scope coordinates)
    return _turned(s, _rotated_frame(R, s.ax), bool(rx or ry or rz))


def _rotated_frame(R: tuple, frame: tuple) -> tuple:
    """The axes (world vectors) `R` makes of `frame`'s: axis j = sum_i R[i][j] * frame axis i."""
    return tuple(tuple(sum(R[i][j] * frame[i][k] for i in range(3)) for k in range(3)) for j in range(3))


def _turned(s: Shape, new: tuple, changed: bool) -> Shape:
    """The shape with its scope (and the geometry, held in scope coordinates) turned to the
    axes `new` about the scope origin."""
    ax = s.ax
    c = s
    c.ax = new  # type: ignore[assignment]
    if c.on is not None and changed:
        c.on = None  # a turned face is no longer a view of its volume's boundary
    if c.tex is not None:
        moved(c, c.o, ax)
    return c


WORLD_FRAME = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
ROTATE_SYSTEMS = ("scope", "pivot", "object", "world")


@operation("rotate", (Param("mode", "axis", choices=("abs", "rel")),
                      Param("system", "axis", choices=ROTATE_SYSTEMS),
                      Param("x"), Param("y"), Param("z")),
           doc="CGA's rotate(mode, coordSystem, x, y, z): turn the scope about its origin by angles "
               "(degrees, x first) given in the scope's, the pivot's, the object's or the world's axes; "
               "rel adds them to the scope's orientation, abs sets it to them.")
def op_rotate(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    mode, system = str(args[0]), str(args[1])
    if mode not in ("abs", "rel"):
        raise ValueError(f"rotate(): mode must be abs or rel, got {mode!r}")
    if system not in ROTATE_SYSTEMS:
        raise ValueError(f"rotate(): the coordinate system must be one of {', '.join(ROTATE_SYSTEMS)}, "
                         f"got {system!r}")
    rx, ry, rz = (number(v, "rotate() angle") for v in args[2:5])
    R = rotation(rx, ry, rz)
    # the initial shape's frame (CGA's object and default pivot) is the world's: grammarkit's
    # lots are given in world coordinates and nothing moves the pivot
    frame = s.ax if system == "scope" else WORLD_FRAME
    if mode == "abs":
        # the orientation relative to the system is set to R (for the scope system, the scope's
        # own orientation is the identity, so abs and rel agree)
        return _turned(s, _rotated_frame(R, frame), True)
    if system == "scope":
        return _turned(s, _rotated_frame(R, s.ax), bool(rx or ry or rz))
    # relative in a fixed frame F (rows: its axes): the world rotation W = F^T R F turns every axis
    W = [[sum(frame[i][a] * R[i][j] * frame[j][b] for i in range(3) for j in range(3)) for b in range(3)]
         for a in range(3)]
    new = tuple(tuple(sum(W[k][m] * axis[m] for m in range(3)) for k in range(3)) for axis in s.ax)
    return _turned(s, new, bool(rx or ry or rz))


@operation("s", (Param("x"), Param("y"), Param("z")), doc="Set the scope size.")
def op_s(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    new = tuple(number(v, "s()") for v in args[:3])
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


@operation("center", (Param("axes", "axis", required=False, default="xyz",
                           choices=("x", "y", "z", "xy", "xz", "yz", "xyz")),),
           doc="Center the scope in its parent's scope along the given axes.")
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
