"""Lot and shape operations: setback*, shapeL/U/O, innerRectangle, scatter; report, print, label..."""
from __future__ import annotations

from typing import Any

from lark import Token, Tree

from ....ir import (
    Arg,
    Branch,
    Num,
    OpCall,
    Ref,
    Seq,
    Terminal,
)
from ...expressions import Untranslatable, call_args, translate_expr
from ..context import (
    HandlerContext,
    axis_name,
    need,
    register,
)
from .roofs import comp_fe_values, is_comp_fe


# -- lots (grammarkit/split/ops/lots.py) --------------------------------------------------------------
def _h_setback(gk: str):
    def handler(h: HandlerContext):
        if h.block is None:
            raise Untranslatable(f"op:{gk}", f"{gk}() without a block", h.span)
        need(h.args, 1, 2, gk, h.span)
        dist_tree = h.args[0]
        op = gk
        # setback(comp(fe) { all: expr }) is CGA's long form of setbackPerEdge(expr)
        if isinstance(dist_tree, Tree) and dist_tree.data == "func_block_call":
            inner = _comp_fe_all(dist_tree) if gk == "setback" else None
            if inner is None and gk == "setback" and is_comp_fe(dist_tree):
                # comp(fe) { front: 3 | all: 0 }: per edge, the first entry that takes it
                notes: list = []
                d = comp_fe_values(dist_tree, h.frame, h.ctx, h.span, notes)
                return _setback_call(h, "setbackPerEdge", d, notes)
            if inner is None:
                raise Untranslatable("setback:array", "per-edge distances other than "
                                     "comp(fe) { ... }", h.span)
            op, dist_tree = "setbackPerEdge", inner
        return _setback_call(h, op, translate_expr(dist_tree, h.ctx), [])
    return handler


def _setback_call(h: HandlerContext, op: str, d: Any, notes: list):
    entries = h.t.comp_entries(h.block, h.frame, h.rctx, "edges")
    if not entries:
        raise Untranslatable("setback:no-selector", "none of its selectors is supported", h.span)
    call = OpCall(name=op, args=(Arg(value=d),), block=tuple(entries), span=h.span)
    if len(h.args) == 2 and not notes:
        return [call], (f"{h.name}:uvSet", "the uv set of uv selectors is ignored")
    if len(h.args) == 2:
        notes = notes + ["the uv set of uv selectors is ignored"]
    if notes:
        return [call], (f"{h.name}:options", "; ".join(dict.fromkeys(notes)))
    return [call], None


for _gk in ("setback", "setbackPerEdge", "setbackToArea"):
    register(_gk)(_h_setback(_gk))


def _comp_fe_all(tree: Tree) -> Any:
    """The expression of `comp(fe) { all: expr }` (CGA's comp function), or None."""
    name = next((c.value for c in tree.children if isinstance(c, Token)), None)
    args = call_args(tree)
    block = next((c for c in tree.children if isinstance(c, Tree) and c.data in ("block", "fblock")), None)
    if name != "comp" or len(args) != 1 or axis_name(args[0]) != "fe" or block is None:
        return None
    entries = [e for e in block.children if isinstance(e, Tree)]
    if len(entries) != 1 or entries[0].data not in ("entry", "merged_entry"):
        return None
    key = entries[0].children[0].children[0]
    if not (isinstance(key, Tree) and key.data == "ref" and key.children[0].value == "all"):
        return None
    body = entries[0].children[-1]
    if isinstance(body, Tree) and body.data == "entry_body":
        if len(body.children) != 1 or not isinstance(body.children[0], Tree):
            return None
        body = body.children[0]
    # the entry was parsed as a rule body: its one item read back as an expression
    if body.data == "call":
        return Tree("func_call", body.children)
    if body.data == "name":
        return Tree("ref", body.children)
    return body


def _h_shape_op(gk: str, n: int):
    def handler(h: HandlerContext):
        if h.block is None:
            raise Untranslatable(f"op:{gk}", f"{gk}() without a block", h.span)
        need(h.args, n, n, gk, h.span)
        entries = h.t.comp_entries(h.block, h.frame, h.rctx, "shape-parts")
        if not entries:
            raise Untranslatable(f"{gk}:no-selector", "none of its selectors is supported", h.span)
        args = [translate_expr(a, h.ctx) for a in h.args]
        if h.frame != "Y":
            # CGA classifies the edges' outward normals into the scope's quadrants; on a face
            # of a volume (frame Z: the scope's z is the face normal) no edge is front or back
            # (CGA's shapeX is setback(comp(fe) { front = f | ... })), grammarkit's faces call
            # their -y/+y edges front/back too, so those wings get no width
            args = [Num(value=0) if side in ("front", "back") else a for side, a in zip(_SHAPE_SIDES[gk], args)]
        return [OpCall(name=gk, args=tuple(Arg(value=a) for a in args), block=tuple(entries), span=h.span)], None
    return handler


_SHAPE_SIDES = {"shapeL": ("front", "left"), "shapeU": ("front", "right", "left"),
                "shapeO": ("front", "right", "back", "left")}


for _gk, _n in (("shapeL", 2), ("shapeU", 3), ("shapeO", 4)):
    register(_gk)(_h_shape_op(_gk, _n))



@register("label")
def _h_label(h: HandlerContext):
    need(h.args, 1, 1, "label", h.span)
    name = translate_expr(h.args[0], h.ctx)
    return [OpCall(name="label", args=(Arg(value=name),), span=h.span)], None


