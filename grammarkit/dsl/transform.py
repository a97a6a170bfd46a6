"""Lark parse tree -> IR: one transformer method per tree shape, every node with its Span.

Problems the grammar cannot express (a reserved word used as a name, a bad string escape, a
pattern that lists something other than rule names, ...) are collected as diagnostics; the
transformer always finishes so that every problem in a file is reported at once.
"""
from __future__ import annotations

import math
import re
from typing import Any, Iterable

from lark import Token, Tree

from ..errors import DiagnosticBag
from ..ir import (
    Arg, AssetDir, Attr, Binary, Const, Bool, Branch, Call, Case, CaseArm, Choice, ChoiceArm, ConstraintDef, CountRange,
    Default, DockDef, ExampleDef, Function, Import, InlinePart, NeighborRule, Nil, Num, OpCall, PartDef, Pattern,
    Placement, Push, Ref, Repeat, Rule, Seq, SiteDef, Snippet, Str, Successor, Terminal, Unary, UpDef, Use,
    Variants, VariantOption, Vector,
)
from ..ir.base import Span
from ..ir.expr import PRECEDENCE, UNARY_PRECEDENCE
from .parser import KEYWORDS

MAX_EXPR_DEPTH = 64  # operator chains deeper than this are refused (printer/checker recurse)

_ESCAPES = {"n": "\n", "t": "\t", "r": "\r", '"': '"', "\\": "\\", "0": "\0"}
_ESCAPE_RE = re.compile(r"\\(u\{[0-9a-fA-F]{1,6}\}|.)")


class Header:
    """`grammar NAME` (not an IR statement: it sets Grammar.name)."""

    def __init__(self, name: str, span: Span):
        self.name = name
        self.span = span


class _Group:
    """A parenthesised body inside a sequence (flattened or kept as a Case/Choice item)."""

    def __init__(self, body: Any, span: Span):
        self.body = body
        self.span = span


def call_names(tree: Tree) -> set[str]:
    """Names of all rules defined in a parse tree (to tell successor calls from operations)."""
    names = set()
    for t in tree.find_data("rule"):
        if t.children and isinstance(t.children[0], Token):
            names.add(str(t.children[0]))
    return names


