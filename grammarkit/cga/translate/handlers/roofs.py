"""CGA's roofGable, roofHip, roofShed with all their forms, and envelope()."""
from __future__ import annotations

import dataclasses
import math
from typing import Any

from lark import Tree

from ....ir import (
    Arg,
    Binary,
    Bool,
    Call,
    Num,
    OpCall,
    Ref,
    Str,
    Vector,
)
from ... import frames
from ...expressions import Untranslatable, translate_expr
from ..context import (
    HandlerContext,
    axis_name,
    need,
    register,
)


# -- roofs -------------------------------------------------------------------------------------
def _on_roof(overhang: Any, angle: Any) -> Any:
    """CGA measures a roof's overhang on the roof plane; grammarkit's is horizontal: o cos(a)."""
    if isinstance(overhang, Num) and overhang.value == 0:
        return overhang
    if isinstance(overhang, Num) and isinstance(angle, Num):
        return Num(value=overhang.value * math.cos(math.radians(angle.value)))
    return Binary(op="*", left=overhang, right=Call(func="cos", args=(angle,)))


def _roof_value(gk: str, args: list, ctx: Any, span: Any) -> tuple[Any, str, list]:
    """(angle or height, value type, the remaining CGA arguments)."""
    kind = axis_name(args[0]) if args else None
    if kind in ("byAngle", "byHeight"):
        if len(args) < 2:
            raise Untranslatable(f"op:{gk}", f"{gk}({kind}) without a value", span)
        return translate_expr(args[1], ctx), kind, args[2:]
    if not args:
        raise Untranslatable(f"op:{gk}", f"{gk}() without an angle", span)
    return translate_expr(args[0], ctx), "byAngle", args[1:]


def _even(tree: Any, ctx: Any) -> Arg | None:
    """CGA's `even` (grammarkit's even=: the ridge level, non-planar faces); false is the default."""
    value = translate_expr(tree, ctx)
    if isinstance(value, Bool) and value.value is False:
        return None
    return Arg(name="even", value=value)


def _overhang(value: Any, vt: str, angle: Any, notes: list) -> Any:
    if vt == "byAngle":
        return _on_roof(value, angle)
    if not (isinstance(value, Num) and value.value == 0):
        notes.append("with byHeight the overhang is taken as horizontal (CGA measures it on the roof)")
    return value


def _index_arg(tree: Any, ctx: Any, notes: list, gk: str) -> Arg | None:
    try:
        return Arg(name="index", value=translate_expr(tree, ctx))
    except Untranslatable as exc:
        notes.append(f"the edge index is not translated ({exc.message})")
        return None


def _roof_call(gk: str, value: Any, vt: str, named: list, span: Any, notes: list):
    call_args: list = [Arg(value=value), *named]
    if vt == "byHeight":
        call_args.append(Arg(name="value_type", value=Ref(name="byHeight")))
    call = OpCall(name=gk, args=tuple(call_args), span=span)
    return [call], ((f"{gk}:options", "; ".join(notes)) if notes else None)


@register("roofGable")
def _h_roof_gable(h: HandlerContext):
    """roofGable(angle, overhangX, overhangY, even, index) / (byHeight, h, overhangX, overhangY, even)."""
    value, vt, rest = _roof_value("roofGable", h.args, h.ctx, h.span)
    need(rest, 0, 4 if axis_name(h.args[0]) not in ("byAngle", "byHeight") else 3, "roofGable", h.span)
    notes: list = []
    named: list = []
    if len(rest) >= 1:
        named.append(Arg(name="overhang", value=_overhang(translate_expr(rest[0], h.ctx), vt, value, notes)))
    if len(rest) >= 2:
        named.append(Arg(name="overhang_y", value=_overhang(translate_expr(rest[1], h.ctx), vt, value, notes)))
    index = _index_arg(rest[3], h.ctx, notes, "roofGable") if len(rest) >= 4 else None
    if index is not None:  # CGA ignores even with an index
        named.append(index)
    elif len(rest) >= 3:
        e = _even(rest[2], h.ctx)
        if e is not None:
            named.append(e)
    if index is None:
        # CGA orients an unindexed gable itself (along the long sides of a rectangle), not
        # along a scope axis: grammarkit's ridge=auto
        named.append(Arg(name="ridge", value=Ref(name="auto")))
    return _roof_call("roofGable", value, vt, named, h.span, notes)


