"""`comp(f)`, `comp(e)`, `comp(fe)`, `comp(v)`: a shape's faces, edges or vertices as shapes
of their own (CGA semantics). The faces are found by grammarkit.split.ops.faces (whose
docstring says what comp(f) decomposes and how it names the faces), the edges and vertices by
grammarkit.split.ops.comp_edges.
"""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import Shape
from .comp_edges import op_comp_edges, op_comp_face_edges, op_comp_vertices
from .faces import faces_of
from .helpers import operation

FACE_SELECTORS = ("top", "bottom", "side", "front", "back", "left", "right", "all")
# "<index>" stands for the integer selectors 0, 1, ...
COMP_SELECTORS = FACE_SELECTORS + ("vertical", "horizontal", "aslant", "nutant", "volume", "<index>",
                                   # comp(e) / comp(v) (grammarkit/split/ops/comp_edges.py)
                                   "border", "inside", "eave", "ridge", "hip", "valley")


@operation("comp", (Param("mode", "axis", choices=("f", "e", "fe", "v")),), block="selectors",
           selectors=COMP_SELECTORS,
           doc="Decompose a shape into its faces (f), edges (e), face edges (fe) or vertices (v) (the shape is "
               "consumed unless `volume:` keeps it); selectors by orientation, `all`, an index, "
               "`volume`; for edges also `border`, `inside`, `eave`, `ridge`, `hip`, `valley`.")
def op_comp(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    mode = str(args[0])
    if mode in ("e", "fe", "v"):  # edges, face edges, vertices (grammarkit/split/comp_edges.py)
        fn = {"e": op_comp_edges, "fe": op_comp_face_edges, "v": op_comp_vertices}[mode]
        out = fn(ctx, s, args, block)
        for slot in block:
            if slot.sel == "volume":
                out.append((s.copy(), slot, 0, 1))
                break
        return out
    if mode != "f":
        raise ValueError(f"comp({mode}) is not supported")
    parts = faces_of(s)
    total = len(parts)
    out = []
    for idx, (sel, face) in enumerate(parts):
        for slot in block:
            k = slot.sel
            if k == idx if type(k) is int else k in sel:
                out.append((face, slot, idx, total))
                break
    for slot in block:
        if slot.sel == "volume":
            out.append((s.copy(), slot, 0, 1))
            break
    return out
