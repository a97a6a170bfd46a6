"""IR -> canonical .grammar text.

`parse(print_grammar(g)) == g` for every grammar the text syntax can express; the few IR
shapes it cannot (an empty sequence, a name that is not an identifier, a non-finite number,
a call that would read back as the other of successor/operation, ...) raise GrammarError
naming the node, rather than printing text that means something else.

Canonical form: statements in source order; full-line comments before the statement they were
attached to; minimal parentheses (from PRECEDENCE); integral numbers without `.0`; one space
around binary operators and after commas; an operation block on one line when the statement
fits in WIDTH columns, otherwise one branch per line; a blank line between groups of
statements of different kinds.
"""
from __future__ import annotations

import math
import unicodedata
from pathlib import Path
from typing import Any, Callable, Iterable

from .errors import GrammarError
from .ir import (
    AssetDir, Attr, Binary, Bool, Branch, Call, Case, Choice, Const, ConstraintDef, Default, DockDef, ExampleDef,
    Function, Grammar, Import, NeighborRule, Nil, Num, OpCall, PartDef, Pattern, Placement, Push, Ref, Repeat,
    Rule, Seq, SiteDef, Snippet, Str, Successor, Terminal, Unary, UpDef, Use, Variants, Vector,
)
from .ir.expr import PRECEDENCE, UNARY_PRECEDENCE

WIDTH = 100
INDENT = "  "
_ATOM = 10
_KEYWORDS: frozenset[str] | None = None


def _keywords() -> frozenset[str]:
    global _KEYWORDS
    if _KEYWORDS is None:
        from .dsl.parser import KEYWORDS
        _KEYWORDS = KEYWORDS
    return _KEYWORDS


def _unprintable(what: str, node: Any = None) -> GrammarError:
    span = getattr(node, "span", None)
    return GrammarError(f"cannot print grammar: {what}", span, code="unprintable")


def _ident(name: str, node: Any = None) -> str:
    from .dsl.parser import NAME_RE
    if not isinstance(name, str) or not NAME_RE.match(name) or name in _keywords():
        raise _unprintable(f"{name!r} is not a valid name", node)
    return name


def _dotted(name: str, node: Any = None) -> str:
    for piece in name.split("."):
        _ident(piece, node)
    return name


# -- expressions ---------------------------------------------------------------------------

def format_number(value: float, node: Any = None) -> str:
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _unprintable(f"number {value!r} is not finite", node)
    value = float(value)
    if value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)


def format_string(value: str) -> str:
    out = ['"']
    for ch in value:
        if ch == "\\":
            out.append("\\\\")
        elif ch == '"':
            out.append('\\"')
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ch == "\r":
            out.append("\\r")
        elif unicodedata.category(ch) in ("Cc", "Cs", "Zl", "Zp", "Cf") or ch == "\ufeff":
            out.append("\\u{%x}" % ord(ch))
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _prec(e: Any) -> int:
    if isinstance(e, Binary):
        return PRECEDENCE[e.op]
    if isinstance(e, Unary):
        return UNARY_PRECEDENCE
    if isinstance(e, Num) and e.value < 0:
        return UNARY_PRECEDENCE  # printed with a leading '-'
    return _ATOM


def format_expr(e: Any, min_prec: int = 0) -> str:
    text = _expr(e)
    return f"({text})" if _prec(e) < min_prec else text


