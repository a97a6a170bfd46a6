"""Asset inserts: i() and the primitive operations."""
from __future__ import annotations

from typing import Any

from ....ir import (
    Arg,
    Binary,
    Call,
    Case,
    CaseArm,
    Num,
    OpCall,
    Ref,
    Seq,
    Str,
)
from ....ir.base import Span
from ....printer import format_expr
from ...expressions import Untranslatable, translate_expr
from ..context import (
    HandlerContext,
    known_file_name,
    register,
)

# CGA's built-in assets and primitive operations -> grammarkit's built-in primitives
# (grammarkit/split/assets.py). CGA's primitives are y-up; in frame Y that is grammarkit's z.
_BUILTIN_NAMES = {"cube": "cube", "cube:notex": "cube:notex", "cylinder": "cylinder",
                  "sphere": "sphere", "cone": "cone", "quad": "quad", "disk": "disk"}
_PRIMITIVE_OPS = {"primitiveCube": "cube", "primitiveCylinder": "cylinder", "primitiveSphere": "sphere",
                  "primitiveCone": "cone", "primitiveQuad": "quad", "primitiveDisk": "disk"}


def _builtin(name: str, frame: str, span: Span | None, options: bool) -> tuple:
    gk = _BUILTIN_NAMES.get(name)
    if gk is None:
        raise Untranslatable("i:builtin", f"built-in asset 'builtin:{name}' has no grammarkit "
                             "counterpart", span)
    if gk == "cylinder" and frame == "Z":
        gk = "cylinder:y"  # CGA's cylinder axis is its scope's y: grammarkit's y on a face
    call = OpCall(name="i", args=(Arg(value=Str(value="builtin:" + gk)),), span=span)
    if options:
        return [call], ("i:options", "the up axis and insert mode arguments are ignored")
    return [call], None


def _sized(w: Any, h: Any, d: Any, frame: str, span: Span | None) -> list:
    """CGA's primitives with dimensions: a w x h x d box (CGA's x, y, z) centred in the scope's
    xz and standing on its y = 0, as t() s() in grammarkit's axes (frame Y: CGA's y is z).
    Sizes are taken by magnitude: a centred box of width -w is the box of width w (rule files
    write negative sizes, and the engine's s() refuses them)."""
    w, h, d = (Call(func="abs", args=(v,), span=span) if not (isinstance(v, Num) and v.value >= 0) else v
               for v in (w, h, d))
    def half_rest(size: str, dim: Any) -> Any:
        return Binary(op="/", left=Binary(op="-", left=Ref(name=size), right=dim), right=Num(value=2))
    if frame == "Y":
        move, size = (half_rest("scope.sx", w), half_rest("scope.sy", d), Num(value=0)), (w, d, h)
    else:
        move, size = (half_rest("scope.sx", w), Num(value=0), half_rest("scope.sz", d)), (w, h, d)
    return [OpCall(name="t", args=tuple(Arg(value=v) for v in move), span=span),
            OpCall(name="s", args=tuple(Arg(value=v) for v in size), span=span)]


def _h_primitive(cga: str):
    def handler(h: HandlerContext):
        items, approx = _builtin(_PRIMITIVE_OPS[cga], h.frame, h.span, False)
        args = [translate_expr(a, h.ctx) for a in h.args]
        sides = args[0] if cga in ("primitiveCylinder", "primitiveCone", "primitiveDisk") and args else None
        if cga == "primitiveCube" and len(args) == 3:
            return _sized(*args, h.frame, h.span) + items, None
        if cga == "primitiveCylinder" and len(args) == 3:
            diameter = Binary(op="*", left=Num(value=2), right=args[1])
            items = _sized(diameter, args[2], diameter, h.frame, h.span) + items
            args = args[:1]
        if args and not (len(args) == 1 and isinstance(sides, Num) and sides.value == 16):
            approx = (f"{cga}:options", "the number of segments (and other arguments) is "
                      "grammarkit's fixed 16" if sides is not None or cga != "primitiveCube"
                      else "its arguments are not translated")
        return items, approx
    return handler


for _cga in _PRIMITIVE_OPS:
    register(_cga)(_h_primitive(_cga))



def _insert_call(h: HandlerContext, path: Any) -> OpCall:
    """`i(path)`; with missing_assets="keep", `i(path, missing=skip)`: a file that is not
    there when the shape is derived leaves the shape out with a located warning, as CityEngine
    and PRT do ("error" keeps the plain i(), which stops the derivation instead)."""
    args = [Arg(value=path)]
    if h.t.missing_assets == "keep":
        args.append(Arg(name="missing", value=Ref(name="skip", span=h.span)))
    return OpCall(name="i", args=tuple(args), span=h.span)


@register("i")
def _h_i(h: HandlerContext):
    if not h.args:
        raise Untranslatable("op:i", "i() without a file", h.span)
    path = translate_expr(h.args[0], h.ctx)
    options = ("i:options", "the up axis and insert mode arguments are ignored") if len(h.args) > 1 else None
    if not isinstance(path, Str):
        # a computed file name (an attr, a parameter, fileRandom(...), "dir/" + name): grammarkit
        # evaluates it at derive time too; a value known from the attrs' defaults is looked up
        # (and, with missing_assets="drop", left out when missing) like a literal
        known = known_file_name(h.t, path)
        if known is None:
            h.t.computed_asset(format_expr(path), h.span)
        if known is not None and not h.t.asset(known, h.span, computed=True) and h.t.missing_assets == "drop":
            raise Untranslatable("asset:missing", f"asset {known!r} was not found (the i() is "
                                 "left out; --missing-assets keep keeps it)", h.span)
        call = _insert_call(h, path)
        if known is None and h.t.missing_assets == "drop":
            # which file is only known while deriving: `(case fileExists(p): i(p))` leaves the
            # i() out there when the file is missing, as "drop" does here for a known one
            guard = Case(arms=(CaseArm(cond=Call(func="fileExists", args=(path,), span=h.span),
                                       body=Seq(items=(call,)), span=h.span),), span=h.span)
            return [guard], options
        return [call], options
    if path.value.startswith("builtin:"):
        return _builtin(path.value[len("builtin:"):], h.frame, h.span, len(h.args) > 1)
    found = h.t.asset(path.value, h.span)
    if not found and h.t.missing_assets == "drop":
        raise Untranslatable("asset:missing", f"asset {path.value!r} was not found (the i() is "
                             "left out; --missing-assets keep keeps it)", h.span)
    return [_insert_call(h, path)], options