@register("roofHip")
def _h_roof_hip(h: HandlerContext):
    """roofHip(angle, overhang, even) / roofHip(byHeight, h, overhang, even)."""
    value, vt, rest = _roof_value("roofHip", h.args, h.ctx, h.span)
    need(rest, 0, 2, "roofHip", h.span)
    notes: list = []
    named: list = []
    if len(rest) >= 1:
        named.append(Arg(name="overhang", value=_overhang(translate_expr(rest[0], h.ctx), vt, value, notes)))
    if len(rest) >= 2:
        e = _even(rest[1], h.ctx)
        if e is not None:
            named.append(e)
    return _roof_call("roofHip", value, vt, named, h.span, notes)


@register("roofShed")
def _h_roof_shed(h: HandlerContext):
    """roofShed(angle, index) / roofShed(byHeight, h, index): the low edge is edge `index`
    (CGA's default: edge 0)."""
    value, vt, rest = _roof_value("roofShed", h.args, h.ctx, h.span)
    need(rest, 0, 1, "roofShed", h.span)
    notes: list = []
    index = _index_arg(rest[0], h.ctx, notes, "roofShed") if rest else Arg(name="index", value=Num(value=0.0))
    return _roof_call("roofShed", value, vt, [index] if index is not None else [], h.span, notes)




# -- envelope ------------------------------------------------------------------------------------
# grammarkit's edge selectors -> the side `comp.sel` names on a per-edge shape
# (grammarkit/split/ops/lots.py: edge_shape); "all" is every edge
_SEL_SIDES = {"front": ("front",), "bottom": ("front",), "back": ("back",), "top": ("back",),
              "left": ("left",), "right": ("right",), "side": ("left", "right"), "all": None}


def _entry_expr(body: Any) -> Any:
    """A comp-function entry's body (parsed as a rule body) read back as an expression tree:
    CGA's parser takes `front: attrName` and `front: f(x)` (items); a bare number is not an
    item there, so `front: 5` does not parse and never reaches here."""
    if isinstance(body, Tree) and body.data == "entry_body":
        if len(body.children) != 1 or not isinstance(body.children[0], Tree):
            return None
        body = body.children[0]
    if not isinstance(body, Tree):
        return None
    if body.data == "call":
        return Tree("func_call", body.children)
    if body.data == "name":
        return Tree("ref", body.children)
    return body  # an fblock entry: already an expression


def is_comp_fe(tree: Any) -> bool:
    if not (isinstance(tree, Tree) and tree.data == "func_block_call"):
        return False
    name = next((c.value for c in tree.children if not isinstance(c, Tree)), None)
    args = [c for c in tree.children if isinstance(c, Tree) and c.data == "args"]
    inner = [a for a in args[0].children if isinstance(a, Tree)] if args else []
    return name == "comp" and len(inner) == 1 and axis_name(inner[0]) == "fe"


def comp_fe_values(tree: Tree, frame: str, ctx: Any, span: Any, notes: list) -> Any:
    """CGA's comp function `comp(fe) { sel: v | ... }` (an array: for each face edge the value
    of the first entry whose selector takes it) as one expression evaluated per edge:
    `select(comp.sel == "front", v1, select(comp.index == 2, v2, ...))`."""

    block = next(c for c in tree.children if isinstance(c, Tree) and c.data in ("block", "fblock"))
    arms: list = []
    for entry in (e for e in block.children if isinstance(e, Tree)):
        if entry.data not in ("entry", "merged_entry"):  # `=` and `:` mean the same for values
            raise Untranslatable("envelope:comp-entry", "a comp(fe) function entry that is not `selector: value`", span)
        key = entry.children[0].children[0]
        value_tree = _entry_expr(entry.children[-1])
        if value_tree is None:
            raise Untranslatable("envelope:comp-entry", "a comp(fe) function entry whose value is not a "
                                 "name or a function call", span)
        value = translate_expr(value_tree, ctx)
        if isinstance(key, Tree) and key.data == "number":
            k = float(key.children[0].value)
            if not k.is_integer() or k < 0:
                raise Untranslatable("envelope:comp-selector", f"comp(fe) index {key.children[0].value}", span)
            arms.append((Binary(op="==", left=Ref(name="comp.index"), right=Num(value=k)), value))
            continue
        sel = axis_name(key)
        mapped, approx = frames.edge_selectors(frame, sel) if sel else (None, None)
        if mapped is None or any(m not in _SEL_SIDES for m in mapped):
            raise Untranslatable("envelope:comp-selector", f"comp(fe) selector {sel!r} in a per-edge value", span)
        if approx:
            notes.append(approx)
        sides: list = []
        for m in mapped:
            if _SEL_SIDES[m] is None:
                sides = None
                break
            sides.extend(_SEL_SIDES[m])
        if sides is None:
            arms.append((Bool(value=True), value))
            break  # `all` takes every edge: later entries are never reached
        if not sides:
            continue  # a selector that takes no edge here (CGA's top on a lot)
        cond = None
        for side in dict.fromkeys(sides):
            test = Binary(op="==", left=Ref(name="comp.sel"), right=Str(value=side))
            cond = test if cond is None else Binary(op="||", left=cond, right=test)
        arms.append((cond, value))
    if not arms or not (isinstance(arms[-1][0], Bool)):
        # CGA's comp function leaves edges no selector takes at the type's default (0)
        arms.append((Bool(value=True), Num(value=0.0)))
    out = arms[-1][1]
    for cond, value in reversed(arms[:-1]):
        out = Call(func="select", args=(cond, value, out))
    return out


