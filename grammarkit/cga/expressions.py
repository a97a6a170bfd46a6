"""CGA expressions -> grammarkit IR expressions.

What maps: numbers, strings, booleans, arithmetic, comparisons, `&&`, `||`, `!`, attrs,
consts and rule parameters, `scope.*` (through the frame's axis mapping, see frames.py),
`split.index/total`, `comp.index/total`, the math functions grammarkit has, `rint`
(grammarkit's `round`), `pow(a, b)` (`a ^ b`), `p(x)` (`rand() < x`) and CGA *functions*
(`name(params) = expr`): a function is inlined at each call with its arguments substituted
(parenthesised by the IR, so precedence is kept), which is exact for CGA's pure functions;
a recursive one (directly or through others) cannot be inlined and becomes a grammarkit
function `func name(params) = expr` instead (`ExprContext.emitted`, see translate/recursion.py), called
by name.

What does not map raises `Untranslatable` naming the missing feature; the caller decides
whether the construct that holds the expression is dropped or approximated.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable

from lark import Token, Tree

from ..ir import Binary, Bool, Call, Num, Ref, Str, Unary
from ..ir.base import Span
from . import frames
from .names import gk_name

# CGA function -> (grammarkit function, min args, max args)
_FUNCTIONS: dict[str, tuple[str, int, int | None]] = {
    "rand": ("rand", 0, 2), "min": ("min", 1, None), "max": ("max", 1, None),
    "floor": ("floor", 1, 1), "ceil": ("ceil", 1, 1), "abs": ("abs", 1, 1),
    "sqrt": ("sqrt", 1, 1), "sin": ("sin", 1, 1), "cos": ("cos", 1, 1), "tan": ("tan", 1, 1),
    "rint": ("round", 1, 1), "clamp": ("clamp", 3, 3),
    # string and list functions (grammarkit/split/strings.py)
    "str": ("str", 1, 1), "len": ("len", 1, 1), "find": ("find", 2, 3),
    "substring": ("substring", 3, 3), "listSize": ("listSize", 1, 1), "listItem": ("listItem", 2, 2),
    "listIndex": ("listIndex", 2, 2), "listFirst": ("listFirst", 1, 1), "listLast": ("listLast", 1, 1),
    "listRange": ("listRange", 3, 3), "replace": ("replace", 3, 3),
    # the CGA utility library's text helpers and CGA's file functions (grammarkit/functions.py)
    "getRange": ("getRange", 3, 3), "getPrefix": ("getPrefix", 2, 2), "getSuffix": ("getSuffix", 2, 2),
    "findFirst": ("cgaFindFirst", 2, 2), "findLast": ("findLast", 2, 2), "count": ("count", 2, 2),
    "fileName": ("fileName", 1, 1), "fileBasename": ("fileBasename", 1, 1),
    "fileDirectory": ("fileDirectory", 1, 1), "fileExtension": ("fileExtension", 1, 1),
    "fileSearch": ("fileSearch", 1, 1), "fileRandom": ("fileRandom", 1, 1), "fileExists": ("fileExists", 1, 1),
    # arrays (grammarkit/split/strings.py)
    "size": ("cgaSize", 1, 1), "nRows": ("cgaRows", 1, 1), "nColumns": ("cgaColumns", 1, 1),
}
# functions whose value is text: `+` with one of them concatenates (CGA converts the other side)
_TEXT_FUNCTIONS = {"colorRGBToHex", "colorHSVToHex", "str", "substring", "listItem", "listFirst", "listLast", "listRange", "replace",
                   "getRange", "getPrefix", "getSuffix", "fileName", "fileBasename", "fileDirectory",
                   "fileExtension", "fileSearch", "fileRandom"}
_BINARY = {"+": "+", "-": "-", "*": "*", "/": "/", "%": "%", "==": "==", "!=": "!=",
           "<": "<", "<=": "<=", ">": ">", ">=": ">="}
_INDEX_REFS = {"split.index", "split.total", "comp.index", "comp.total", "comp.sel"}
_GEOMETRY_REFS = {"geometry.area", "geometry.volume", "geometry.nVertices", "geometry.isRectangular",
                  "geometry.isConcave"}
# counts CGA has and grammarkit's geometry queries give through nVertices: exact on faces
# (n outline vertices, n edges, 1 face) and on the prisms extrude() makes (2n vertices, 3n
# edges, n + 2 faces); on meshes (booleans, inserted assets) the prism formula is used
_DERIVED_GEOMETRY = {
    "geometry.nEdges": lambda nv, vol: Call(func="select", args=(
        Binary(op=">", left=vol, right=Num(value=0)), Binary(op="*", left=nv, right=Num(value=1.5)), nv)),
    "geometry.nFaces": lambda nv, vol: Call(func="select", args=(
        Binary(op=">", left=vol, right=Num(value=0)),
        Binary(op="+", left=Binary(op="/", left=nv, right=Num(value=2)), right=Num(value=2)), Num(value=1))),
}
MAX_INLINE_DEPTH = 16


def _derived_geometry(name: str, span: Span | None) -> Any:
    return _DERIVED_GEOMETRY[name](Ref(name="geometry.nVertices", span=span),
                                   Ref(name="geometry.volume", span=span))


class Untranslatable(Exception):
    def __init__(self, feature: str, message: str, span: Span | None = None):
        super().__init__(message)
        self.feature = feature
        self.message = message
        self.span = span


def span_of(node: Any, filename: str | None) -> Span | None:
    # nodes of an imported file carry that file's name (translate/declarations.py: _merge_import)
    if isinstance(node, Token):
        filename = getattr(node, "cga_file", filename)
    else:
        filename = getattr(getattr(node, "meta", None), "cga_file", filename)
    if isinstance(node, Token):
        if node.line is None:
            return None
        end_line = node.end_line or node.line
        end_col = node.end_column or node.column + len(node.value)
        if end_line != node.line:
            end_line, end_col = node.line, node.column + len(node.value.split("\n", 1)[0])
        return Span(file=filename, line=node.line, column=node.column, end_line=end_line,
                    end_column=end_col)
    meta = getattr(node, "meta", None)
    if meta is None or getattr(meta, "empty", True):
        return None
    return Span(file=filename, line=meta.line, column=meta.column, end_line=meta.end_line,
                end_column=meta.end_column)


def children(tree: Tree) -> list[Any]:
    """The children of a tree that are not keyword/punctuation tokens."""
    return [c for c in tree.children
            if not (isinstance(c, Token) and c.type in ("CASE", "ELSE", "PERCENT_COLON"))]


def call_args(tree: Tree) -> list[Any]:
    for c in tree.children:
        if isinstance(c, Tree) and c.data == "args":
            return list(c.children)
    return []


@dataclass
class Function:
    """A CGA function `name(params) = body`, inlined at each call."""

    name: str
    params: tuple[str, ...]
    body: Any


@dataclass
class ExprContext:
    filename: str | None
    frame: frames.Frame = "Y"
    params: dict[str, str] = field(default_factory=dict)        # rule parameters
    values: dict[str, str] = field(default_factory=dict)        # attrs and consts
    functions: dict[tuple[str, int], Function] = field(default_factory=dict)
    # Names bound by an inlined function call: name -> IR expression.
    bound: dict[str, Any] = field(default_factory=dict)
    inlining: tuple[str, ...] = ()
    # Called for every CGA function that was inlined (its declaration counts as translated).
    on_inline: Callable[[str], None] | None = None
    # Inside an s()/t()/setupProjection argument: the grammarkit scope size a `'v` anywhere in
    # the expression is relative to (`'1 + 0.3` is scope.sy + 0.3); None elsewhere.
    relative: str | None = None
    # CGA functions emitted as grammarkit functions (the recursive ones): (name, arity) ->
    # frame -> the grammarkit function's name, or the Untranslatable its body raised.
    emitted: dict[tuple[str, int], dict[str, Any]] = field(default_factory=dict)
    # names of the emitted functions whose value is text (`+` with a call of one concatenates)
    text_functions: set[str] = field(default_factory=set)
    # readStringTable's file name (IR) -> (the name or None if not static, its rows of cells
    # or None if not found)
    read_table: Callable[[Any], "tuple[str | None, list[list[str]] | None]"] | None = None
    # translating an operation's argument: an array literal there is per-edge or per-axis
    # values the operation's handler translates (or warns about), not an array value; inside a
    # call or an index (`extrude(size([1, 2]))`, `extrude(h[1])`) it is a value again
    operation_argument: bool = False
    # attrs and consts whose CGA value is an array (a literal or a table read): named as an
    # operation's argument itself they are per-edge values too, not a number
    array_names: frozenset[str] = frozenset()

    def with_frame(self, frame: frames.Frame) -> "ExprContext":
        return replace(self, frame=frame)

    def with_relative(self, size_ref: str | None) -> "ExprContext":
        return replace(self, relative=size_ref)


def translate_expr(node: Any, ctx: ExprContext) -> Any:
    """A CGA expression tree -> an IR expression; raises Untranslatable."""
    span = span_of(node, ctx.filename)
    if isinstance(node, Token):  # a bare token only appears for names in a few places
        return _ref(node.value, span, ctx)
    kind = node.data
    kids = node.children
    if kind == "number":
        return Num(value=float(kids[0].value), span=span)
    if kind == "string":
        return Str(value=_unquote(kids[0].value), span=span)
    if kind == "true":
        return Bool(value=True, span=span)
    if kind == "false":
        return Bool(value=False, span=span)
    if kind == "ref":
        return _ref(kids[0].value, span, ctx)
    if kind == "func_call":
        return _call(kids[0].value, call_args(node), span, replace(ctx, operation_argument=False)
                     if ctx.operation_argument else ctx)
    if kind == "func_block_call":
        raise Untranslatable(f"fn:{kids[0].value}{{}}", f"{kids[0].value}(...) {{ ... }} as a value "
                             "(per-edge values) is not supported", span)
    if kind == "binop":
        left, op, right = kids
        a, b = translate_expr(left, ctx), translate_expr(right, ctx)
        tf = ctx.text_functions
        if op.value == "+" and (is_text(a, tf) or is_text(b, tf)):
            # CGA's + joins text and turns the other side into text (str(3) is "3")
            a, b = (x if is_text(x, tf) else Call(func="str", args=(x,), span=x.span) for x in (a, b))
        return Binary(op=_BINARY[op.value], left=a, right=b, span=span)
    if kind in ("or_op", "and_op"):
        left, right = kids
        return Binary(op="||" if kind == "or_op" else "&&", left=translate_expr(left, ctx),
                      right=translate_expr(right, ctx), span=span)
    if kind == "neg":
        operand = translate_expr(kids[-1], ctx)
        if isinstance(operand, Num):
            return Num(value=-operand.value, span=span)
        return Unary(op="-", operand=operand, span=span)
    if kind == "pos":
        return translate_expr(kids[-1], ctx)
    if kind == "not_op":
        return Unary(op="!", operand=translate_expr(kids[-1], ctx), span=span)
    if kind == "rel":
        if ctx.relative is not None:
            v = translate_expr(kids[-1], ctx)
            size = Ref(name=ctx.relative, span=span)
            return size if isinstance(v, Num) and v.value == 1 else Binary(op="*", left=v, right=size, span=span)
        raise Untranslatable("expr:relative", "a relative value ' outside a split size or "
                             "s()/t() argument is not supported", span)
    if kind == "floating":
        raise Untranslatable("expr:floating", "a floating value ~ outside a split size is not "
                             "supported", span)
    if kind == "array" and ctx.operation_argument:
        raise Untranslatable("expr:array", "an array as an operation's argument is not supported here", span)
    if kind == "array":
        return _array_literal(node, span, ctx)
    if kind == "index":
        return _array_index(node, span, replace(ctx, operation_argument=False))
    if kind == "case_expr":
        # case c1: v1 case c2: v2 else: v3 -> select(c1, v1, select(c2, v2, v3)) (lazy)
        parts = [k for k in kids if isinstance(k, Tree)]
        conds, vals, other = parts[0:-1:2], parts[1:-1:2], parts[-1]
        out = translate_expr(other, ctx)
        for cond, val in reversed(list(zip(conds, vals))):
            out = Call(func="select", args=(translate_expr(cond, ctx), translate_expr(val, ctx), out),
                       span=span)
        return out
    if kind == "stoch_expr":
        # 30%: a 20%: b else: c -> pick(rand(0, 100), 30, a, 20, b, c)
        parts = [k for k in kids if isinstance(k, Tree) or (isinstance(k, Token) and k.type != "PERCENT_COLON"
                                                             and k.type != "ELSE")]
        args: list = [Call(func="rand", args=(Num(value=0.0), Num(value=100.0)), span=span)]
        for k in parts[:-1]:
            args.append(translate_expr(k, ctx))
        args.append(translate_expr(parts[-1], ctx))
        return Call(func="pick", args=tuple(args), span=span)
    raise Untranslatable(f"expr:{kind}", f"expression {kind} is not supported", span)


def _array_literal(node: Tree, span: Span | None, ctx: ExprContext) -> Any:
    """`[1, 2; 3, 4]` -> cgaArray(2, 2, 1, 2, 3, 4) (grammarkit/split/strings.py); `[]` is 0 x 0."""
    rows = [list(r.children) for r in node.children if isinstance(r, Tree) and r.data == "args"]
    if len({len(r) for r in rows}) > 1:
        raise Untranslatable("expr:array", "the rows of an array literal have different lengths", span)
    cols = len(rows[0]) if rows else 0
    items = [translate_expr(x, ctx) for r in rows for x in r]
    return Call(func="cgaArray", args=(Num(value=float(len(rows))), Num(value=float(cols)), *items), span=span)


def _array_index(node: Tree, span: Span | None, ctx: ExprContext) -> Any:
    """`m[i]` / `m[i, j]` -> cgaIndex(m, i[, j]); with an index range (`m[1:n, 0]`,
    `m[n:-1:1, 4]`: start:end or start:step:end, ends included) -> cgaSlice(m, bounds...)."""
    target, index_args = node.children[0], node.children[-1]
    idx = list(index_args.children)
    if len(idx) > 2:
        raise Untranslatable("expr:array", f"an array index with {len(idx)} dimensions", span)
    m = translate_expr(target, ctx)
    if not any(isinstance(k, Tree) and k.data == "index_range" for k in idx):
        return Call(func="cgaIndex", args=(m, *(translate_expr(k, ctx) for k in idx)), span=span)
    bounds: list[Any] = []
    for k in idx:
        if isinstance(k, Tree) and k.data == "index_range":
            parts = [translate_expr(x, ctx) for x in k.children if not isinstance(x, Token)]
            start, end, step = (parts[0], parts[1], Num(value=1.0)) if len(parts) == 2 else (parts[0], parts[2], parts[1])
        else:
            start = end = translate_expr(k, ctx)
            step = Num(value=1.0)
        bounds += [start, end, step]
    return Call(func="cgaSlice", args=(m, *bounds), span=span)


def _read_table(name: str, args: list[Any], span: Span | None, ctx: ExprContext) -> Any:
    """readStringTable("file.csv") / readFloatTable(...): read while importing (the file is
    looked up as an asset is) and written into the grammar as an array literal."""
    if ctx.read_table is None:
        raise Untranslatable(f"fn:{name}", f"{name}(): no rule file to read the table beside", span)
    try:
        file, rows = ctx.read_table(translate_expr(args[0], ctx))
    except ValueError as exc:
        raise Untranslatable(f"fn:{name}", f"{name}(): {exc}", span) from None
    if file is None:
        raise Untranslatable(f"fn:{name}", f"{name}() of a file name known only while deriving", span)
    if rows is None:
        raise Untranslatable(f"fn:{name}", f"{name}({file!r}): the file was not found", span)
    cols = max((len(r) for r in rows), default=0)
    cells = [r[k] if k < len(r) else "" for r in rows for k in range(cols)]
    if name == "readFloatTable":
        items: list[Any] = [Num(value=_table_float(c)) for c in cells]
    else:
        items = [Str(value=c) for c in cells]
    return Call(func="cgaArray", args=(Num(value=float(len(rows))), Num(value=float(cols)), *items), span=span)


def _table_float(cell: str) -> float:
    try:
        return float(cell.strip())
    except ValueError:
        return float("nan")  # CGA: a cell that is not a number reads as NaN


def is_text(e: Any, text_functions: "set[str] | frozenset[str]" = frozenset()) -> bool:
    """Whether an IR expression is statically text (a string, a text function, a join);
    `text_functions`: user functions known to return text."""
    if isinstance(e, Str):
        return True
    if isinstance(e, Call):
        return (e.func in _TEXT_FUNCTIONS or e.func in text_functions
                or (e.func == "select" and (is_text(e.args[1], text_functions) or is_text(e.args[2], text_functions))))
    if isinstance(e, Binary):
        return e.op == "+" and (is_text(e.left, text_functions) or is_text(e.right, text_functions))
    return False


def _unquote(text: str) -> str:
    body = text[1:-1]
    out, i = [], 0
    while i < len(body):
        c = body[i]
        if c == "\\" and i + 1 < len(body):
            nxt = body[i + 1]
            out.append({"n": "\n", "t": "\t", "r": "\r"}.get(nxt, nxt))
            i += 2
            continue
        out.append(c)
        i += 1
    return "".join(out)


def unquote(text: str) -> str:
    return _unquote(text)


def _ref(name: str, span: Span | None, ctx: ExprContext) -> Any:
    if ctx.operation_argument and name in ctx.array_names and name not in ctx.bound and name not in ctx.params:
        raise Untranslatable("expr:array", f"the array {name} as an operation's argument is not supported here",
                             span)
    if name in ctx.bound:
        return ctx.bound[name]
    if name in ctx.params:
        return Ref(name=ctx.params[name], span=span)
    if name in ctx.values:
        return Ref(name=ctx.values[name], span=span)
    if (name, 0) in ctx.emitted:
        return _emitted_call((name, 0), [], span, ctx)
    if (name, 0) in ctx.functions:
        return _inline(ctx.functions[(name, 0)], [], span, ctx)
    mapped = frames.scope_name(ctx.frame, name)
    if mapped is not None:
        return Ref(name=mapped, span=span)
    if name in _INDEX_REFS or name in _GEOMETRY_REFS:
        return Ref(name=name, span=span)
    if name in _DERIVED_GEOMETRY:
        return _derived_geometry(name, span)
    if name in _FUNCTIONS and _FUNCTIONS[name][1] == 0:
        # a built-in function called without parentheses (`~(rand)`): CGA allows it
        return Call(func=_FUNCTIONS[name][0], args=(), span=span)
    if name == "scope.elevation":
        # the world height of the scope's origin (CGA's y): grammarkit's scope.tz is the origin's
        # world z whatever the frame, and its lots lie at z = 0 (sea level)
        return Ref(name="scope.tz", span=span)
    if name == "initialShape.origin.py":
        return Num(value=0.0, span=span)  # the lot's height: grammarkit lots lie at z = 0
    head = name.split(".", 1)[0]
    if head in ("geometry", "scope", "comp", "split", "initialShape", "material", "seedian",
                "world", "object", "pivot", "trim", "convert"):
        raise Untranslatable(f"ref:{name}", f"{name} is not supported", span)
    raise Untranslatable("ref:unknown", f"unknown name {name!r} (an attr of an imported file?)",
                         span)


def _call(name: str, args: list[Any], span: Span | None, ctx: ExprContext) -> Any:
    key = (name, len(args))
    if key in ctx.emitted:
        return _emitted_call(key, args, span, ctx)
    if key in ctx.functions:
        return _inline(ctx.functions[key], args, span, ctx)
    if name in _GEOMETRY_REFS and (not args or name == "geometry.isRectangular" and len(args) == 1):
        # geometry.area() etc.: built-in names of grammarkit (isRectangular's tolerance in
        # degrees is grammarkit's fixed one, see docs/cga.md)
        return Ref(name=name, span=span)
    if name in _DERIVED_GEOMETRY and not args:
        return _derived_geometry(name, span)
    if name in ("readStringTable", "readFloatTable") and len(args) == 1:
        return _read_table(name, args, span, ctx)
    if name in _FUNCTIONS:
        gk, lo, hi = _FUNCTIONS[name]
        if len(args) < lo or (hi is not None and len(args) > hi):
            raise Untranslatable(f"fn:{name}", f"{name}() with {len(args)} arguments", span)
        return Call(func=gk, args=tuple(translate_expr(a, ctx) for a in args), span=span)
    if name in ("inside", "overlaps", "touches") and len(args) <= 2:
        # occlusion queries: the target keyword and the label as literal strings
        target = args[0].children[0].value if args and isinstance(args[0], Tree) and args[0].data == "ref" else None
        if args and target not in ("intra", "inter", "all"):
            raise Untranslatable(f"fn:{name}", f"{name}() target {target!r}", span)
        out = [Str(value=target, span=span)] if args else []
        if len(args) == 2:
            label = translate_expr(args[1], ctx)
            if not isinstance(label, Str):
                raise Untranslatable(f"fn:{name}", f"{name}() with a computed label", span)
            out.append(label)
        return Call(func=name, args=tuple(out), span=span)
    if name == "listRandom" and len(args) == 1:
        # an item drawn uniformly: listItem(l, floor(rand(0, listSize(l))))
        lst = translate_expr(args[0], ctx)
        idx = Call(func="floor", args=(Call(func="rand", args=(Num(value=0.0), Call(
            func="listSize", args=(lst,), span=span)), span=span),), span=span)
        return Call(func="listItem", args=(lst, idx), span=span)
    if name in ("colorRGBToHex", "colorHSVToHex") and len(args) == 3:
        from .colors import hsv_rgb_exprs, rgb_hex_expr
        vals = tuple(translate_expr(a, ctx) for a in args)
        if any(isinstance(x, Str) for x in vals):
            raise Untranslatable(f"fn:{name}", f"{name}() of a string", span)
        if not all(isinstance(x, Num) for x in vals) and any(_draws(x) for x in vals):
            # the expression uses each argument several times; CGA draws it once
            raise Untranslatable(f"fn:{name}", f"{name}() of a random value (an argument drawn "
                                 "by rand() at derive time)", span)
        rgb = hsv_rgb_exprs(*vals, span=span) if name == "colorHSVToHex" else vals
        return _bounded_colour(name, rgb_hex_expr(rgb, span=span), span)
    if name in ("colorHexToH", "colorHexToS", "colorHexToV") and len(args) == 1:
        from .colors import hex_hsv_expr
        arg = translate_expr(args[0], ctx)
        if _draws(arg):
            raise Untranslatable(f"fn:{name}", f"{name}() of a random value (drawn at derive time)", span)
        return _bounded_colour(name, hex_hsv_expr(name[-1], arg, span=span), span)
    if name == "pow" and len(args) == 2:
        return Binary(op="^", left=translate_expr(args[0], ctx), right=translate_expr(args[1], ctx),
                      span=span)
    if name == "p" and len(args) == 1:
        return Binary(op="<", left=Call(func="rand", span=span), right=translate_expr(args[0], ctx),
                      span=span)
    if name == "float" and len(args) == 1:
        inner = translate_expr(args[0], ctx)
        return Call(func="float", args=(inner,), span=span) if not isinstance(inner, Num) else inner
    if name == "bool" and len(args) == 1:
        inner = translate_expr(args[0], ctx)
        if isinstance(inner, Str):
            raise Untranslatable(f"fn:{name}", f"{name}() of a string is not supported", span)
        return inner
    raise Untranslatable(f"fn:{name}", f"function {name}() is not supported", span)


def _bounded_colour(name: str, expr: Any, span: Span | None) -> Any:
    from .colors import MAX_COLOR_NODES, tree_size
    if tree_size(expr) > MAX_COLOR_NODES:
        raise Untranslatable(f"fn:{name}", f"{name}() of a computed colour nested too deeply to "
                             f"write as one expression (over {MAX_COLOR_NODES} terms)", span)
    return expr


def _draws(node: Any) -> bool:
    """Whether an IR expression draws random numbers (rand, fileRandom) when evaluated."""
    if isinstance(node, Call) and node.func in ("rand", "fileRandom"):
        return True
    if isinstance(node, (list, tuple)):
        return any(_draws(n) for n in node)
    fields = getattr(node, "__dict__", None)
    return bool(fields) and not isinstance(node, (Num, Str, Bool)) and any(
        _draws(v) for k, v in fields.items() if k != "span")


def _emitted_call(key: tuple[str, int], args: list[Any], span: Span | None, ctx: ExprContext) -> Any:
    """A call of a CGA function emitted as a grammarkit function (for the caller's frame)."""
    target = ctx.emitted[key].get(ctx.frame)
    if isinstance(target, Untranslatable):
        raise Untranslatable(target.feature, target.message, span)
    if target is None:  # not emitted for this frame (cannot happen: both frames are)
        raise Untranslatable("fn:recursive", f"recursive function {key[0]}() cannot be inlined", span)
    return Call(func=target, args=tuple(translate_expr(a, ctx) for a in args), span=span)


def _inline(fn: Function, args: list[Any], span: Span | None, ctx: ExprContext) -> Any:
    if fn.name in ctx.inlining:
        raise Untranslatable("fn:recursive", f"recursive function {fn.name}() cannot be inlined", span)
    if len(ctx.inlining) >= MAX_INLINE_DEPTH:
        raise Untranslatable("fn:deep", f"functions nested more than {MAX_INLINE_DEPTH} deep", span)
    values = [translate_expr(a, ctx) for a in args]
    inner = ExprContext(ctx.filename, ctx.frame, {}, ctx.values, ctx.functions,
                        dict(zip(fn.params, values)), ctx.inlining + (fn.name,), ctx.on_inline,
                        emitted=ctx.emitted, text_functions=ctx.text_functions, read_table=ctx.read_table)
    out = translate_expr(fn.body, inner)
    if ctx.on_inline is not None:
        ctx.on_inline(fn.name)
    return out


# -- static values (for choosing a fallback) --------------------------------------------------

__all__ = ["ExprContext", "Function", "Untranslatable", "is_text", "translate_expr", "span_of",
           "children", "call_args", "unquote", "gk_name"]
