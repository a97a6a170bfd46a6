"""What every operation handler shares: the typed handler context, the handler table and the
registration beside each handler, and the small helpers handlers use.

A handler translates one CGA operation call:

    @register("extrude")
    def _extrude(h: HandlerContext) -> HandlerResult: ...

It returns `(items, None)`, or `(items, (feature, message))` for an approximation, and raises
`Untranslatable` for what it cannot translate. It reaches the translator (recording,
entries of blocks, assets) through `h.t`, typed by the `TranslatorAPI` protocol so that this
module and the handler modules never import the translator (no import circle).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Protocol

from lark import Tree

from ...ir.base import Span
from ..expressions import ExprContext, Untranslatable, translate_expr


@dataclass
class RuleCtx:
    """The rule being translated: its key (name, arity), grammarkit name, parameters (CGA name
    -> grammarkit name) and whether its constructs are counted in the report."""
    key: tuple[str, int]
    gk: str
    params: dict[str, str]
    counting: bool
    # the shape is a horizontal face (a roof or top face, CGA's comp(f) top/bottom/horizontal
    # of a lot-like volume): a volume extruded from it is scoped like a lot's (frame Y), so its
    # `top` is the cap, not the side that `top` is on a volume extruded from a facade
    horizontal: bool = False


class TranslatorAPI(Protocol):
    """The part of the translator handlers use."""
    missing_assets: str
    operations: frozenset[str]   # the grammarkit operations that exist (the registry's names)
    values: list
    value_names: dict[str, str]
    frame_change: str | None

    def split_entries(self, block: Tree, frame: str, rctx: RuleCtx, ctx: ExprContext) -> list: ...
    def comp_entries(self, block: Tree, frame: str, rctx: RuleCtx, mode: str) -> list: ...
    def asset(self, path: str, span: Span | None, computed: bool = False) -> bool: ...
    def computed_asset(self, text: str, span: Span | None) -> None: ...
    def constant_value(self, expr: Any) -> Any: ...
    def body_items(self, nodes: list, frame: str, rctx: RuleCtx) -> list: ...


@dataclass
class HandlerContext:
    """One CGA operation call being translated (what handlers used to get as 9 arguments)."""
    t: TranslatorAPI          # the translator (recording, blocks, assets, constants)
    name: str                 # the CGA operation's name
    args: list                # the call's argument trees (CGA parse trees)
    block: Tree | None        # its `{ ... }` block, if any
    star: bool                # the block is repeated: `{ ... }*`
    frame: str                # the frame of the current shape ("Y" lot-like, "Z" a face; frames.py)
    rctx: RuleCtx             # the rule it is in
    ctx: ExprContext          # for translating its argument expressions
    span: Span | None         # where it is in the CGA file
    out: list                 # the items translated so far in this sequence (a handler may merge)


HandlerResult = tuple[list, "tuple[str, str] | None"]
Handler = Callable[[HandlerContext], HandlerResult]

# CGA operation name -> handler; filled by `register` as the handler modules are imported
# (handlers/__init__.py imports them all).
HANDLERS: dict[str, Handler] = {}


def register(*names: str) -> Callable[[Handler], Handler]:
    """Register the decorated handler for the CGA operations `names` (one handler each)."""
    def deco(fn: Handler) -> Handler:
        for name in names:
            if name in HANDLERS:
                raise RuntimeError(f"two handlers for the CGA operation {name!r}")
            HANDLERS[name] = fn
        return fn
    return deco


# Operations CGA writes without parentheses.
BARE_OPS = {"reverseNormals", "cleanupGeometry", "deleteHoles", "resetGeometry", "resetMaterial",
            "convexify", "innerRectangle", "alignScopeToAxes", "alignScopeToGeometry",
            "primitiveCube", "primitiveQuad", "primitiveDisk", "setPivot", "trim"}


def axis_name(tree: Any) -> str | None:
    """The name of a bare-name argument (`x`, `world.lowest`, `fe`), else None."""
    if isinstance(tree, Tree) and tree.data == "ref":
        return tree.children[0].value
    return None


def need(args: list, lo: int, hi: int, name: str, span: Span | None) -> None:
    if not lo <= len(args) <= hi:
        raise Untranslatable(f"op:{name}/{len(args)}", f"{name}() with {len(args)} arguments is not "
                             "supported", span)


def literal_number(tree: Any) -> float | None:
    """The value of a number literal argument, else None."""
    if isinstance(tree, Tree) and tree.data == "number":
        return float(tree.children[0].value)
    if isinstance(tree, Tree) and tree.data == "neg":
        v = literal_number(tree.children[-1])
        return None if v is None else -v
    return None


def known_file_name(t: TranslatorAPI, value: Any) -> str | None:
    """The file name a computed expression has with the attrs' default values, when that is
    known without deriving (an attr set to a string, "dir/" + such an attr), else None."""
    known = t.constant_value(value)
    return known if isinstance(known, str) and known and not known.startswith("builtin:") else None


def rel_or_abs(tree: Any, size_ref: str, ctx: ExprContext) -> Any:
    """An s()/t() argument: `'v` is v times the scope size along that axis, also inside the
    argument's expression (`'1 + 0.3`: the size plus 0.3)."""
    return translate_expr(tree, ctx.with_relative(size_ref))
