"""Scope transformations: t, r, s, center."""
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