def _per_edge_arg(tree: Any, frame: str, ctx: Any, span: Any, notes: list) -> Any:
    """A float[] argument of envelope: `comp(fe) { ... }`, an array literal `[a, b, c]`
    (grammarkit's tuple `(a, b, c)`), or any other expression (its value must be an array of
    one value per edge, or a number for every edge)."""
    if is_comp_fe(tree):
        return comp_fe_values(tree, frame, ctx, span, notes)
    if isinstance(tree, Tree) and tree.data == "array":
        rows = [c for c in tree.children if isinstance(c, Tree) and c.data == "args"]
        if len(rows) != 1:
            raise Untranslatable("envelope:array", "a 2-d array as per-edge values", span)
        return Vector(items=tuple(translate_expr(c, ctx) for c in rows[0].children))
    if isinstance(tree, Tree) and tree.data == "ref" and tree.children[0].value in ctx.array_names:
        # an attr or const holding the per-edge array: its items as the vector, when deriving
        array = translate_expr(tree, dataclasses.replace(ctx, operation_argument=False))
        return Call(func="cgaVector", args=(array,), span=span)
    return translate_expr(tree, ctx)


@register("envelope")
def _h_envelope(h: HandlerContext):
    """envelope(direction, maxHeight, frontBase, frontAngle [, backBase, backAngle [, sideBase,
    sideAngle | , rightBase, rightAngle, leftBase, leftAngle]]) -> envelope; street.* sides are
    the lot's front/back/right/left (grammarkit lots have no street attributes, as CGA's
    fallback). envelope(direction, maxHeight, baseHeights, angles) -> envelopePerEdge."""
    if len(h.args) not in (4, 6, 8, 10):
        raise Untranslatable(f"envelope:{len(h.args)}", f"envelope() with {len(h.args)} arguments", h.span)
    direction = axis_name(h.args[0])
    if direction not in ("normal", "world.up"):
        raise Untranslatable("envelope:direction", f"envelope direction {direction!r}", h.span)
    gk_direction = Arg(value=Ref(name="normal" if direction == "normal" else "worldUp"))
    per_edge = len(h.args) == 4 and any(is_comp_fe(a) or (isinstance(a, Tree) and a.data == "array")
                                      for a in h.args[2:])
    if per_edge:
        notes: list = []
        base = _per_edge_arg(h.args[2], h.frame, h.ctx, h.span, notes)
        angle = _per_edge_arg(h.args[3], h.frame, h.ctx, h.span, notes)
        call = OpCall(name="envelopePerEdge", args=(gk_direction, Arg(value=translate_expr(h.args[1], h.ctx)),
                                                    Arg(value=base), Arg(value=angle)), span=h.span)
        return [call], (("envelope:options", "; ".join(dict.fromkeys(notes))) if notes else None)
    if h.frame != "Y":
        # CGA classifies a face's edges in the object's frame (street.* falls back to object.*),
        # which a face of a volume does not have here: exact when every side has the same values
        bases, angles = h.args[2::2], h.args[3::2]
        if not (len(h.args) in (8, 10) and all(b == bases[0] for b in bases) and all(a == angles[0] for a in angles)):
            raise Untranslatable("envelope:face", "envelope() on a face of a volume with different values "
                                 "per side (CGA classifies its edges in the object's frame)", h.span)
    vals = [translate_expr(a, h.ctx) for a in h.args[1:]]
    max_height, rest = vals[0], vals[1:]
    if len(rest) == 6:  # front, back, side (both right and left)
        rest = rest + rest[4:6]
    names = ("front_base", "front_angle", "back_base", "back_angle", "right_base", "right_angle",
             "left_base", "left_angle")
    call_args = [gk_direction, Arg(value=max_height)]
    call_args += [Arg(name=n, value=v) for n, v in zip(names, rest)]
    return [OpCall(name="envelope", args=tuple(call_args), span=h.span)], (
        "envelope:street", "street.front/back/left/right are the lot's front/back/left/right edges "
        "(grammarkit lots have no street attributes)") if h.frame == "Y" else None

