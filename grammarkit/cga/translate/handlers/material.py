"""Colour, material and texturing: color, set, setupProjection, projectUV, tileUV, texture..."""
from __future__ import annotations

import re
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
    Unary,
)
from ....printer import format_expr
from ... import frames
from ...expressions import ExprContext, Untranslatable, translate_expr
from ..context import (
    HandlerContext,
    axis_name,
    known_file_name,
    literal_number,
    need,
    register,
    rel_or_abs,
)


def _hex(v: float) -> str:
    return f"{max(0, min(255, round(v * 255))):02x}"


@register("color")
def _h_color(h: HandlerContext):
    values = [translate_expr(a, h.ctx) for a in h.args]
    if len(values) == 1:
        v = values[0]
        if isinstance(v, Str):
            text = v.value.strip()
            if re.fullmatch(r"#[0-9A-Fa-f]{3}", text):
                text = "#" + "".join(c * 2 for c in text[1:])
            if not re.fullmatch(r"#[0-9A-Fa-f]{6}", text):
                raise Untranslatable("color:format", f"colour {text!r} is not #rrggbb", h.span)
            return [OpCall(name="color", args=(Arg(value=Str(value=text.lower())),), span=h.span)], None
        return [OpCall(name="color", args=(Arg(value=v),), span=h.span)], None
    if len(values) in (3, 4) and all(isinstance(v, Num) for v in values):
        text = "#" + "".join(_hex(v.value) for v in values[:3])
        call = OpCall(name="color", args=(Arg(value=Str(value=text)),), span=h.span)
        return [call], (("color:alpha", "the opacity is ignored") if len(values) == 4 else None)
    raise Untranslatable("color:rgb-expr", "color(r, g, b) from expressions (not constants)", h.span)


@register("set")
def _h_set(h: HandlerContext):
    target = axis_name(h.args[0]) if h.args else None
    if target == "material.name" and len(h.args) == 2:
        return [OpCall(name="material", args=(Arg(value=translate_expr(h.args[1], h.ctx)),), span=h.span)], None
    if target in ("material.color.rgb",) and len(h.args) == 2:
        return _h_color(h.t, h.args[1:], h.block, h.star, h.frame, h.rctx, h.ctx, h.span, h.out)
    if target in ("trim.vertical", "trim.horizontal") and len(h.args) == 2:
        value = translate_expr(h.args[1], h.ctx)
        if target == "trim.vertical":
            return [OpCall(name="trim", args=(Arg(value=value),), span=h.span)], None
        # grammarkit makes vertical trim planes only: turning horizontal ones off changes nothing
        if isinstance(value, Bool) and not value.value:
            return [], None
        return [], ("set(trim.horizontal)", "grammarkit makes no horizontal trim planes")
    if target and target.startswith("material.") and len(h.args) == 2:
        value = translate_expr(h.args[1], h.ctx)
        if target.endswith("map"):
            known = value.value if isinstance(value, Str) else known_file_name(h.t, value)
            if known:
                h.t.asset(known, h.span, computed=not isinstance(value, Str))
            elif not isinstance(value, Str):
                h.t.computed_asset(format_expr(value), h.span)
        return [OpCall(name="set", args=(Arg(value=Ref(name=target)), Arg(value=value)), span=h.span)], None
    if target and len(h.args) == 2:
        kinds = {v.name: v.kind for v in h.t.values}
        if kinds.get(target) == "attr":
            value = translate_expr(h.args[1], h.ctx)
            return [OpCall(name="set", args=(Arg(value=Ref(name=h.t.value_names[target])), Arg(value=value)),
                           span=h.span)], None
        if kinds.get(target) == "const":
            raise Untranslatable("op:set(const)", f"set({target}, ...) of a const", h.span)
    raise Untranslatable("op:set", f"set({target}, ...): only attrs of this file can be set", h.span)



# -- texturing (grammarkit/split/ops/texturing.py) -----------------------------------------------------
# A CGA axis letter of setupProjection -> (grammarkit letter, reversed). World axes are y-up in
# CGA and z-up in grammarkit, as the lot's scope (frame Y); a face's scope is the identity.
def _projection_axis(frame: str, world: bool, letter: str) -> tuple[str, bool]:
    return frames.axis("Y" if world else frame, letter)


def _texture_size(tree: Any, size_ref: str, ctx: ExprContext) -> Any:
    """A texture width/height: `'v` is v times the scope size along that axis, `~v` the size
    nearest to v that fits a whole number of times into the scope (CGA's floating size)."""
    if isinstance(tree, Tree) and tree.data == "floating":
        v = translate_expr(tree.children[-1], ctx)
        size = Ref(name=size_ref)
        count = Call(func="max", args=(Num(value=1), Call(func="round", args=(Binary(op="/", left=size, right=v),))))
        return Binary(op="/", left=size, right=count)
    return rel_or_abs(tree, size_ref, ctx)


def _negated(e: Any) -> Any:
    return Num(value=-e.value) if isinstance(e, Num) else Unary(op="-", operand=e)