@register("innerRectangle")
def _h_inner_rectangle(h: HandlerContext):
    if h.block is None:
        raise Untranslatable("op:innerRectangle", "innerRectangle without a block", h.span)
    need(h.args, 0, 1, "innerRectangle", h.span)
    mode = axis_name(h.args[0]) if h.args else "scope"
    if mode not in ("scope", "edge"):
        raise Untranslatable("innerRectangle:align", f"innerRectangle({mode})", h.span)
    entries = h.t.comp_entries(h.block, h.frame, h.rctx, "shape-parts")
    if not entries:
        raise Untranslatable("innerRectangle:no-selector", "none of its selectors is supported", h.span)
    return [OpCall(name="innerRectangle", args=(Arg(value=Ref(name=mode)),), block=tuple(entries), span=h.span)], None


_SCATTER_MEANS = ("center", "front", "back", "left", "right", "top", "bottom")


@register("scatter")
def _h_scatter(h: HandlerContext):
    """`scatter(domain, n, uniform|gaussian [, mean, stddev]) { Rule }` -> `{ all: Rule }`."""
    need(h.args, 3, 5, "scatter", h.span)
    domain, dist = axis_name(h.args[0]), axis_name(h.args[2])
    if domain not in ("surface", "volume", "scope"):
        raise Untranslatable("scatter:domain", f"scatter domain {domain!r}", h.span)
    if dist not in ("uniform", "gaussian"):
        raise Untranslatable("scatter:distribution", f"scatter distribution {dist!r}", h.span)
    entries = [e for e in (h.block.children if h.block is not None else ()) if isinstance(e, Tree)]
    if len(entries) != 1 or entries[0].data not in ("bare_entry", "bare_name_entry", "seq_entry"):
        raise Untranslatable("scatter:block", "scatter needs a block of one entry { ops Rule }", h.span)
    e = entries[0]
    # { Rule }, { Rule(args) } or a sequence of operations and calls { t(0, 0, 1) Tree }
    items = list(e.children) if e.data == "seq_entry" else [
        Tree("call" if e.data == "bare_entry" else "name", e.children)]
    # CGA turns a point's y (its up axis) to the surface normal, grammarkit its z: CGA's y-up
    # frame (Y); in a volume or the scope the points keep the shape's axes and frame
    body = h.t.body_items(items, "Y" if domain == "surface" else h.frame, h.rctx) or [Terminal(name=h.rctx.gk, span=h.span)]
    call_args = [Arg(value=Ref(name=domain)), Arg(value=translate_expr(h.args[1], h.ctx)), Arg(value=Ref(name=dist))]
    approx = None
    if len(h.args) >= 4:
        mean = axis_name(h.args[3])
        if mean not in _SCATTER_MEANS:
            raise Untranslatable("scatter:mean", f"scatter mean {mean!r}", h.span)
        # CGA's scope sides in grammarkit's: frame Y maps CGA's +y (top) to +z and CGA's +z
        # (front) to -y, so the names agree; in frame Z (axes as they are) CGA's front is +z
        if h.frame != "Y":
            mean = {"front": "top", "back": "bottom", "top": "back", "bottom": "front"}.get(mean, mean)
        call_args.append(Arg(value=Ref(name=mean)))
    if len(h.args) == 5:
        sd = h.args[4]
        if isinstance(sd, Tree) and sd.data == "rel":
            call_args.append(Arg(value=translate_expr(sd.children[0], h.ctx)))
        else:  # an absolute stddev (metres): relative to the scope's largest size
            def size(a: str) -> Tree:
                return Tree("ref", [Token("NAME", f"scope.s{a}")])

            largest = Tree("func_call", [Token("NAME", "max"), Tree("args", [size("x"), Tree(
                "func_call", [Token("NAME", "max"), Tree("args", [size("y"), size("z")])])])])
            call_args.append(Arg(value=translate_expr(Tree("binop", [sd, Token("SLASH", "/"), largest]), h.ctx)))
            approx = ("scatter:stddev", "an absolute stddev is made relative to the scope's largest "
                      "size (grammarkit's stddev is relative, per axis)")
    return [OpCall(name="scatter", args=tuple(call_args), block=(Branch(key=Ref(name="all"), body=Seq(
        items=tuple(body)), span=h.span),), span=h.span)], approx




@register("report")
def _h_report(h: HandlerContext):
    need(h.args, 2, 2, "report", h.span)
    key, value = translate_expr(h.args[0], h.ctx), translate_expr(h.args[1], h.ctx)
    return [OpCall(name="report", args=(Arg(value=key), Arg(value=value)), span=h.span)], None


@register("print")
def _h_print(h: HandlerContext):
    need(h.args, 1, 1, "print", h.span)
    return [OpCall(name="print", args=(Arg(value=translate_expr(h.args[0], h.ctx)),), span=h.span)], None


@register("convexify")
def _h_convexify(h: HandlerContext):
    need(h.args, 0, 1, "convexify", h.span)
    return [OpCall(name="convexify", args=tuple(Arg(value=translate_expr(a, h.ctx)) for a in h.args), span=h.span)], None


@register("reverseNormals")
def _h_reverse_normals(h: HandlerContext):
    need(h.args, 0, 0, "reverseNormals", h.span)
    return [OpCall(name="reverseNormals", span=h.span)], None

