"""Mass operations: extrude, split, splitArea, comp, offset, taper, roofPyramid, NIL."""
from __future__ import annotations

from lark import Tree

from ....ir import (
    Arg,
    Nil,
    OpCall,
    Ref,
    Repeat,
)
from ... import frames
from ...expressions import Untranslatable, translate_expr
from ..context import (
    HandlerContext,
    axis_name,
    need,
    register,
)


@register("extrude")
def _h_extrude(h: HandlerContext):
    if len(h.args) == 1:
        return [OpCall(name="extrude", args=(Arg(value=translate_expr(h.args[0], h.ctx)),), span=h.span)], None
    if len(h.args) == 2:
        how = axis_name(h.args[0]) or "an axis"
        call = OpCall(name="extrude", args=(Arg(value=translate_expr(h.args[1], h.ctx)),), span=h.span)
        # along the face normal anyway: face.normal (the default), vertex.normal (a planar
        # face's vertex normals are its normal), and world.y / world.up (.flatTop) on a lot or
        # a face of it (frame Y: grammarkit lots are flat, their normal is the world's up)
        if how in ("face.normal", "vertex.normal") or (
                h.frame == "Y" and how in ("world.y", "world.up", "world.up.flatTop")):
            return [call], None
        return [call], ("extrude:axis", f"extrusion along {how} is made along the face normal")
    raise Untranslatable("op:extrude/" + str(len(h.args)), "extrude() with these arguments", h.span)


@register("split")
def _h_split(h: HandlerContext):
    if h.block is None:
        raise Untranslatable("op:split", "split() without a block", h.span)
    a = axis_name(h.args[0]) if h.args else None
    if a not in ("x", "y", "z"):
        raise Untranslatable("split:axis", f"split axis {a!r}", h.span)
    gk_axis, reverse = frames.axis(h.frame, a)
    items = h.t.split_entries(h.block, h.frame, h.rctx, h.ctx)
    if h.star:
        items = [Repeat(items=tuple(items), span=h.span)]
    if reverse:
        items = _reversed(items)
    call = OpCall(name="split", args=(Arg(value=Ref(name=gk_axis)),), block=tuple(items), span=h.span)
    if len(h.args) > 1:
        return [call], ("split:adjust", "split options after the axis (adjustment, unit space) are "
                        "ignored")
    return [call], None


def _reversed(items: list) -> list:
    out = []
    for it in reversed(items):
        if isinstance(it, Repeat):
            it = it.model_copy(update={"items": tuple(_reversed(list(it.items)))})
        out.append(it)
    return out


@register("comp")
def _h_comp(h: HandlerContext):
    """comp(f) (faces; after offset() its inside/border parts), comp(e) and comp(v), and
    comp(fe) (face edges, with comp(e)'s selectors)."""
    mode = axis_name(h.args[0]) if h.args else None
    if h.block is None:
        raise Untranslatable("op:comp", "comp() without a block", h.span)
    if mode == "fe" and len(h.args) == 1:
        entries = h.t.comp_entries(h.block, h.frame, h.rctx, "components")
        if not entries:
            raise Untranslatable("comp:no-selector", "none of its selectors is supported", h.span)
        return [OpCall(name="comp", args=(Arg(value=Ref(name="fe")),), block=tuple(entries), span=h.span)], None
    selectors = {e.children[0].children[0].children[0].value for e in h.block.children
                 if e.data in ("entry", "merged_entry") and isinstance(e.children[0].children[0], Tree)
                 and e.children[0].children[0].data == "ref"}
    prev = h.out[-1] if h.out else None
    if mode == "f" and selectors and selectors <= {"inside", "border"} and isinstance(prev, OpCall) \
            and prev.name == "offset" and prev.block is None:
        entries = h.t.comp_entries(h.block, h.frame, h.rctx, "offset-parts")
        h.out.pop()
        return [prev.model_copy(update={"block": tuple(entries)})], None
    if mode in ("e", "v"):
        entries = h.t.comp_entries(h.block, h.frame, h.rctx, "components")
        if not entries:
            raise Untranslatable("comp:no-selector", "none of its selectors is supported", h.span)
        return [OpCall(name="comp", args=(Arg(value=Ref(name=mode)),), block=tuple(entries), span=h.span)], None
    if mode != "f":
        raise Untranslatable(f"op:comp({mode})", f"comp({mode}) is not supported (only comp(f), comp(e), "
                             "comp(v))", h.span)
    entries = h.t.comp_entries(h.block, h.frame, h.rctx, "faces")
    if not entries:
        raise Untranslatable("comp:no-selector", "none of its selectors is supported", h.span)
    return [OpCall(name="comp", args=(Arg(value=Ref(name="f")),), block=tuple(entries), span=h.span)], None


