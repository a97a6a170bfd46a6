"""The statements `learn` writes, as IR nodes: numbers rounded as the grammar text holds them,
placements, `part` statements and example names (learn.py decides what to write)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..ir.expr import Call, Num, Str
from ..ir.tiling import PartDef, Placement
from .assembly import Assembly
from .rules import euler_degrees

_DIGITS = 4


def _num(x: float) -> Num:
    v = round(float(x), _DIGITS)
    return Num(value=0.0 if v == 0 else v)


def _placement(t: np.ndarray, R: np.ndarray) -> Placement:
    rot = euler_degrees(R)
    rot_node = None if all(abs(round(a, 2)) < 1e-9 for a in rot) else tuple(_num(round(a, 2)) for a in rot)
    return Placement(at=tuple(_num(x) for x in t), rot=rot_node)


def _dir_text(u: np.ndarray) -> str:
    k = int(np.argmax(np.abs(u)))
    if abs(abs(u[k]) - 1.0) < 1e-9:
        return ("+" if u[k] > 0 else "-") + "xyz"[k]
    return "(" + ", ".join(f"{x:.4g}" for x in u) + ")"


def _part_def(ptype: str, asms: list[Assembly], paths: list[str | None], ti: "Any",
              up: np.ndarray | None) -> PartDef:
    """`part T = mesh("example.glb", "T.0") symmetry(zN) [up(...)]` naming the first example
    part of type T, or for in-memory examples without a file a `box(w, d, h)` of that part's
    local bounding box."""
    for asm, path in zip(asms, paths):
        for p in asm.parts:
            if p.type != ptype:
                continue
            if ti.free:
                return PartDef(name=ptype, geometry=Call(func="box", args=tuple(_num(x) for x in ti.extents)),
                               up_any=True)
            symmetry = "none" if ti.orders[0] <= 1 else f"z{ti.orders[0]}"
            ups: tuple = ()
            if len(ti.ups) > 1 or (up is not None and not np.allclose(ti.ups[0], up)):
                ups = tuple(tuple(_num(x) for x in u) for u in ti.ups)
            if path is not None:
                geometry = Call(func="mesh", args=(Str(value=Path(path).as_posix()), Str(value=p.id)))
            else:
                geometry = Call(func="box", args=tuple(_num(x) for x in ti.extents))
            return PartDef(name=ptype, geometry=geometry, symmetry=symmetry, up=ups)
    raise AssertionError(ptype)  # every learned type comes from some part


def _identifier(text: str, used: set[str]) -> str:
    base = "".join(c if c.isalnum() or c == "_" else "_" for c in text) or "example"
    if base[0].isdigit():
        base = "_" + base
    name, k = base, 2
    while name in used:
        name, k = f"{base}_{k}", k + 1
    used.add(name)
    return name
