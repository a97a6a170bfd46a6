"""Semantic checks of a Grammar IR: every problem reported at once into a DiagnosticBag.

Operations, functions and constraints are looked up in the plugin registries, so a plugin's
new operation is checked exactly like a built-in one. The checker never evaluates geometry;
it folds constant expressions only to compare ranges, enums and percentages.
"""
from __future__ import annotations

import difflib
import functools
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

from ..errors import Diagnostic, DiagnosticBag
from ..ir import (
    Attr, Binary, Bool, Branch, Call, Case, Choice, Const, Default, ExampleDef,
    Grammar, Nil, Num, OpCall, PartDef, Pattern, Push, Ref, Repeat, Rule, Seq, SiteDef,
    Snippet, Str, Successor, Terminal, Unary, Use, Variants, Vector,
)
from ..ir.base import Span
from ..registry import ConstraintSpec, FunctionSpec, OperationSpec

# Dotted names the engines provide while deriving (see docs/language.md).
BUILTIN_REFS = frozenset({
    "scope.sx", "scope.sy", "scope.sz", "scope.tx", "scope.ty", "scope.tz",
    "split.index", "split.total", "comp.index", "comp.total",
})
# Global constraints of tiling grammars that are always known, even before their plugin loads.
BUILTIN_CONSTRAINTS = frozenset({"connected", "grounded", "path", "count"})
START = "Start"


def closest_first(name: str, known: Iterable[str]) -> list[str]:
    return list(_closest_first(name, frozenset(known)))


@functools.lru_cache(maxsize=4096)
def _closest_first(name: str, known: frozenset[str]) -> tuple[str, ...]:
    # cached: a file with many misspellings of one name against many known names stays fast
    ordered = sorted(known)
    close = difflib.get_close_matches(name, ordered, n=3, cutoff=0.5)
    return tuple(close + [k for k in ordered if k not in close])


def _known_hint(kind: str, name: str, known: Iterable[str], limit: int = 40) -> str | None:
    ordered = closest_first(name, known)
    if not ordered:
        return f"there are no {kind}"
    shown = ", ".join(ordered[:limit]) + (", ..." if len(ordered) > limit else "")
    best = ordered[0]
    close = difflib.SequenceMatcher(None, name, best).ratio() >= 0.5
    prefix = f"did you mean '{best}'? " if close else ""
    return f"{prefix}known {kind}: {shown}"


def _where(span: Span | None) -> str:
    return f" (at {span})" if span is not None and span.line else ""


@dataclass
class Registries:
    operations: Mapping[str, OperationSpec]
    functions: Mapping[str, FunctionSpec]
    constraints: Mapping[str, ConstraintSpec]

    @classmethod
    def from_plugins(cls) -> "Registries":
        from ..plugins import get_plugin_manager
        pm = get_plugin_manager()
        return cls(pm.operations(), pm.functions(), pm.constraints())


@dataclass
class _Scope:
    values: set[str]
    rules: dict[str, Rule]
    outer_rules: dict[str, Rule] = field(default_factory=dict)
    string_values: set[str] = field(default_factory=set)