def _expr(e: Any) -> str:
    if isinstance(e, Num):
        return format_number(e.value, e)
    if isinstance(e, Str):
        return format_string(e.value)
    if isinstance(e, Bool):
        return "true" if e.value else "false"
    if isinstance(e, Ref):
        return _dotted(e.name, e)
    if isinstance(e, Call):
        return f"{_ident(e.func, e)}({', '.join(format_expr(a) for a in e.args)})"
    if isinstance(e, Vector):
        if len(e.items) == 1:
            return f"({format_expr(e.items[0])},)"
        return f"({', '.join(format_expr(a) for a in e.items)})"
    if isinstance(e, Unary):
        operand = e.operand
        if e.op == "-" and isinstance(operand, Num) and operand.value >= 0:
            inner = f"({_expr(operand)})"  # `-3` would read back as the number -3
        else:
            inner = format_expr(operand, UNARY_PRECEDENCE)
        sep = " " if inner[:1] in ("-", "+", "!") else ""
        return f"{e.op}{sep}{inner}"
    if isinstance(e, Binary):
        p = PRECEDENCE[e.op]
        if e.op == "^":
            left = format_expr(e.left, _ATOM)
            right = format_expr(e.right, UNARY_PRECEDENCE)
        else:
            left = format_expr(e.left, p)
            right = format_expr(e.right, p + 1)
        return f"{left} {e.op} {right}"
    raise _unprintable(f"unknown expression {type(e).__name__}", e)


def _percent(e: Any) -> str:
    if isinstance(e, Num) and e.value >= 0:
        return format_number(e.value, e) + "%"
    if isinstance(e, Ref) and "." not in e.name:
        return _ident(e.name, e) + "%"
    raise _unprintable("a percentage must be a non-negative number or a name", e)


def _vec3(items: Iterable[Any]) -> str:
    return f"({', '.join(format_expr(a) for a in items)})"


# -- rule bodies ---------------------------------------------------------------------------

