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
    Arg, AssetDir, Attr, Binary, Const, Bool, Branch, Call, Case, CaseArm, Choice, ChoiceArm, Default, Function, Import, Nil, Num, OpCall, Pattern,
    Push, Ref, Repeat, Rule, Seq, Snippet, Str, Successor, Terminal, Unary, Use,
    Variants, VariantOption, Vector,
)
from ..ir.base import Span
from ..ir.expr import PRECEDENCE, UNARY_PRECEDENCE
from .parser import KEYWORDS
from .transform_tiling import TilingToIR

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


class ToIR(TilingToIR):
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