class Checker:
    def __init__(self, grammar: Grammar, registries: Registries | None = None,
                 main_file: str | None = None):
        self.g = grammar
        self.reg = registries or Registries.from_plugins()
        self.bag = DiagnosticBag()
        self.main_file = main_file if main_file is not None else grammar.source_path
        self._values: dict[str, Attr | Const] = {}
        self._const_cache: dict[str, Any] = {}

    # -- entry -----------------------------------------------------------------------------
    def run(self) -> list[Diagnostic]:
        g = self.g
        self.collect_definitions()
        self.check_value_cycles()
        top_values = set(self._values)
        string_values = {n for n in top_values if isinstance(self.const_value(Ref(name=n)), str)}
        for a in g.attrs:
            self.check_attr(a, _Scope(top_values, {}, string_values=string_values))
        for c in g.consts:
            self.check_expr(c.value, _Scope(top_values, {}))
        for r in g.rules:
            self.check_rule(r, _Scope(top_values | set(r.params), self.top_rules,
                                      string_values=string_values - set(r.params)))
        for s in g.snippets:
            self.check_snippet(s, top_values, string_values)
        self.check_snippet_bindings()
        self.check_reachability()
        self._unknown_part_uses: dict[str, list[Span | None]] = {}
        self.check_tiling()
        self._report_unknown_parts()
        return self.bag.items

    # -- definitions -----------------------------------------------------------------------
    def _dup(self, kind: str, name: str, node: Any, first: Any) -> None:
        where = f" (first at {first.span})" if first.span is not None and first.span.line else ""
        self.bag.error(f"{kind} '{name}' is defined twice{where}", node.span,
                       code="duplicate")

    def collect_definitions(self) -> None:
        g = self.g
        for v in list(g.attrs) + list(g.consts):
            if v.name in self._values:
                self._dup("value", v.name, v, self._values[v.name])
            else:
                self._values[v.name] = v
        self.top_rules: dict[str, Rule] = {}
        for r in g.rules:
            if r.name in self.top_rules:
                self._dup("rule", r.name, r, self.top_rules[r.name])
            else:
                self.top_rules[r.name] = r
            if r.name in self.reg.operations:
                self.bag.warning(f"rule '{r.name}' has the name of an operation; calls "
                                 f"{r.name}(...) in this grammar mean the rule", r.span,
                                 code="shadows-operation")
            seen: set[str] = set()
            for p in r.params:
                if p in seen:
                    self.bag.error(f"parameter '{p}' of rule '{r.name}' is listed twice", r.span,
                                   code="duplicate")
                seen.add(p)
        self.snippets: dict[str, Snippet] = {}
        for s in g.snippets:
            if s.name in self.snippets:
                self._dup("snippet", s.name, s, self.snippets[s.name])
            else:
                self.snippets[s.name] = s
        self.object_types: dict[str, list[Snippet]] = {}
        for s in self.snippets.values():
            self.object_types.setdefault(s.object_type, []).append(s)
        self.anchors: dict[str, Use] = {}
        for u in g.uses:
            if u.anchor in self.anchors:
                self._dup("anchor", u.anchor, u, self.anchors[u.anchor])
            elif u.anchor in self.top_rules:
                self.bag.error(f"'{u.anchor}' is both a rule{_where(self.top_rules[u.anchor].span)} "
                               f"and bound by `use`", u.span, code="duplicate")
            else:
                self.anchors[u.anchor] = u
        self.defaults: dict[str, Default] = {}
        for d in g.defaults:
            if d.object_type in self.defaults:
                self.bag.error(f"object type '{d.object_type}' already has a default snippet"
                               f"{_where(self.defaults[d.object_type].span)}", d.span,
                               code="duplicate")
            else:
                self.defaults[d.object_type] = d
        self.parts: dict[str, PartDef] = {}
        for p in g.parts:
            if p.name in self.parts:
                self._dup("part", p.name, p, self.parts[p.name])
            else:
                self.parts[p.name] = p
        examples: dict[str, ExampleDef] = {}
        for e in g.examples:
            if e.name in examples:
                self._dup("example", e.name, e, examples[e.name])
            else:
                examples[e.name] = e

    # -- constants -------------------------------------------------------------------------
    def _refs(self, e: Any) -> Iterable[Ref]:
        stack = [e]
        while stack:
            x = stack.pop()
            if isinstance(x, Ref):
                yield x
            elif isinstance(x, Unary):
                stack.append(x.operand)
            elif isinstance(x, Binary):
                stack.extend((x.left, x.right))
            elif isinstance(x, Call):
                stack.extend(x.args)
            elif isinstance(x, Vector):
                stack.extend(x.items)

    def check_value_cycles(self) -> None:
        graph = {n: [r.name for r in self._refs(v.value) if r.name in self._values]
                 for n, v in self._values.items()}
        color: dict[str, int] = {}
        reported: set[frozenset[str]] = set()
        self._cyclic: set[str] = set()
        for root in graph:
            if color.get(root):
                continue
            # iterative DFS keeping the current path to name the cycle
            path: list[str] = []
            stack: list[tuple[str, int]] = [(root, 0)]
            while stack:
                node, i = stack.pop()
                if i == 0:
                    color[node] = 1
                    path.append(node)
                succ = graph[node]
                if i < len(succ):
                    stack.append((node, i + 1))
                    nxt = succ[i]
                    if color.get(nxt) == 1:
                        cycle = path[path.index(nxt):] + [nxt]
                        key = frozenset(cycle)
                        self._cyclic.update(cycle)
                        if key not in reported:
                            reported.add(key)
                            first = self._values[cycle[0]]
                            self.bag.error("cyclic definition: " + " -> ".join(cycle), first.span,
                                           code="cycle")
                    elif not color.get(nxt):
                        stack.append((nxt, 0))
                else:
                    color[node] = 2
                    path.pop()

    def const_value(self, e: Any, local: Mapping[str, Any] | None = None, _depth: int = 0) -> Any:
        """The value of a constant expression, or None when it depends on the derivation."""
        if _depth > 200:
            return None
        if isinstance(e, Num):
            return e.value
        if isinstance(e, Str):
            return e.value
        if isinstance(e, Bool):
            return e.value
        if isinstance(e, Ref):
            if local is not None and e.name in local:
                return local[e.name]
            if e.name in self._const_cache:
                return self._const_cache[e.name]
            v = self._values.get(e.name)
            if v is None or e.name in getattr(self, "_cyclic", ()):
                return None
            self._const_cache[e.name] = None  # guard against cycles
            value = self.const_value(v.value, None, _depth + 1)
            self._const_cache[e.name] = value
            return value
        if isinstance(e, Unary):
            x = self.const_value(e.operand, local, _depth + 1)
            if e.op == "!" and isinstance(x, bool):
                return not x
            if isinstance(x, (int, float)) and not isinstance(x, bool) and e.op in "+-":
                return -x if e.op == "-" else x
            return None
        if isinstance(e, Binary):
            a = self.const_value(e.left, local, _depth + 1)
            b = self.const_value(e.right, local, _depth + 1)
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b)):
                if e.op in ("==", "!=") and a is not None and b is not None:
                    return (a == b) if e.op == "==" else (a != b)
                return None
            try:
                r = {
                    "+": lambda: a + b, "-": lambda: a - b, "*": lambda: a * b,
                    "/": lambda: a / b, "%": lambda: math.fmod(a, b), "^": lambda: a ** b,
                    "<": lambda: a < b, "<=": lambda: a <= b, ">": lambda: a > b,
                    ">=": lambda: a >= b, "==": lambda: a == b, "!=": lambda: a != b,
                }.get(e.op, lambda: None)()
            except (ArithmeticError, ValueError, TypeError):
                return None
            if isinstance(r, complex) or (isinstance(r, float) and not math.isfinite(r)):
                return None
            return r
        return None

    # -- expressions -----------------------------------------------------------------------
    def check_expr(self, e: Any, scope: _Scope) -> None:
        stack = [e]
        while stack:
            x = stack.pop()
            if isinstance(x, Ref):
                self.check_ref(x, scope)
            elif isinstance(x, Unary):
                stack.append(x.operand)
            elif isinstance(x, Binary):
                stack.extend((x.right, x.left))
            elif isinstance(x, Vector):
                stack.extend(reversed(x.items))
            elif isinstance(x, Call):
                self.check_call(x)
                stack.extend(reversed(x.args))

    def check_ref(self, r: Ref, scope: _Scope) -> None:
        if "." in r.name:
            if r.name not in BUILTIN_REFS:
                head = r.name.split(".")[0]
                known = sorted(n for n in BUILTIN_REFS if n.startswith(head + ".")) or sorted(BUILTIN_REFS)
                self.bag.error(f"unknown built-in value '{r.name}'", r.span,
                               hint=_known_hint("values", r.name, known), code="undefined-name")
            return
        if r.name not in scope.values:
            self.bag.error(f"undefined name '{r.name}'", r.span,
                           hint=_known_hint("names here", r.name, scope.values)
                           if scope.values else "define it with `attr` or `const`",
                           code="undefined-name")

    def check_call(self, c: Call) -> None:
        spec = self.reg.functions.get(c.func)
        if spec is None:
            self.bag.error(f"unknown function '{c.func}'", c.span,
                           hint=_known_hint("functions", c.func, self.reg.functions),
                           code="unknown-function")
            return
        n = len(c.args)
        if n < spec.min_args or (spec.max_args is not None and n > spec.max_args):
            if spec.max_args is None:
                want = f"at least {spec.min_args}"
            elif spec.max_args == spec.min_args:
                want = str(spec.min_args)
            else:
                want = f"{spec.min_args} to {spec.max_args}"
            self.bag.error(f"function '{c.func}' takes {want} argument(s), got {n}", c.span,
                           hint=spec.doc or None, code="function-arity")

    # -- attrs -----------------------------------------------------------------------------
    def check_attr(self, a: Attr, scope: _Scope) -> None:
        self.check_expr(a.value, scope)
        if a.range is not None:
            for x in a.range:
                self.check_expr(x, scope)
            lo, hi = (self.const_value(x) for x in a.range)
            value = self.const_value(a.value) if a.name not in self._values or \
                self._values.get(a.name) is a else self.const_value(a.value)
            if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (lo, hi)):
                if lo > hi:
                    self.bag.error(f"@range of '{a.name}' is empty: {_num(lo)} > {_num(hi)}",
                                   a.range[0].span or a.span, code="bad-range")
                elif isinstance(value, (int, float)) and not isinstance(value, bool) and \
                        not lo <= value <= hi:
                    self.bag.error(f"default of '{a.name}' ({_num(value)}) is outside its @range"
                                   f"({_num(lo)}, {_num(hi)})", a.value.span or a.span,
                                   code="out-of-range")
            if isinstance(value, (str, bool)):
                self.bag.error(f"@range needs a numeric attr, but '{a.name}' is a "
                               f"{'string' if isinstance(value, str) else 'boolean'}", a.span,
                               code="bad-range")
            for x, v in zip(a.range, (lo, hi)):
                if isinstance(v, (str, bool)):
                    self.bag.error("@range bounds must be numbers", x.span or a.span,
                                   code="bad-range")
        if a.enum is not None:
            for x in a.enum:
                self.check_expr(x, scope)
            if not a.enum:
                self.bag.error(f"@enum of '{a.name}' lists no values", a.span, code="bad-enum")
            else:
                values = [self.const_value(x) for x in a.enum]
                value = self.const_value(a.value)
                if value is not None and all(v is not None for v in values) and \
                        not any(_same(value, v) for v in values):
                    shown = ", ".join(_show(v) for v in values)
                    self.bag.error(f"default of '{a.name}' ({_show(value)}) is not one of its "
                                   f"@enum values ({shown})", a.value.span or a.span,
                                   code="not-in-enum")

    # -- rules -----------------------------------------------------------------------------
    def rule_target(self, name: str, scope: _Scope) -> Rule | None:
        return scope.rules.get(name) or scope.outer_rules.get(name)

    def is_defined_successor(self, name: str, scope: _Scope) -> bool:
        return (self.rule_target(name, scope) is not None or name in self.anchors
                or name in self.defaults)

    def check_rule(self, r: Rule, scope: _Scope) -> None:
        self.check_seq(r.body, scope)

    def check_seq(self, seq: Seq, scope: _Scope) -> None:
        for item in seq.items:
            self.check_item(item, scope)

    def check_item(self, item: Any, scope: _Scope) -> None:
        if isinstance(item, OpCall):
            self.check_op(item, scope)
        elif isinstance(item, Successor):
            self.check_successor(item.name, item.args, item.span, scope)
        elif isinstance(item, Pattern):
            for n in item.group:
                self.check_successor(n, (), item.span, scope)
            if item.tail is not None:
                self.check_successor(item.tail, (), item.span, scope)
        elif isinstance(item, Push):
            self.check_seq(item.body, scope)
        elif isinstance(item, Case):
            for arm in item.arms:
                self.check_expr(arm.cond, scope)
                self.check_seq(arm.body, scope)
            if item.otherwise is not None:
                self.check_seq(item.otherwise, scope)
        elif isinstance(item, Choice):
            total = 0.0
            known = True
            for arm in item.arms:
                self.check_expr(arm.percent, scope)
                v = self.const_value(arm.percent)
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    if v < 0:
                        self.bag.error("a percentage cannot be negative", arm.percent.span or arm.span,
                                       code="bad-percent")
                    total += v
                else:
                    known = False
                self.check_seq(arm.body, scope)
            if known and total > 100 + 1e-9:
                self.bag.error(f"stochastic percentages add up to {_num(total)}%, more than 100%",
                               item.span, code="bad-percent")
            if item.otherwise is not None:
                self.check_seq(item.otherwise, scope)
        elif isinstance(item, (Terminal, Nil)):
            pass

    def check_successor(self, name: str, args: tuple, span: Span | None, scope: _Scope) -> None:
        for a in args:
            self.check_expr(a, scope)
        target = self.rule_target(name, scope)
        if target is not None:
            if len(args) != len(target.params):
                self.bag.error(f"rule '{name}' takes {len(target.params)} argument(s), got "
                               f"{len(args)}", span, code="successor-arity")
            return
        if name in self.anchors or name in self.defaults:
            if args:
                self.bag.error(f"'{name}' is bound to a snippet and takes no arguments", span,
                               code="successor-arity")
            return
        self.bag.warning(f"no rule '{name}': the shape becomes a leaf named '{name}'", span,
                         hint="write `" + name + ".` to make a leaf on purpose", code="undefined-successor")

    def check_op(self, op: OpCall, scope: _Scope) -> None:
        spec = self.reg.operations.get(op.name)
        if spec is None:
            self.bag.error(f"unknown operation '{op.name}'", op.span,
                           hint=_known_hint("operations", op.name, self.reg.operations),
                           code="unknown-operation")
            for a in op.args:
                if not (isinstance(a.value, Ref) and "." not in a.value.name):
                    self.check_expr(a.value, scope)  # a bare name may be an axis or selector
            for it in op.block or ():
                self.check_block_item(it, scope, None)
            return
        params = spec.params
        by_name = {p.name: p for p in params}
        bound: dict[str, Any] = {}
        positional = 0
        for a in op.args:
            if a.name is None:
                if positional < len(params):
                    p = params[positional]
                    if p.name in bound:
                        self.bag.error(f"argument '{p.name}' of {op.name} given twice", a.span,
                                       code="bad-argument")
                    bound[p.name] = a
                    self.check_arg(op, p, a, scope)
                elif not spec.variadic:
                    self.bag.error(f"too many arguments: {op.name} takes at most {len(params)}"
                                   f" ({_signature(spec)})", a.span or op.span,
                                   code="operation-arity")
                    self.check_expr(a.value, scope)
                else:
                    self.check_expr(a.value, scope)
                positional += 1
            else:
                p = by_name.get(a.name)
                if p is None:
                    self.bag.error(f"{op.name} has no argument named '{a.name}'", a.span or op.span,
                                   hint=_known_hint("arguments", a.name, by_name) if by_name
                                   else f"{op.name} takes no named arguments",
                                   code="unknown-argument")
                    self.check_expr(a.value, scope)
                    continue
                if p.name in bound:
                    self.bag.error(f"argument '{p.name}' of {op.name} given twice", a.span or op.span,
                                   code="bad-argument")
                bound[p.name] = a
                self.check_arg(op, p, a, scope)
        missing = [p.name for p in params if p.required and p.name not in bound]
        if missing:
            self.bag.error(f"{op.name} is missing argument(s): {', '.join(missing)} "
                           f"({_signature(spec)})", op.span, code="operation-arity")
        self.check_block(op, spec, scope)

    def check_arg(self, op: OpCall, p: Any, a: Any, scope: _Scope) -> None:
        v = a.value
        where = a.span or op.span
        if p.type in ("axis", "selector"):
            if not isinstance(v, Ref) or "." in v.name or (p.choices and v.name not in p.choices):
                shown = "|".join(p.choices) if p.choices else "a name"
                self.bag.error(f"argument '{p.name}' of {op.name} must be {shown}", where,
                               code="bad-argument-type")
            return
        self.check_expr(v, scope)
        if p.type == "number":
            kind = _literal_kind(v)
            if kind is None and isinstance(v, Ref) and v.name in scope.string_values:
                kind = "a string"
            if kind is not None and kind != "a number":
                self.bag.error(f"argument '{p.name}' of {op.name} must be a number, not {kind}",
                               where, code="bad-argument-type")
        elif p.type == "string":
            kind = _literal_kind(v)
            if kind is not None and kind != "a string":
                self.bag.error(f"argument '{p.name}' of {op.name} must be a string, not {kind}",
                               where, code="bad-argument-type")

    def check_block(self, op: OpCall, spec: OperationSpec, scope: _Scope) -> None:
        kind = spec.block
        block = op.block
        if kind == "none":
            if block is not None:
                self.bag.error(f"{op.name} takes no {{ }} block", op.span, code="block-kind")
                for it in block:
                    self.check_block_item(it, scope, None)
            return
        if block is None:
            if kind == "sizes":
                self.bag.error(f"{op.name} needs a block of sizes, like {op.name}(...) "
                               "{ 1: A | ~1: B }", op.span, code="block-kind")
            elif kind == "selectors":
                sel = spec.selectors[0] if spec.selectors else "name"
                self.bag.error(f"{op.name} needs a block of selectors, like {op.name}(...) "
                               f"{{ {sel}: A }}", op.span, code="block-kind")
            return
        selectors = kind in ("selectors", "optional-selectors")
        for it in block:
            self.check_block_item(it, scope, spec if selectors else None, op)

    def check_block_item(self, it: Any, scope: _Scope, selector_spec: OperationSpec | None,
                         op: OpCall | None = None) -> None:
        if isinstance(it, Repeat):
            if selector_spec is not None:
                self.bag.error(f"a repeat group {{ ... }}* belongs in a split block, not in "
                               f"{selector_spec.name}'s selector block", it.span, code="block-kind")
            for sub in it.items:
                self.check_block_item(sub, scope, selector_spec, op)
            return
        if not isinstance(it, Branch):
            return
        if selector_spec is not None:
            key = it.key
            if it.mode != "abs" or not isinstance(key, Ref) or "." in key.name:
                self.bag.error(f"{selector_spec.name} takes selectors ({', '.join(selector_spec.selectors)})"
                               f", not sizes", it.span, code="block-kind")
            elif selector_spec.selectors and key.name not in selector_spec.selectors:
                self.bag.error(f"'{key.name}' is not a selector of {selector_spec.name}", key.span
                               or it.span, hint=_known_hint("selectors", key.name,
                                                            selector_spec.selectors),
                               code="unknown-selector")
        else:
            self.check_expr(it.key, scope)
            kind = _literal_kind(it.key)
            if kind is not None and kind != "a number":
                self.bag.error(f"a split size must be a number, not {kind}", it.key.span or it.span,
                               code="bad-argument-type")
        self.check_seq(it.body, scope)

    # -- snippets --------------------------------------------------------------------------
    def check_snippet(self, s: Snippet, top_values: set[str], string_values: set[str]) -> None:
        local_rules: dict[str, Rule] = {}
        for r in s.rules:
            if r.name in local_rules:
                self._dup(f"rule (in snippet {s.name})", r.name, r, local_rules[r.name])
            else:
                local_rules[r.name] = r
        names: dict[str, Attr] = {}
        for a in s.attrs:
            if a.name in names:
                self._dup(f"attr (in snippet {s.name})", a.name, a, names[a.name])
            names[a.name] = a
        values = top_values | set(names)
        if START not in local_rules:
            self.bag.error(f"snippet '{s.name}' has no `{START}` rule (its axiom)", s.span,
                           code="snippet-start")
        for a in s.attrs:
            self.check_attr(a, _Scope(values, {}, string_values=string_values))
            self.check_attr_override(s, a)
        for r in s.rules:
            self.check_rule(r, _Scope(values | set(r.params), local_rules, self.top_rules,
                                      string_values=string_values - set(r.params)))
        # unreachable rules inside the snippet
        reach = self._reachable_from([START], lambda n: local_rules.get(n))
        for r in s.rules:
            if r.name not in reach and r.name in local_rules and local_rules[r.name] is r:
                self.bag.warning(f"rule '{r.name}' of snippet '{s.name}' is never used "
                                 f"(unreachable from {START})", r.span, code="unreachable")

    def check_attr_override(self, s: Snippet, a: Attr) -> None:
        """A grammar attr replaces a snippet attr of the same name (that is how a model sets a
        snippet's parameter). Warn when the replacing value lies outside the snippet attr's
        range: usually two unrelated attrs that happen to share a name (e.g. a lot `depth`
        of 20 becoming every window's recess depth)."""
        top = self._values.get(a.name)
        if not isinstance(top, Attr) or a.range is None:
            return
        lo, hi = (self.const_value(x) for x in a.range)
        value = self.const_value(top.value)
        numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (lo, hi, value))
        if numbers and not lo <= value <= hi:
            self.bag.warning(
                f"attr '{a.name}' = {_num(value)} of this grammar replaces attr '{a.name}' of "
                f"snippet '{s.name}', outside that attr's @range({_num(lo)}, {_num(hi)})",
                top.span, code="attr-override-range",
                hint=f"rename one of them if they are different things; the snippet's attr is defined{_where(a.span)}")

    def check_snippet_bindings(self) -> None:
        for u in self.g.uses:
            s = self.snippets.get(u.snippet)
            if s is None:
                self.bag.error(f"unknown snippet '{u.snippet}'", u.span,
                               hint=_known_hint("snippets", u.snippet, self.snippets),
                               code="unknown-snippet")
                continue
            owners = self.object_types.get(u.anchor)
            if owners and u.anchor != s.object_type:
                self.bag.error(f"`use {u.snippet} as {u.anchor}`: {u.anchor} is an object type "
                               f"(of snippet {owners[0].name}), but {u.snippet} makes a "
                               f"{s.object_type}", u.span, code="object-type")
        for d in self.g.defaults:
            s = self.snippets.get(d.snippet)
            if s is None:
                self.bag.error(f"unknown snippet '{d.snippet}'", d.span,
                               hint=_known_hint("snippets", d.snippet, self.snippets),
                               code="unknown-snippet")
            elif s.object_type != d.object_type:
                self.bag.error(f"`default {d.snippet} for {d.object_type}`: snippet {d.snippet} "
                               f"makes a {s.object_type}, not a {d.object_type}", d.span,
                               code="object-type")
        seen_types: dict[str, Variants] = {}
        for v in self.g.variants:
            if v.object_type in seen_types:
                self.bag.error(f"object type '{v.object_type}' already has a variants table"
                               f"{_where(seen_types[v.object_type].span)}", v.span, code="duplicate")
            seen_types[v.object_type] = v
            total = 0.0
            known = True
            names: set[str] = set()
            for o in v.options:
                if o.snippet in names:
                    self.bag.error(f"snippet '{o.snippet}' listed twice", o.span or v.span,
                                   code="duplicate")
                names.add(o.snippet)
                s = self.snippets.get(o.snippet)
                if s is None:
                    self.bag.error(f"unknown snippet '{o.snippet}'", o.span or v.span,
                                   hint=_known_hint("snippets", o.snippet, self.snippets),
                                   code="unknown-snippet")
                elif s.object_type != v.object_type:
                    self.bag.error(f"snippet '{o.snippet}' makes a {s.object_type}, not a "
                                   f"{v.object_type}", o.span or v.span, code="object-type")
                self.check_expr(o.weight, _Scope(set(self._values), {}))
                w = self.const_value(o.weight)
                if isinstance(w, (int, float)) and not isinstance(w, bool):
                    if w < 0:
                        self.bag.error("a weight cannot be negative", o.span or v.span,
                                       code="bad-percent")
                    total += w
                else:
                    known = False
            if known and total > 100 + 1e-9:
                self.bag.error(f"variant weights add up to {_num(total)}%, more than 100%", v.span,
                               code="bad-percent")

    # -- reachability ----------------------------------------------------------------------
    def _successors(self, seq: Seq) -> Iterable[str]:
        stack: list[Any] = list(seq.items)
        while stack:
            item = stack.pop()
            if isinstance(item, Successor):
                yield item.name
            elif isinstance(item, Pattern):
                yield from item.group
                if item.tail is not None:
                    yield item.tail
            elif isinstance(item, OpCall):
                for it in item.block or ():
                    stack.extend(_block_seqs(it))
            elif isinstance(item, Push):
                stack.extend(item.body.items)
            elif isinstance(item, Case):
                for arm in item.arms:
                    stack.extend(arm.body.items)
                if item.otherwise is not None:
                    stack.extend(item.otherwise.items)
            elif isinstance(item, Choice):
                for arm in item.arms:
                    stack.extend(arm.body.items)
                if item.otherwise is not None:
                    stack.extend(item.otherwise.items)

    def _reachable_from(self, roots: Iterable[str], lookup) -> set[str]:
        seen: set[str] = set()
        todo = list(roots)
        while todo:
            n = todo.pop()
            if n in seen:
                continue
            seen.add(n)
            r = lookup(n)
            if r is not None:
                todo.extend(self._successors(r.body))
        return seen

    def check_reachability(self) -> None:
        rules = self.g.rules
        if not rules:
            return
        main = [r for r in rules if r.span is None or r.span.file == self.main_file]
        start = (main or list(rules))[0]
        # Successors inside snippets reached through `use`/`default` also reach top-level rules.
        snippet_reach: dict[str, set[str]] = {}

        def snippet_names(s: Snippet) -> set[str]:
            if s.name not in snippet_reach:
                local = {r.name: r for r in s.rules}
                snippet_reach[s.name] = self._reachable_from([START], lambda n: local.get(n))
            return snippet_reach[s.name]

        seen: set[str] = set()
        todo = [start.name]
        while todo:
            n = todo.pop()
            if n in seen:
                continue
            seen.add(n)
            r = self.top_rules.get(n)
            if r is not None:
                todo.extend(self._successors(r.body))
                continue
            bound = []
            if n in self.anchors and self.anchors[n].snippet in self.snippets:
                bound.append(self.snippets[self.anchors[n].snippet])
            elif n in self.defaults and self.defaults[n].snippet in self.snippets:
                bound.append(self.snippets[self.defaults[n].snippet])
            for v in self.g.variants:
                if v.object_type == n:
                    bound.extend(self.snippets[o.snippet] for o in v.options if o.snippet in self.snippets)
            for s in bound:
                local = {r.name for r in s.rules}
                for name in snippet_names(s):
                    rr = next((r for r in s.rules if r.name == name), None)
                    if rr is not None:
                        todo.extend(x for x in self._successors(rr.body) if x not in local)
        for r in rules:
            if r.span is not None and self.main_file is not None and r.span.file != self.main_file:
                continue  # an imported library may hold rules this grammar does not need
            if r.name not in seen and self.top_rules.get(r.name) is r:
                self.bag.warning(f"rule '{r.name}' is never used (unreachable from the start rule "
                                 f"'{start.name}')", r.span, code="unreachable")

    # -- tiling ----------------------------------------------------------------------------
    def _part_ref(self, name: str, span: Span | None, what: str) -> None:
        if name not in self.parts:
            self._unknown_part_uses.setdefault(name, []).append((span, what))

    def _report_unknown_parts(self) -> None:
        """One error per unknown part type, at its first use in the file: a missing `part` line
        would otherwise repeat in every neighbour set, dock and example."""
        def position(use):
            span = use[0]
            return (span.line, span.column) if span is not None else (1 << 30, 0)

        for name, uses in self._unknown_part_uses.items():
            span, what = min(uses, key=position)
            more = len(uses) - 1
            also = f" (and {more} more use{'s' if more > 1 else ''})" if more else ""
            self.bag.error(f"unknown part type '{name}' in {what}{also}", span,
                           hint=_known_hint("part types", name, self.parts) if self.parts
                           else f"declare it with `part {name} = box(w, d, h)` or "
                                f"`part {name} = mesh(\"file.glb\")`", code="unknown-part")

    def check_tiling(self) -> None:
        g = self.g
        values = _Scope(set(self._values), {})
        sites: dict[tuple[str, str], SiteDef] = {}
        for p in g.parts:
            # the geometry constructor (mesh, box, ...) belongs to the tiling engine; check its args
            for a in p.geometry.args:
                self.check_expr(a, values)
        for s in g.sites:
            self._part_ref(s.part, s.span, "site")
            key = (s.part, s.name)
            if key in sites:
                self._dup("site", f"{s.part}.{s.name}", s, sites[key])
            sites[key] = s
            for x in s.position:
                self.check_expr(x, values)
        for d in g.docks:
            for part, site in ((d.a, d.a_site), (d.b, d.b_site)):
                self._part_ref(part, d.span, "dock")
                if site is not None and part in self.parts and (part, site) not in sites:
                    known = [n for (p, n) in sites if p == part]
                    self.bag.error(f"part '{part}' has no site '{site}'", d.span,
                                   hint=_known_hint("sites", site, known) if known
                                   else f"declare it with `site {part}.{site} at (x, y, z)`",
                                   code="unknown-site")
            for pl in d.placements:
                for x in pl.at + (pl.rot or ()):
                    self.check_expr(x, values)
        for n in g.neighbor_rules:
            self._part_ref(n.part, n.span, "neighbors")
            for m in n.multisets:
                for t in m:
                    self._part_ref(t, n.span, "neighbors")
            for c in n.counts:
                self._part_ref(c.type, c.span or n.span, "neighbors")
                if c.hi is not None and c.lo > c.hi:
                    self.bag.error(f"count range {c.lo}..{c.hi} is empty", c.span or n.span,
                                   code="bad-range")
        known = set(self.reg.constraints) | BUILTIN_CONSTRAINTS
        for c in g.constraints:
            if c.name not in known:
                self.bag.error(f"unknown constraint '{c.name}'", c.span,
                               hint=_known_hint("constraints", c.name, known),
                               code="unknown-constraint")
            spec = self.reg.constraints.get(c.name)
            bound: dict[int, Any] = {}  # argument index -> Param
            if spec is not None:
                params = list(spec.params)
                by_name = {p.name: p for p in params}
                npos = 0
                for k, a in enumerate(c.args):
                    if a.name is None:
                        if npos < len(params):
                            bound[k] = params[npos]
                        else:
                            self.bag.error(f"too many arguments: constraint {c.name} takes at "
                                           f"most {len(params)}", a.span or c.span,
                                           code="operation-arity")
                        npos += 1
                    elif a.name in by_name:
                        bound[k] = by_name[a.name]
                    else:
                        self.bag.error(f"constraint {c.name} has no argument named '{a.name}'",
                                       a.span or c.span,
                                       hint=_known_hint("arguments", a.name, by_name) if by_name
                                       else f"{c.name} takes no arguments",
                                       code="unknown-argument")
            for k, a in enumerate(c.args):
                v = a.value
                p = bound.get(k)
                if p is not None and p.type in ("axis", "selector"):
                    if not isinstance(v, Ref) or (p.choices and v.name not in p.choices):
                        shown = "|".join(p.choices) if p.choices else "a name"
                        self.bag.error(f"argument '{p.name}' of constraint {c.name} must be "
                                       f"{shown}", a.span or c.span, code="bad-argument-type")
                elif isinstance(v, Ref) and "." not in v.name:
                    # bare names in constraint arguments name part types (or values)
                    if v.name not in self.parts and v.name not in self._values:
                        self._part_ref(v.name, v.span or c.span, f"constraint {c.name}")
                else:
                    self.check_expr(v, values)
        for e in g.examples:
            for ip in e.parts:
                self._part_ref(ip.type, ip.span or e.span, f"example {e.name}")
                for x in ip.placement.at + (ip.placement.rot or ()):
                    self.check_expr(x, values)