class _Printer:
    def __init__(self, grammar: Grammar):
        self.rule_names = {r.name for r in grammar.rules}
        for s in grammar.snippets:
            self.rule_names.update(r.name for r in s.rules)
        self.break_blocks = False

    def seq(self, seq: Seq, indent: int, bare: bool = False) -> str:
        """A sequence; `bare`: a lone case/choice may be written without parentheses."""
        items = seq.items
        if not items:
            raise _unprintable("an empty sequence (a rule body needs at least one item; use NIL)",
                               seq)
        if bare and len(items) == 1 and isinstance(items[0], (Case, Choice)):
            return self.item(items[0], indent)
        out = []
        for i, item in enumerate(items):
            if isinstance(item, Pattern) and i != len(items) - 1:
                raise _unprintable("a repeat pattern must be the last item of its sequence", item)
            text = self.item(item, indent)
            if isinstance(item, (Case, Choice)):
                text = f"({text})"
            out.append(text)
        return " ".join(out)

    def item(self, item: Any, indent: int) -> str:
        if isinstance(item, OpCall):
            if item.name in self.rule_names and item.block is None and all(
                    a.name is None for a in item.args):
                raise _unprintable(f"operation call {item.name}(...) has the name of a rule and "
                                   "would read back as a successor", item)
            text = f"{_ident(item.name, item)}({self.args(item.args)})"
            if item.block is not None:
                text += " " + self.block(item.block, indent)
            return text
        if isinstance(item, Successor):
            if item.args:
                if item.name not in self.rule_names:
                    raise _unprintable(f"successor {item.name}(...) with arguments but no rule "
                                       f"{item.name} would read back as an operation", item)
                return f"{_ident(item.name, item)}({', '.join(format_expr(a) for a in item.args)})"
            return _ident(item.name, item)
        if isinstance(item, Terminal):
            return _ident(item.name, item) + "."
        if isinstance(item, Nil):
            return "NIL"
        if isinstance(item, Push):
            return f"[ {self.seq(item.body, indent, bare=True)} ]"
        if isinstance(item, Case):
            if not item.arms:
                raise _unprintable("a case needs at least one `case` arm", item)
            parts = [f"case {format_expr(a.cond)}: {self.seq(a.body, indent)}" for a in item.arms]
            if item.otherwise is not None:
                parts.append(f"else: {self.seq(item.otherwise, indent)}")
            return " ".join(parts)
        if isinstance(item, Choice):
            if not item.arms:
                raise _unprintable("a stochastic choice needs at least one `N%:` arm", item)
            parts = [f"{_percent(a.percent)}: {self.seq(a.body, indent)}" for a in item.arms]
            if item.otherwise is not None:
                parts.append(f"else: {self.seq(item.otherwise, indent)}")
            return " | ".join(parts)
        if isinstance(item, Pattern):
            if not item.group:
                raise _unprintable("a repeat pattern needs at least one name", item)
            text = f"({' '.join(_ident(n, item) for n in item.group)})*"
            if item.tail is not None:
                text += " " + _ident(item.tail, item)
            return text
        raise _unprintable(f"unknown rule item {type(item).__name__}", item)

    def args(self, args) -> str:
        out = []
        for a in args:
            value = format_expr(a.value)
            out.append(f"{_ident(a.name, a)}={value}" if a.name is not None else value)
        return ", ".join(out)

    def block_item(self, it: Any, indent: int) -> str:
        if isinstance(it, Branch):
            mark = {"abs": "", "rel": "'", "float": "~"}[it.mode]
            return f"{mark}{format_expr(it.key)}: {self.seq(it.body, indent)}"
        if isinstance(it, Repeat):
            return self.block(it.items, indent) + "*"
        raise _unprintable(f"unknown block entry {type(it).__name__}", it)

    def block(self, items, indent: int) -> str:
        if not items:
            return "{}"
        one = "{ " + " | ".join(self.block_item(i, indent) for i in items) + " }"
        if not self.break_blocks or len(items) < 2 or (
                "\n" not in one and indent * len(INDENT) + len(one) <= WIDTH // 2):
            return one
        pad = INDENT * (indent + 1)
        lines = []
        for k, i in enumerate(items):
            text = self.block_item(i, indent + 1)
            lines.append(pad + ("| " if k else "") + text)
        return "{\n" + "\n".join(lines) + "\n" + INDENT * indent + "}"


# -- statements ----------------------------------------------------------------------------

def _comments(comments: Iterable[str], indent: str = "") -> list[str]:
    out = []
    for c in comments:
        if "\n" in c or "\r" in c:
            raise _unprintable("a comment cannot contain a line break")
        out.append(f"{indent}#{c}".rstrip() if c.strip() else f"{indent}#")
    return out


def _attr(a: Attr) -> str:
    text = f"attr {_ident(a.name, a)} = {format_expr(a.value)}"
    if a.range is not None:
        text += f" @range({format_expr(a.range[0])}, {format_expr(a.range[1])})"
    if a.enum is not None:
        text += f" @enum({', '.join(format_expr(v) for v in a.enum)})"
    return text


def _rule(p: _Printer, r: Rule, indent: int) -> str:
    head = _ident(r.name, r)
    if r.params:
        head += f"({', '.join(_ident(n, r) for n in r.params)})"
    text = f"{head} --> {p.seq(r.body, indent, bare=True)}"
    if any(len(line) + indent * len(INDENT) > WIDTH for line in text.split("\n")):
        p.break_blocks = True
        try:
            text = f"{head} --> {p.seq(r.body, indent, bare=True)}"
        finally:
            p.break_blocks = False
    return text


_AXES = {(1.0, 0.0, 0.0): "+x", (-1.0, 0.0, 0.0): "-x", (0.0, 1.0, 0.0): "+y",
         (0.0, -1.0, 0.0): "-y", (0.0, 0.0, 1.0): "+z", (0.0, 0.0, -1.0): "-z"}


def _direction(d: Any) -> str:
    """A part's `up(...)` direction: `+x` for a signed unit axis, else the vector."""
    if all(isinstance(x, Num) for x in d):
        name = _AXES.get(tuple(float(x.value) + 0.0 for x in d))
        if name is not None:
            return name
    return _vec3(d)


def _count_comparison(s: ConstraintDef) -> str | None:
    """`(T) == n` / `(T) >= n` / `(T) <= n` for `count` constraints written that way (the parser
    turns them into the bounds lo/hi), else None."""
    if s.name != "count" or not s.args or s.args[0].name not in (None, "type"):
        return None
    bounds = {a.name: a.value for a in s.args[1:]}
    if len(bounds) != len(s.args) - 1 or not set(bounds) <= {"lo", "hi"} or not bounds:
        return None
    head = f"({format_expr(s.args[0].value)})"
    if set(bounds) == {"lo", "hi"}:
        if bounds["lo"] != bounds["hi"]:
            return None
        return f"{head} == {format_expr(bounds['lo'])}"
    if "lo" in bounds:
        return f"{head} >= {format_expr(bounds['lo'])}"
    return f"{head} <= {format_expr(bounds['hi'])}"


def _placement(pl: Placement) -> str:
    text = f"at {_vec3(pl.at)}"
    if pl.rot is not None:
        text += f" rot {_vec3(pl.rot)}"
    return text


def _statement(p: _Printer, s: Any) -> list[str]:
    """Lines of one statement (comments first)."""
    lines = _comments(getattr(s, "comments", ()))
    if isinstance(s, Attr):
        lines.append(_attr(s))
    elif isinstance(s, Const):
        lines.append(f"const {_ident(s.name, s)} = {format_expr(s.value)}")
    elif isinstance(s, Function):
        params = ", ".join(_ident(n, s) for n in s.params)
        lines.append(f"func {_ident(s.name, s)}({params}) = {format_expr(s.value)}")
    elif isinstance(s, Rule):
        lines.append(_rule(p, s, 0))
    elif isinstance(s, Import):
        lines.append(f"import {format_string(s.path)}")
    elif isinstance(s, AssetDir):
        lines.append(f"asset_dir {format_expr(s.value)}")
    elif isinstance(s, Snippet):
        lines.extend(_snippet(p, s))
    elif isinstance(s, Use):
        lines.append(f"use {_ident(s.snippet, s)} as {_ident(s.anchor, s)}")
    elif isinstance(s, Default):
        lines.append(f"default {_ident(s.snippet, s)} for {_ident(s.object_type, s)}")
    elif isinstance(s, Variants):
        opts = " | ".join(f"{_ident(o.snippet, o)}: {_percent(o.weight)}" for o in s.options)
        lines.append(f"variants {_ident(s.object_type, s)} " + (f"{{ {opts} }}" if opts else "{}"))
    elif isinstance(s, UpDef):
        lines.append(f"up {s.axis}")
    elif isinstance(s, ConstraintDef):
        text = f"constraint {_ident(s.name, s)}"
        compared = _count_comparison(s)
        if compared is not None:
            text += compared
        elif s.args:
            text += f"({p.args(s.args)})"
        lines.append(text)
    elif isinstance(s, tuple(_TILING_LINES)):
        lines.append(next(f for cls, f in _TILING_LINES.items() if isinstance(s, cls))(s))
    elif isinstance(s, ExampleDef):
        lines.extend(_example(s))
    else:
        raise _unprintable(f"unknown statement {type(s).__name__}", s)
    return lines


def _snippet(p: _Printer, s: Snippet) -> list[str]:
    head = f"snippet {_ident(s.name, s)} : {_ident(s.object_type, s)} {{"
    if not s.attrs and not s.rules:
        return [head + "}"]
    lines = [head]
    for a in s.attrs:
        lines.extend(_comments(a.comments, INDENT))
        lines.append(INDENT + _attr(a))
    for r in s.rules:
        lines.extend(_comments(r.comments, INDENT))
        lines.append(INDENT + _rule(p, r, 1))
    lines.append("}")
    return lines


def _part(s: PartDef) -> str:
    text = f"part {_ident(s.name, s)} = {format_expr(s.geometry)}"
    if s.symmetry is not None or s.mirror:
        group = s.symmetry if s.symmetry is not None else "none"
        text += f" symmetry({group}, mirror)" if s.mirror else f" symmetry({group})"
    if s.up_any:
        text += " up(any)"
    elif s.up:
        text += f" up({', '.join(_direction(d) for d in s.up)})"
    return text


def _site(s: SiteDef) -> str:
    text = f"site {_ident(s.part, s)}.{_ident(s.name, s)} at {_vec3(s.position)}"
    if s.facing != "+x":
        text += f" facing {s.facing}"
    if s.mirror is not None:
        text += f" mirror {s.mirror}"
    if s.required:
        text += " required"
    return text


def _dock(s: DockDef) -> str:
    a = _ident(s.a, s) + (f".{_ident(s.a_site, s)}" if s.a_site is not None else "")
    b = _ident(s.b, s) + (f".{_ident(s.b_site, s)}" if s.b_site is not None else "")
    text = f"dock {a} -- {b}"
    if s.placements:
        one = " { " + " | ".join(_placement(pl) for pl in s.placements) + " }"
        if len(text) + len(one) <= WIDTH or len(s.placements) < 2:
            text += one
        else:
            body = "\n".join(INDENT + ("| " if k else "") + _placement(pl)
                             for k, pl in enumerate(s.placements))
            text += " {\n" + body + "\n}"
    return text


def _neighbors(s: NeighborRule) -> str:
    parts = []
    if s.multisets:
        parts.append(" | ".join("{" + ", ".join(_ident(n, s) for n in m) + "}"
                                for m in s.multisets))
    for c in s.counts:
        if c.lo < 0 or (c.hi is not None and c.hi < 0):
            raise _unprintable("neighbour counts cannot be negative", c)
        if c.hi is None:
            parts.append(f"{_ident(c.type, c)} in {c.lo}..")
        elif c.hi == c.lo:
            parts.append(f"{_ident(c.type, c)} in {c.lo}")
        else:
            parts.append(f"{_ident(c.type, c)} in {c.lo}..{c.hi}")
    return f"neighbors {_ident(s.part, s)}:" + (" " + ", ".join(parts) if parts else "")


# the tiling statements that print as one line, by IR class
_TILING_LINES: dict[type, Callable[[Any], str]] = {
    PartDef: _part, SiteDef: _site, DockDef: _dock, NeighborRule: _neighbors}


def _example(s: ExampleDef) -> list[str]:
    if s.source is not None and s.parts:
        raise _unprintable("an example is either a file or inline parts, not both", s)
    if s.source is not None:
        return [f"example {_ident(s.name, s)} = assembly({format_string(s.source)})"]
    entries = [f"{_ident(ip.type, ip)} {_placement(ip.placement)}" for ip in s.parts]
    one = f"example {_ident(s.name, s)} {{ {'; '.join(entries)} }}" if entries else \
        f"example {_ident(s.name, s)} {{}}"
    if len(one) <= WIDTH:
        return [one]
    return [f"example {_ident(s.name, s)} {{", *(INDENT + e for e in entries), "}"]


def print_grammar(grammar: Grammar, *, header: bool = True) -> str:
    """Canonical text of a grammar. `header=False` leaves out the `grammar NAME` line."""
    p = _Printer(grammar)
    out: list[str] = _comments(grammar.comments)
    if header:
        out.append(f"grammar {_ident(grammar.name, grammar)}")
    prev_kind = "header" if header or out else None
    for s in grammar.statements:
        lines = _statement(p, s)
        kind = s.kind
        commented = bool(getattr(s, "comments", ()))
        multi = len(lines) - len(getattr(s, "comments", ())) > 1
        if prev_kind is not None and (kind != prev_kind or multi or commented):
            out.append("")
        out.extend(lines)
        prev_kind = "multi" if multi else kind
    if grammar.trailing_comments:
        if out:
            out.append("")
        out.extend(_comments(grammar.trailing_comments))
    return "\n".join(out) + "\n" if out else ""


def format_grammar(source: "str | Path | Grammar", *, filename: str | None = None) -> str:
    """Canonical text of grammar source (text, path or IR). Raises GrammarError on syntax errors."""
    if isinstance(source, Grammar):
        return print_grammar(source)
    from .dsl import parse_with_header
    grammar, has_header = parse_with_header(source, filename=filename)
    return print_grammar(grammar, header=has_header or grammar.name != _default_name(grammar))


def _default_name(grammar: Grammar) -> str:
    from .dsl.frontend import DEFAULT_NAME, default_name
    return default_name(grammar.source_path) if grammar.source_path else DEFAULT_NAME