class ToIR:
    """Builds IR nodes bottom-up. `rule_names` decides whether `Name(args)` is a successor."""

    def __init__(self, filename: str | None, bag: DiagnosticBag, rule_names: Iterable[str] = ()):
        self.filename = filename
        self.bag = bag
        self.rule_names = set(rule_names)
        self._depth: dict[int, int] = {}
        self._literal_nums: set[int] = set()  # ids of Num built straight from a NUMBER token
        # The two maps above are keyed by id(): keep their nodes alive so ids are never reused.
        self._alive: list[Any] = []

    # -- helpers ---------------------------------------------------------------------------
    def span(self, meta) -> Span:
        if getattr(meta, "empty", True):
            return Span(file=self.filename)
        return Span(file=self.filename, line=meta.line, column=meta.column,
                    end_line=meta.end_line, end_column=meta.end_column)

    def tspan(self, tok: Token) -> Span:
        return Span(file=self.filename, line=tok.line or 0, column=tok.column or 0,
                    end_line=tok.end_line or tok.line or 0,
                    end_column=tok.end_column or tok.column or 0)

    def name(self, tok: Token) -> str:
        value = str(tok)
        if value in KEYWORDS:
            self.bag.error(f"'{value}' is a reserved word and cannot be used as a name",
                           self.tspan(tok), code="reserved-word")
        return value

    def depth(self, node: Any) -> int:
        return self._depth.get(id(node), 1)

    def _deep(self, node: Any, children: Iterable[Any], span: Span) -> Any:
        d = 1 + max((self.depth(c) for c in children), default=0)
        if d > MAX_EXPR_DEPTH:
            if not getattr(self, "_reported_deep", False):
                self.bag.error(f"expression nested too deeply (the limit is {MAX_EXPR_DEPTH} levels)",
                               span, code="too-deep", hint="split it into several consts")
                self._reported_deep = True
            return Num(value=0, span=span)
        self._depth[id(node)] = d
        self._alive.append(node)
        return node

    # -- statements ------------------------------------------------------------------------
    def start(self, meta, children):
        return children

    def header(self, meta, c):
        return Header(self.name(c[0]), self.span(meta))

    def import_(self, meta, c):
        return Import(path=self.string_value(c[0]), span=self.span(meta))

    def asset_dir(self, meta, c):
        return AssetDir(value=c[0], span=self.span(meta))

    def attr(self, meta, c):
        name = self.name(c[0])
        value = c[1]
        rng = enum = None
        for ann_kind, ann_value, ann_span in c[2:]:
            if ann_kind == "range":
                if rng is not None:
                    self.bag.error("@range given twice", ann_span, code="duplicate-annotation")
                rng = ann_value
            else:
                if enum is not None:
                    self.bag.error("@enum given twice", ann_span, code="duplicate-annotation")
                enum = ann_value
        return Attr(name=name, value=value, range=rng, enum=enum, span=self.span(meta))

    def range_ann(self, meta, c):
        return ("range", (c[0], c[1]), self.span(meta))

    def enum_ann(self, meta, c):
        return ("enum", tuple(c), self.span(meta))

    def const(self, meta, c):
        return Const(name=self.name(c[0]), value=c[1], span=self.span(meta))

    def func(self, meta, c):
        return Function(name=self.name(c[0]), params=c[1], value=c[2], span=self.span(meta))

    def rule(self, meta, c):
        name = self.name(c[0])
        params: tuple[str, ...] = c[1] if len(c) == 3 else ()
        body = self.as_seq(c[-1], self.span(meta))
        return Rule(name=name, params=params, body=body, span=self.span(meta))

    def params(self, meta, c):
        return tuple(self.name(t) for t in c)

    # -- rule bodies -----------------------------------------------------------------------
    def as_seq(self, body: Any, span: Span) -> Seq:
        if isinstance(body, Seq):
            return body
        return Seq(items=(body,), span=getattr(body, "span", span))

    def seq(self, meta, c):
        items: list[Any] = []
        for item in c:
            if isinstance(item, _Group):
                body = item.body
                if isinstance(body, Seq):
                    items.extend(body.items)  # `(A B)` is just A B
                else:
                    items.append(body)
            else:
                items.append(item)
        return Seq(items=tuple(items), span=self.span(meta))

    def call(self, meta, c):
        tok = c[0]
        name = self.name(tok)
        args: tuple[Arg, ...] = ()
        block = None
        for part in c[1:]:
            if isinstance(part, list):
                args = tuple(part)
            elif isinstance(part, tuple):
                block = part
        span = self.span(meta)
        if name in self.rule_names and block is None and all(a.name is None for a in args):
            return Successor(name=name, args=tuple(a.value for a in args), span=span)
        return OpCall(name=name, args=args, block=block, span=span)

    def successor(self, meta, c):
        return Successor(name=self.name(c[0]), span=self.span(meta))

    def terminal(self, meta, c):
        value = str(c[0])[:-1]
        if value in KEYWORDS:
            self.bag.error(f"'{value}' is a reserved word and cannot be used as a name",
                           self.tspan(c[0]), code="reserved-word")
        return Terminal(name=value, span=self.span(meta))

    def nil(self, meta, c):
        return Nil(span=self.span(meta))

    def push(self, meta, c):
        return Push(body=self.as_seq(c[0], self.span(meta)), span=self.span(meta))

    def group(self, meta, c):
        return _Group(c[0], self.span(meta))

    def pattern(self, meta, c):
        span = self.span(meta)
        body = c[0]
        names: list[str] = []
        if isinstance(body, Seq) and body.items and all(
                isinstance(i, Successor) and not i.args for i in body.items):
            names = [i.name for i in body.items]
        else:
            self.bag.error("a repeat pattern `( ... )*` may only list rule names, like (A B)*",
                           span, code="bad-pattern")
        tail = self.name(c[1]) if len(c) > 1 else None
        return Pattern(group=tuple(names), tail=tail, span=span)

    def case(self, meta, c):
        arms = tuple(x for x in c if isinstance(x, CaseArm))
        otherwise = next((x for x in c if isinstance(x, Seq)), None)
        return Case(arms=arms, otherwise=otherwise, span=self.span(meta))

    def case_arm(self, meta, c):
        return CaseArm(cond=c[0], body=c[1], span=self.span(meta))

    def else_arm(self, meta, c):
        return c[0]

    def choice(self, meta, c):
        arms = tuple(x for x in c if isinstance(x, ChoiceArm))
        otherwise = next((x for x in c if isinstance(x, Seq)), None)
        return Choice(arms=arms, otherwise=otherwise, span=self.span(meta))

    def choice_arm(self, meta, c):
        return ChoiceArm(percent=c[0], body=c[1], span=self.span(meta))

    def percent(self, meta, c):
        tok = c[0]
        if tok.type == "PERCENT":
            return self.number_value(tok, str(tok)[:-1])
        return Ref(name=self.name(tok), span=self.tspan(tok))

    def args(self, meta, c):
        return list(c)

    def pos_arg(self, meta, c):
        return Arg(value=c[0], span=self.span(meta))

    def named_arg(self, meta, c):
        return Arg(name=self.name(c[0]), value=c[1], span=self.span(meta))

    def block(self, meta, c):
        return tuple(c)

    def _branch(self, meta, c, mode):
        return Branch(mode=mode, key=c[0], body=c[1], span=self.span(meta))

    def abs_branch(self, meta, c):
        return self._branch(meta, c, "abs")

    def rel_branch(self, meta, c):
        return self._branch(meta, c, "rel")

    def float_branch(self, meta, c):
        return self._branch(meta, c, "float")

    def repeat(self, meta, c):
        return Repeat(items=tuple(c), span=self.span(meta))

    # -- snippets --------------------------------------------------------------------------
    def snippet(self, meta, c):
        attrs = tuple(x for x in c[2:] if isinstance(x, Attr))
        rules = tuple(x for x in c[2:] if isinstance(x, Rule))
        return Snippet(name=self.name(c[0]), object_type=self.name(c[1]), attrs=attrs, rules=rules,
                       span=self.span(meta))

    def use(self, meta, c):
        return Use(snippet=self.name(c[0]), anchor=self.name(c[1]), span=self.span(meta))

    def default(self, meta, c):
        return Default(snippet=self.name(c[0]), object_type=self.name(c[1]), span=self.span(meta))

    def variants(self, meta, c):
        return Variants(object_type=self.name(c[0]), options=tuple(c[1:]), span=self.span(meta))

    def variant(self, meta, c):
        return VariantOption(snippet=self.name(c[0]), weight=c[1], span=self.span(meta))

    # -- tiling ----------------------------------------------------------------------------
    def part(self, meta, c):
        span = self.span(meta)
        geometry = c[1]
        if not isinstance(geometry, Call):
            self.bag.error("a part's geometry must be a call such as mesh(\"file.glb\") or box(w, d, h)",
                           getattr(geometry, "span", None) or span, code="bad-part")
            geometry = Call(func="box", args=(), span=span)
        opts: dict[str, Any] = {}
        for name, value, ospan in c[2:]:
            if name in opts:
                self.bag.error(f"part option {name}(...) given twice", ospan, code="bad-part")
            opts[name] = value
        symmetry, mirror = opts.get("symmetry", (None, False))
        up = opts.get("up", ())
        return PartDef(name=self.name(c[0]), geometry=geometry, symmetry=symmetry, mirror=mirror,
                       up=() if up == "any" else up, up_any=up == "any", span=span)

    _AXIS_VECTORS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}

    def part_option(self, meta, c):
        """`symmetry(z4[, mirror])` or `up(+z, (0, 1, 0), ...)` after a part's geometry."""
        span = self.span(meta)
        name = str(c[0])
        args = [a for a in c[1:] if isinstance(a, list)]
        args = args[0] if args else []
        mirror = any(isinstance(a, Tree) or a == "mirror" for a in c[1:] if not isinstance(a, list))
        if name == "symmetry":
            if any(a.name is not None for a in args) or len(args) > 1:
                self.bag.error("symmetry(...) takes one group (none, z2, z4, ... zN) and optionally "
                               "`mirror`", span, code="bad-symmetry")
                return ("symmetry", (None, mirror), span)
            group = None
            if args:
                v = args[0].value
                text = v.name if isinstance(v, Ref) else None
                if text == "none" or (text and re.fullmatch(r"z([1-9][0-9]{0,2})", text)):
                    group = "none" if text in ("none", "z1") else text
                else:
                    self.bag.error("a symmetry group is none, z2, z3, z4, ... (turns about the up axis "
                                   "that leave the part looking the same)", getattr(v, "span", None) or span,
                                   code="bad-symmetry")
            elif not mirror:
                self.bag.error("symmetry() needs a group (none, z2, z4, ...) or `mirror`", span,
                               code="bad-symmetry")
            return ("symmetry", (group if args else "none", mirror), span)
        if name == "up":
            if mirror or not args:
                self.bag.error("up(...) lists directions of the part's frame that may point up, "
                               "e.g. up(+z, +x) or up((0, 0, 1)), or is up(any)", span, code="bad-up")
                return ("up", (), span)
            if len(args) == 1 and isinstance(args[0].value, Ref) and args[0].value.name == "any":
                return ("up", "any", span)
            dirs = []
            for a in args:
                d = self._direction(a.value)
                if d is None or a.name is not None:
                    self.bag.error("a direction is +x, -x, +y, -y, +z, -z or a vector (x, y, z)",
                                   a.span or span, code="bad-up")
                    continue
                dirs.append(d)
            return ("up", tuple(dirs), span)
        self.bag.error(f"unknown part option '{name}(...)'; part options are symmetry(...) and up(...)",
                       self.tspan(c[0]), code="bad-part")
        return (name, None, span)

    def part_mirror(self, meta, c):
        return "mirror"

    def _direction(self, v):
        """`+x`/`-z` (a signed axis name) or a 3-vector expression, as three expressions."""
        sign, inner = 1.0, v
        if isinstance(v, Unary) and v.op in "+-" and isinstance(v.operand, Ref):
            sign, inner = (-1.0 if v.op == "-" else 1.0), v.operand
        if isinstance(inner, Ref) and inner.name in self._AXIS_VECTORS:
            span = getattr(v, "span", None)
            return tuple(Num(value=sign * x + 0.0, span=span) for x in self._AXIS_VECTORS[inner.name])
        if isinstance(v, Vector) and len(v.items) == 3:
            return tuple(v.items)
        return None

    def up_axis(self, meta, c):
        span = self.span(meta)
        head, value = str(c[0]), str(c[1])
        if head != "up":
            self.bag.error(f"unknown statement '{head} {value}' (did you mean `up +z`?)", span,
                           code="syntax")
            return UpDef(span=span)
        if value not in ("+x", "-x", "+y", "-y", "+z", "-z", "none"):
            self.bag.error(f"`up` takes an axis (+x, -x, +y, -y, +z, -z) or `none`, not '{value}'",
                           self.tspan(c[1]), code="bad-up")
            value = "+z"
        return UpDef(axis=value, span=span)

    def vec3(self, meta, c):
        return tuple(c)

    def facing(self, meta, c):
        return ("facing", str(c[0]))

    def mirror(self, meta, c):
        axis = str(c[0])
        if axis not in ("x", "y", "z"):
            self.bag.error(f"mirror axis must be x, y or z, not '{axis}'", self.tspan(c[0]),
                           code="bad-axis")
            axis = "x"
        return ("mirror", axis)

    def rot(self, meta, c):
        return ("rot", c[0])

    def site(self, meta, c):
        span = self.span(meta)
        dotted = str(c[0]).split(".")
        if len(dotted) != 2:
            self.bag.error("a site is named Part.site (exactly one dot)", self.tspan(c[0]),
                           code="bad-site")
            dotted = [dotted[0], dotted[-1]]
        for piece in dotted:
            if piece in KEYWORDS:
                self.bag.error(f"'{piece}' is a reserved word and cannot be used as a name",
                               self.tspan(c[0]), code="reserved-word")
        opts = dict(x for x in c[2:] if x is not None)
        return SiteDef(part=dotted[0], name=dotted[1], position=c[1],
                       facing=opts.get("facing", "+x"), mirror=opts.get("mirror"),
                       required=bool(opts.get("required")), span=span)

    def site_flag(self, meta, c):
        if str(c[0]) != "required":
            self.bag.error(f"unknown site flag '{c[0]}' (the only flag is `required`)", self.tspan(c[0]),
                           code="bad-site")
            return None
        return ("required", True)

    def endpoint(self, meta, c):
        pieces = str(c[0]).split(".")
        if len(pieces) > 2:
            self.bag.error("a dock end is Part or Part.site", self.tspan(c[0]), code="bad-dock")
        for piece in pieces:
            if piece in KEYWORDS:
                self.bag.error(f"'{piece}' is a reserved word and cannot be used as a name",
                               self.tspan(c[0]), code="reserved-word")
        return (pieces[0], pieces[1] if len(pieces) > 1 else None)

    def dock(self, meta, c):
        (a, a_site), (b, b_site) = c[0], c[1]
        placements = c[2] if len(c) > 2 else ()
        return DockDef(a=a, a_site=a_site, b=b, b_site=b_site, placements=placements,
                       span=self.span(meta))

    def placements(self, meta, c):
        return tuple(c)

    def placement(self, meta, c):
        rot = c[1][1] if len(c) > 1 else None
        return Placement(at=c[0], rot=rot, span=self.span(meta))

    def neighbors(self, meta, c):
        multisets: tuple = ()
        counts = []
        for x in c[1:]:
            if isinstance(x, CountRange):
                counts.append(x)
            else:
                multisets = x
        return NeighborRule(part=self.name(c[0]), multisets=multisets, counts=tuple(counts),
                            span=self.span(meta))

    def multisets(self, meta, c):
        return tuple(c)

    def multiset(self, meta, c):
        return tuple(self.name(t) for t in c)

    def _int(self, tok: Token) -> int:
        digits = str(tok).lstrip("0") or "0"
        # compared as text first: Python refuses to convert more than 4,300 digits (a ValueError)
        if len(digits) > 10 or int(digits) > 10**9:
            self.bag.error(f"count is too large (the limit is {10**9:,})", self.tspan(tok),
                           code="bad-number")
            return 10**9
        return int(digits)

    def count_between(self, meta, c):
        lo = self._int(c[1])
        hi = self._int(c[2]) if len(c) > 2 else None
        return CountRange(type=self.name(c[0]), lo=lo, hi=hi, span=self.span(meta))

    def count_exact(self, meta, c):
        n = self._int(c[1])
        return CountRange(type=self.name(c[0]), lo=n, hi=n, span=self.span(meta))

    def constraint(self, meta, c):
        span = self.span(meta)
        cmp = c[-1] if len(c) > 1 and isinstance(c[-1], tuple) else None
        rest = c[1:-1] if cmp is not None else c[1:]
        args = tuple(rest[0]) if rest and rest[0] is not None else ()
        name = self.name(c[0])
        if cmp is not None:
            op, value = cmp
            if name != "count" or len(args) != 1 or args[0].name not in (None, "type"):
                self.bag.error(f"a comparison `{op} n` follows only count(Type): "
                               "`constraint count(Entry) == 1`", span, code="bad-constraint")
            else:
                bounds = {"==": ("lo", "hi"), ">=": ("lo",), "<=": ("hi",)}[op]
                args = args + tuple(Arg(name=b, value=value, span=getattr(value, "span", span)) for b in bounds)
        return ConstraintDef(name=name, args=args, span=span)

    def count_eq(self, meta, c):
        return ("==", c[0])

    def count_ge(self, meta, c):
        return (">=", c[0])

    def count_le(self, meta, c):
        return ("<=", c[0])

    def example_file(self, meta, c):
        span = self.span(meta)
        if str(c[1]) != "assembly":
            self.bag.error(f"an example file is given as assembly(\"file\"), not {c[1]}(...)",
                           self.tspan(c[1]), code="bad-example")
        return ExampleDef(name=self.name(c[0]), source=self.string_value(c[2]), span=span)

    def example_inline(self, meta, c):
        return ExampleDef(name=self.name(c[0]), parts=tuple(c[1:]), span=self.span(meta))

    def inline_part(self, meta, c):
        span = self.span(meta)
        rot = c[2][1] if len(c) > 2 else None
        return InlinePart(type=self.name(c[0]), placement=Placement(at=c[1], rot=rot, span=span),
                          span=span)

    # -- expressions -----------------------------------------------------------------------
    def number_value(self, tok: Token, text: str) -> Num:
        value = float(text)
        if not math.isfinite(value):
            self.bag.error(f"number {text} is too large", self.tspan(tok), code="bad-number")
            value = 0.0
        num = Num(value=value, span=self.tspan(tok))
        self._literal_nums.add(id(num))
        self._alive.append(num)
        return num

    def number(self, meta, c):
        return self.number_value(c[0], str(c[0]))

    def string_value(self, tok: Token) -> str:
        raw = str(tok)[1:-1]
        if "\\" not in raw:
            return raw

        def unescape(m: re.Match) -> str:
            esc = m.group(1)
            if esc.startswith("u{"):
                code = int(esc[2:-1], 16)
                if code > 0x10FFFF or 0xD800 <= code <= 0xDFFF:
                    self.bag.error(f"\\{esc} is not a valid character", self.tspan(tok),
                                   code="bad-escape")
                    return "?"
                return chr(code)
            if esc in _ESCAPES:
                return _ESCAPES[esc]
            self.bag.error(f"unknown escape \\{esc} in string (use \\\\ for a backslash)",
                           self.tspan(tok), code="bad-escape")
            return esc

        return _ESCAPE_RE.sub(unescape, raw)

    def string(self, meta, c):
        return Str(value=self.string_value(c[0]), span=self.span(meta))

    def true(self, meta, c):
        return Bool(value=True, span=self.span(meta))

    def false(self, meta, c):
        return Bool(value=False, span=self.span(meta))

    def ref(self, meta, c):
        tok = c[0]
        if tok.type == "DOTTED_NAME":
            for piece in str(tok).split("."):
                if piece in KEYWORDS:
                    self.bag.error(f"'{piece}' is a reserved word and cannot be used as a name",
                                   self.tspan(tok), code="reserved-word")
            return Ref(name=str(tok), span=self.span(meta))
        return Ref(name=self.name(tok), span=self.span(meta))

    def call_expr(self, meta, c):
        span = self.span(meta)
        node = Call(func=self.name(c[0]), args=tuple(c[1:]), span=span)
        return self._deep(node, c[1:], span)

    def paren(self, meta, c):
        self._literal_nums.discard(id(c[0]))
        return c[0]

    def vector(self, meta, c):
        span = self.span(meta)
        return self._deep(Vector(items=tuple(c), span=span), c, span)

    def _span_of(self, a: Any, b: Any) -> Span:
        sa, sb = getattr(a, "span", None), getattr(b, "span", None)
        if sa is None or sb is None:
            return sa or sb or Span(file=self.filename)
        return Span(file=self.filename, line=sa.line, column=sa.column, end_line=sb.end_line,
                    end_column=sb.end_column)

    def expr(self, meta, c):
        """Fold `prefix* atom (binop prefix* atom)*` with an operator stack (shunting-yard).

        Unary prefix operators bind tighter than every binary operator except `^`, so `-2 ^ 2`
        is -(2 ^ 2) and `-a * b` is (-a) * b; `^` is right-associative. A `-` applied directly
        to a number literal folds into a negative number.
        """
        out: list[Any] = []
        ops: list[tuple[str, bool, Token]] = []  # (operator, is_prefix, token)

        def reduce_top() -> None:
            op, prefix, tok = ops.pop()
            if prefix:
                operand = out.pop()
                out.append(self._unary(op, tok, operand))
            else:
                right = out.pop()
                left = out.pop()
                span = self._span_of(left, right)
                out.append(self._deep(Binary(op=op, left=left, right=right, span=span),
                                      (left, right), span))

        expect_operand = True
        for child in c:
            if not isinstance(child, Token):
                out.append(child)
                expect_operand = False
                continue
            op = str(child)
            if expect_operand:
                ops.append((op, True, child))
                continue
            prec = PRECEDENCE[op]
            while ops:
                top, top_prefix, _ = ops[-1]
                top_prec = UNARY_PRECEDENCE if top_prefix else PRECEDENCE[top]
                if top_prec > prec or (top_prec == prec and op != "^" and not top_prefix):
                    reduce_top()
                else:
                    break
            ops.append((op, False, child))
            expect_operand = True
        while ops:
            reduce_top()
        return out[0]

    def _unary(self, op: str, tok: Token, operand: Any) -> Any:
        span = self._span_of(_TokSpan(self.tspan(tok)), operand)
        if op == "-" and isinstance(operand, Num) and id(operand) in self._literal_nums:
            # `-3` is the number -3 (so `offset(-0.1)` carries a plain negative number)
            return Num(value=-operand.value, span=span)
        return self._deep(Unary(op=op, operand=operand, span=span), (operand,), span)

    # -- walking the tree without recursion ------------------------------------------------
    def transform(self, root: Tree) -> Any:
        """Post-order walk without recursion; computes each node's source span from its tokens.

        The parser keeps every token (keywords and punctuation too) so that a statement's span
        starts at its keyword; methods receive only the tokens that carry values (names,
        numbers, strings, ...), plus the operator tokens of `expr`.
        """
        values: list[list[Any]] = [[]]
        starts: list[tuple[int, int] | None] = [None]
        ends: list[tuple[int, int] | None] = [None]
        keep_ops: list[bool] = [False]
        work: list[tuple[Any, bool]] = [(root, False)]
        while work:
            node, done = work.pop()
            if not isinstance(node, Tree):
                if node.type == "_NL":
                    continue
                if starts[-1] is None:
                    starts[-1] = (node.line, node.column)
                ends[-1] = (node.end_line, node.end_column)
                if keep_ops[-1] or node.type in _VALUE_TOKENS:
                    values[-1].append(node)
            elif done:
                children = values.pop()
                start = starts.pop()
                end = ends.pop()
                keep_ops.pop()
                values[-1].append(getattr(self, node.data)(_Meta(start, end), children))
                if start is not None:
                    if starts[-1] is None:
                        starts[-1] = start
                    ends[-1] = end
            else:
                work.append((node, True))
                values.append([])
                starts.append(None)
                ends.append(None)
                keep_ops.append(node.data == "expr")
                work.extend((child, False) for child in reversed(node.children))
        return values[0][0]


_VALUE_TOKENS = frozenset({"NAME", "CALL_NAME", "DOTTED_NAME", "TERMINAL_NAME", "NUMBER", "PERCENT",
                           "INT", "STRING", "FACING"})


class _Meta:
    """Source range of a tree node (what Lark's `meta` would hold)."""

    __slots__ = ("line", "column", "end_line", "end_column", "empty")

    def __init__(self, start: tuple[int, int] | None, end: tuple[int, int] | None):
        self.empty = start is None
        self.line, self.column = start or (0, 0)
        self.end_line, self.end_column = end or (0, 0)


class _TokSpan:
    def __init__(self, span: Span):
        self.span = span