@register("setupProjection")
def _h_setup_projection(h: HandlerContext):
    need(h.args, 4, 7, "setupProjection", h.span)
    axes = axis_name(h.args[1]) or ""
    origin, _, pair = axes.partition(".")
    if origin not in ("scope", "world") or len(pair) != 2 or any(c not in "xyz" for c in pair) or pair[0] == pair[1]:
        raise Untranslatable("setupProjection:axes", f"projection axes {axes!r}", h.span)
    world = origin == "world"
    uv_set = translate_expr(h.args[0], h.ctx)
    letters, sizes, offs = [], [], []
    for k, letter in enumerate(pair):
        gk, rev = _projection_axis(h.frame, world, letter)
        size = _texture_size(h.args[2 + k], "scope.s" + gk, h.ctx)
        off = rel_or_abs(h.args[4 + k], "scope.s" + gk, h.ctx) if len(h.args) > 4 + k else Num(value=0)
        if rev:
            # CGA's coordinate along this axis is -(grammarkit's) (world) or sy - y (a lot's
            # scope: CGA's z runs from the back): the same tiles with a mirrored size
            size = _negated(size)
            off = _negated(off) if world else Binary(op="-", left=Ref(name="scope.s" + gk), right=off)
        letters.append(gk)
        sizes.append(size)
        offs.append(off)
    call_args_ = [Arg(value=uv_set), Arg(value=Ref(name=f"{origin}.{letters[0]}{letters[1]}")),
                  Arg(value=sizes[0]), Arg(value=sizes[1])]
    if not all(isinstance(o, Num) and o.value == 0 for o in offs):
        call_args_ += [Arg(value=offs[0]), Arg(value=offs[1])]
    call = OpCall(name="setupProjection", args=tuple(call_args_), span=h.span)
    if len(h.args) == 7 and literal_number(h.args[6]) != 0:
        return [call], ("setupProjection:uwFactor", "the w texture coordinate (uwFactor) is not made")
    return [call], None


def _uv_op(gk: str, lo: int, hi: int):
    def handler(h: HandlerContext):
        need(h.args, lo, hi, gk, h.span)
        return [OpCall(name=gk, args=tuple(Arg(value=translate_expr(a, h.ctx)) for a in h.args), span=h.span)], None
    return handler


for _gk, _lo, _hi in (("projectUV", 1, 1), ("translateUV", 3, 3), ("scaleUV", 3, 3), ("rotateUV", 2, 2),
                      ("deleteUV", 1, 1)):
    register(_gk)(_uv_op(_gk, _lo, _hi))


@register("tileUV")
def _h_tile_uv(h: HandlerContext):
    """`tileUV(k, w, h)`; `~w` and `'w` are taken over the scope's x (u) and y (v) sizes, as
    setupProjection's are (CGA measures the uv extent of the geometry: the same for a
    projection along the scope's axes)."""
    need(h.args, 3, 3, "tileUV", h.span)
    sizes = [_texture_size(a, f"scope.s{c}", h.ctx) for a, c in zip(h.args[1:], "xy")]
    approx = None
    if any(isinstance(a, Tree) and a.data in ("floating", "rel") for a in h.args[1:]):
        approx = ("tileUV:relative", "~ and ' tile sizes are measured over the scope's x and y sizes "
                  "(CGA: over the uv extent of the geometry)")
    return [OpCall(name="tileUV", args=(Arg(value=translate_expr(h.args[0], h.ctx)), *(Arg(value=v) for v in sizes)),
                   span=h.span)], approx


@register("normalizeUV")
def _h_normalize_uv(h: HandlerContext):
    need(h.args, 3, 3, "normalizeUV", h.span)
    which, mode = axis_name(h.args[1]), axis_name(h.args[2])
    if which not in ("uv", "u", "v") or mode not in ("separatePerFace", "collectiveAllFaces"):
        raise Untranslatable("normalizeUV:args", f"normalizeUV(.., {which}, {mode})", h.span)
    approx = None
    if mode == "separatePerFace":
        approx = ("normalizeUV:separatePerFace", "separatePerFace normalises over the whole shape (exact "
                  "for a face; a volume's faces together)")
    return [OpCall(name="normalizeUV", args=(Arg(value=translate_expr(h.args[0], h.ctx)), Arg(value=Ref(name=which)),
                                             Arg(value=Ref(name=mode))), span=h.span)], approx



@register("texture")
def _h_texture(h: HandlerContext):
    need(h.args, 1, 1, "texture", h.span)
    path = translate_expr(h.args[0], h.ctx)
    # a computed file name is evaluated at derive time (relative to the grammar's folder)
    known = path.value if isinstance(path, Str) else known_file_name(h.t, path)
    if known:
        h.t.asset(known, h.span, computed=not isinstance(path, Str))
    elif not isinstance(path, Str):
        h.t.computed_asset(format_expr(path), h.span)
    return [OpCall(name="texture", args=(Arg(value=path),), span=h.span)], None