@register("offset")
def _h_offset(h: HandlerContext):
    need(h.args, 1, 1, "offset", h.span)
    d = translate_expr(h.args[0], h.ctx)
    if h.block is not None:
        entries = h.t.comp_entries(h.block, h.frame, h.rctx, "offset-parts")
        return [OpCall(name="offset", args=(Arg(value=d),), block=tuple(entries), span=h.span)], None
    return [OpCall(name="offset", args=(Arg(value=d),), span=h.span)], None


@register("roofPyramid")
def _h_roof_pyramid(h: HandlerContext):
    """roofPyramid([byAngle,] angle); the other roofs are in roofs.py."""
    args = h.args
    if args and axis_name(args[0]) in ("byHeight", "byAngle"):
        if axis_name(args[0]) == "byHeight":
            raise Untranslatable("roofPyramid:byHeight", "roofPyramid(byHeight, ...) is not supported", h.span)
        args = args[1:]
    if not args:
        raise Untranslatable("op:roofPyramid", "roofPyramid() without an angle", h.span)
    call = OpCall(name="roofPyramid", args=(Arg(value=translate_expr(args[0], h.ctx)),), span=h.span)
    if len(args) > 1:
        return [call], ("roofPyramid:options", "extra arguments are ignored")
    return [call], None


@register("taper")
def _h_taper(h: HandlerContext):
    need(h.args, 1, 1, "taper", h.span)
    return [OpCall(name="taper", args=(Arg(value=translate_expr(h.args[0], h.ctx)),), span=h.span)], None


@register("NIL")
def _h_nil_op(h: HandlerContext):
    return [Nil(span=h.span)], None


# -- splitArea -----------------------------------------------------------------------------------
@register("splitArea")
def _h_split_area(h: HandlerContext):
    """`splitArea(axis[, adjustMode]) { area: A | ... }*`: split's entries, in area units; the
    axis mapped per frame as split's (CGA's z on a lot is grammarkit's y, parts reversed)."""
    if h.block is None:
        raise Untranslatable("op:splitArea", "splitArea() without a block", h.span)
    need(h.args, 1, 2, "splitArea", h.span)
    a = axis_name(h.args[0])
    if a not in ("x", "y", "z"):
        raise Untranslatable("splitArea:axis", f"splitArea axis {a!r}", h.span)
    gk_axis, reverse = frames.axis(h.frame, a)
    if gk_axis == "z":
        raise Untranslatable("splitArea:axis", f"splitArea({a}) across the face (its normal)", h.span)
    call_args: list = [Arg(value=Ref(name=gk_axis))]
    if len(h.args) == 2:
        mode = axis_name(h.args[1])
        if mode not in ("adjust", "noAdjust"):
            raise Untranslatable("splitArea:adjust", f"splitArea adjust mode {mode!r}", h.span)
        if mode == "noAdjust":
            call_args.append(Arg(name="adjust_mode", value=Ref(name=mode)))
    items = h.t.split_entries(h.block, h.frame, h.rctx, h.ctx)
    if h.star:
        items = [Repeat(items=tuple(items), span=h.span)]
    if reverse:
        items = _reversed(items)
    return [OpCall(name="splitArea", args=tuple(call_args), block=tuple(items), span=h.span)], None