def _block_seqs(it: Any) -> list[Any]:
    out: list[Any] = []
    stack = [it]
    while stack:
        x = stack.pop()
        if isinstance(x, Branch):
            out.extend(x.body.items)
        elif isinstance(x, Repeat):
            stack.extend(x.items)
    return out


def _literal_kind(v: Any) -> str | None:
    if isinstance(v, Num):
        return "a number"
    if isinstance(v, Str):
        return "a string"
    if isinstance(v, Bool):
        return "a boolean"
    if isinstance(v, Vector):
        return "a tuple"
    if isinstance(v, (Unary, Binary)):
        if isinstance(v, Binary) and v.op in ("==", "!=", "<", "<=", ">", ">=", "&&", "||"):
            return "a boolean"
        if isinstance(v, Unary) and v.op == "!":
            return "a boolean"
        return None
    return None


def _signature(spec: OperationSpec) -> str:
    parts = []
    for p in spec.params:
        t = "|".join(p.choices) if p.choices else p.type
        parts.append(f"{p.name}: {t}" + ("" if p.required else f" = {p.default!r}"))
    return f"{spec.name}({', '.join(parts)})"


def _num(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else repr(float(v))


def _show(v: Any) -> str:
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, bool):
        return "true" if v else "false"
    return _num(v)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    return a == b


def check_grammar(grammar: Grammar, registries: Registries | None = None,
                  main_file: str | None = None) -> list[Diagnostic]:
    return Checker(grammar, registries, main_file).run()
