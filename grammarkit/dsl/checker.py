"""Semantic checks of a Grammar IR: every problem reported at once into a DiagnosticBag.

Operations, functions and constraints are looked up in the registries the caller passes
(`grammarkit.registry.Registries`), so a plugin's new operation is checked exactly like a
built-in one. Operation calls are bound by the compiler's own binder (binding.py), and
constant expressions are folded by the engines' own evaluator (`grammarkit.expr_eval`), so
`check` reports what deriving would refuse, with the same messages and codes. The checker
never evaluates geometry.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

from ..errors import Diagnostic, DiagnosticBag
from ..expr_eval import NOT_CONSTANT, FunctionTable, arity_problem, fold_constant, folding_table
from ..ir import (
    Attr, Binary, Branch, Call, Case, Choice, Const, Default, ExampleDef, Function,
    Grammar, Nil, Num, OpCall, PartDef, Pattern, Push, Ref, Repeat, Rule, Seq, SiteDef,
    Snippet, Successor, Terminal, Unary, Use, Variants, Vector,
)
from ..ir.base import Span
from ..registry import OperationSpec, Registries
from .binding import bind_operation, check_block, check_sequence, literal_kind
from .suggest import NearMisses, closest_first, known_hint

# Dotted names the engines provide while deriving (see docs/language.md).
BUILTIN_REFS = frozenset({
    "scope.sx", "scope.sy", "scope.sz", "scope.tx", "scope.ty", "scope.tz",
    "split.index", "split.total", "comp.index", "comp.total", "comp.sel",
    # the shape's geometry (split grammars; grammarkit/split/geometry_queries.py)
    "geometry.area", "geometry.volume", "geometry.nVertices", "geometry.isRectangular",
})
# Global constraints of tiling grammars that are always known, even before their plugin loads.
BUILTIN_CONSTRAINTS = frozenset({"connected", "grounded", "path", "count"})
START = "Start"


_known_hint = known_hint
__all__ = ["BUILTIN_CONSTRAINTS", "BUILTIN_REFS", "Checker", "Registries", "check_grammar", "closest_first"]


def _where(span: Span | None) -> str:
    return f" (at {span})" if span is not None and span.line else ""


@dataclass
class _Scope:
    values: set[str]
    rules: dict[str, Rule]
    outer_rules: dict[str, Rule] = field(default_factory=dict)
    params: frozenset[str] = frozenset()  # rule parameters: never constant
    local_attrs: Mapping[str, Attr] = field(default_factory=dict)  # a snippet's own attrs


class Checker:
    def __init__(self, grammar: Grammar, registries: Registries, main_file: str | None = None):
        if registries is None:
            raise TypeError("Checker: registries= is required (grammarkit.registry.Registries)")
        self.g = grammar
        self.reg = registries
        self.bag = DiagnosticBag()
        self.main_file = main_file if main_file is not None else grammar.source_path
        self._values: dict[str, Attr | Const] = {}
        self._const_cache: dict[str, Any] = {}
        self._reported: set[tuple] = set()  # fold errors already reported (span, message)
        self._functions = registries.functions  # looked up once: folding asks for every expression
        self._memo: dict[tuple[int, int], tuple] = {}
        # user functions (`func`): name -> arity -> first definition
        self.user_functions: dict[str, dict[int, Function]] = {}
        self._fold_table: FunctionTable | None = None
        self._near_misses: dict[tuple[int, int], tuple[NearMisses, Any]] = {}

    # -- entry -----------------------------------------------------------------------------
    def run(self) -> list[Diagnostic]:
        g = self.g
        self.collect_definitions()
        self.check_value_cycles()
        top_values = set(self._values)
        for a in g.attrs:
            self.check_attr(a, _Scope(top_values, {}))
        for c in g.consts:
            self.check_expr(c.value, _Scope(top_values, {}))
        for f in g.functions:
            self.check_expr(f.value, _Scope(top_values | set(f.params), {}, params=frozenset(f.params)))
        for r in g.rules:
            self.check_rule(r, _Scope(top_values | set(r.params), self.top_rules,
                                      params=frozenset(r.params)))
        for s in g.snippets:
            self.check_snippet(s, top_values)
        self.check_snippet_bindings()
        self.check_asset_dirs()
        self.check_reachability()
        self._unknown_part_uses: dict[str, list[Span | None]] = {}
        self.check_tiling()
        self._report_unknown_parts()
        return self.bag.items

    # -- definitions -----------------------------------------------------------------------
    def _params_once(self, params: Any, owner: str, span: Any) -> None:
        """A located error for each parameter name a rule or function lists twice."""
        seen: set[str] = set()
        for p in params:
            if p in seen:
                self.bag.error(f"parameter '{p}' of {owner} is listed twice", span, code="duplicate")
            seen.add(p)

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
        self.collect_functions()
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
            self._params_once(r.params, f"rule '{r.name}'", r.span)
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

    def collect_functions(self) -> None:
        g = self.g
        tiling = g.family == "tiling"
        for f in g.functions:
            if tiling:
                self.bag.error(f"function '{f.name}': tiling grammars have no user functions (yet)", f.span,
                               hint="compute the value with attrs and consts", code="func-in-tiling")
            arities = self.user_functions.setdefault(f.name, {})
            n = len(f.params)
            if n in arities:
                first = arities[n]
                self.bag.error(f"function '{f.name}' with {n} parameter{'s' if n != 1 else ''} is defined "
                               f"twice{_where(first.span).replace(' (at ', ' (first at ')}", f.span,
                               hint="overloads of a function differ in their number of parameters",
                               code="duplicate")
            else:
                arities[n] = f
            self._params_once(f.params, f"function '{f.name}'", f.span)
            if f.name in self.reg.functions and len(arities) == 1 and arities.get(n) is f:
                self.bag.warning(f"function '{f.name}' has the name of a built-in function; calls "
                                 f"{f.name}(...) in this grammar mean the user function", f.span,
                                 code="shadows-function")

    def _function_refs(self, e: Any, seen: set[tuple[str, int]]) -> Iterable[Ref]:
        """The names `e` reads, through the bodies of the user functions it calls (their
        parameters excluded): what a value depends on."""
        for x in self._refs(e, calls=True):
            if isinstance(x, Ref):
                yield x
                continue
            f = self.user_functions.get(x.func, {}).get(len(x.args))
            if f is None or (x.func, len(x.args)) in seen:
                continue
            seen.add((x.func, len(x.args)))
            yield from (r for r in self._function_refs(f.value, seen) if r.name not in f.params)

    # -- constants -------------------------------------------------------------------------
    def _refs(self, e: Any, calls: bool = False) -> Iterable[Any]:
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
                if calls and x.func in self.user_functions:
                    yield x
                stack.extend(x.args)
            elif isinstance(x, Vector):
                stack.extend(x.items)

    def check_value_cycles(self) -> None:
        graph = {n: [r.name for r in self._function_refs(v.value, set()) if r.name in self._values]
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

    def _lookup(self, name: str, scope: _Scope | None, used: list[str] | None = None) -> Any:
        """A name's constant value for folding (NOT_CONSTANT for rule parameters, built-in
        values and anything cyclic or unknown). Attrs count with their default values."""
        if scope is not None:
            if name in scope.params:
                return NOT_CONSTANT
            local = scope.local_attrs.get(name)
            if local is not None and not isinstance(self._values.get(name), Attr):
                if used is not None:
                    used.append(name)
                return self._fold(local.value, None, used)
        if name in self._const_cache:
            value = self._const_cache[name]
        else:
            v = self._values.get(name)
            if v is None or name in getattr(self, "_cyclic", ()):
                return NOT_CONSTANT
            self._const_cache[name] = NOT_CONSTANT  # guard against cycles
            value = self._fold(v.value, None, None)
            self._const_cache[name] = value
        if used is not None and value is not NOT_CONSTANT and (
                isinstance(self._values.get(name), Attr) or name in self._attr_dependent()):
            used.append(name)
        return value

    def _attr_dependent(self) -> set[str]:
        """Consts whose value depends on an attr (so a `--set` may change it)."""
        found = getattr(self, "_attr_deps", None)
        if found is None:
            found = set()
            changed = True
            while changed:
                changed = False
                for n, v in self._values.items():
                    if n in found or isinstance(v, Attr):
                        continue
                    if any(isinstance(self._values.get(r.name), Attr) or r.name in found
                           for r in self._function_refs(v.value, set())):
                        found.add(n)
                        changed = True
            self._attr_deps = found
        return found

    def _fold(self, e: Any, scope: _Scope | None, used: list[str] | None, errors: list | None = None) -> Any:
        if isinstance(e, Num):  # most arguments and sizes are plain numbers
            v = e.value
            return int(v) if float(v).is_integer() and abs(v) < 2 ** 53 else v
        return fold_constant(e, lambda n: self._lookup(n, scope, used), self._functions, errors,
                             user=self._folding_functions())

    def _folding_functions(self) -> FunctionTable | None:
        """The user functions for folding. Their bodies see attrs as not constant (a `--set`
        may change them, and the error report would not know which attr a body read)."""
        if not self.user_functions:
            return None
        if self._fold_table is None:
            def lookup(name: str) -> Any:
                if isinstance(self._values.get(name), Attr) or name in self._attr_dependent():
                    return NOT_CONSTANT
                return self._lookup(name, None, None)
            self._fold_table = folding_table(self.g.functions, lookup, self._functions)
        return self._fold_table

    def _folded(self, e: Any, scope: _Scope | None) -> tuple[Any, tuple[str, ...], tuple]:
        """(value or NOT_CONSTANT, attrs it used, evaluation errors) of `e` in `scope`, folded
        once per expression and scope (the binder and the error report ask for the same ones)."""
        key = (id(e), id(scope))
        hit = self._memo.get(key)
        if hit is None:
            used: list[str] = []
            errors: list = []
            value = self._fold(e, scope, used, errors)
            hit = self._memo[key] = (value, tuple(used), tuple(errors), e, scope)  # keeps ids alive
        return hit[0], hit[1], hit[2]

    def const_value(self, e: Any, scope: _Scope | None = None, fixed_only: bool = False) -> Any:
        """The value of a constant expression (attrs at their defaults), or None when it
        depends on the derivation (`fixed_only`: or on an attr, which `--set` may change).
        Folded by the engines' evaluator (grammarkit.expr_eval)."""
        value, used, _ = self._folded(e, scope)
        return None if value is NOT_CONSTANT or (fixed_only and used) else value

    def report_fold_errors(self, e: Any, scope: _Scope) -> None:
        """Errors the engines would raise evaluating constant parts of `e` (`1 / 0`,
        `9 ^ 9 ^ 9`, `"x" * 600000000`): errors, or warnings when an attr's default value is
        involved (a `--set` may avoid them)."""
        _, used, errors = self._folded(e, scope)
        for exc in errors:
            d = exc.diagnostics[0]
            key = (d.span, d.message)
            if key in self._reported:
                continue
            self._reported.add(key)
            if used:
                self.bag.warning(f"with the default value of {', '.join(sorted(set(used)))}: {d.message}",
                                 d.span, code=d.code)
            else:
                self.bag.error(d.message, d.span, code=d.code)

    # -- expressions -----------------------------------------------------------------------
    def check_expr(self, e: Any, scope: _Scope) -> None:
        if not isinstance(e, Ref):
            self.report_fold_errors(e, scope)
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
        overloads = self.user_functions.get(c.func)
        if overloads is not None:
            n = len(c.args)
            if n not in overloads:
                table = FunctionTable(self.g.functions, lambda name, span: None, self._functions)
                self.bag.error(table.arity_problem(c.func, n) or "", c.span, hint=table.signatures(c.func),
                               code="function-arity")
            return
        spec = self.reg.functions.get(c.func)
        if spec is None:
            self.bag.error(f"unknown function '{c.func}'", c.span,
                           hint=_known_hint("functions", c.func, set(self.reg.functions) | set(self.user_functions)),
                           code="unknown-function")
            return
        problem = arity_problem(c.func, spec, len(c.args))
        if problem is not None:
            self.bag.error(problem, c.span, hint=spec.doc or None, code="function-arity")

    # -- attrs -----------------------------------------------------------------------------
    def check_attr(self, a: Attr, scope: _Scope) -> None:
        self.check_expr(a.value, scope)
        if a.range is not None:
            for x in a.range:
                self.check_expr(x, scope)
            lo, hi = (self.const_value(x, scope) for x in a.range)
            value = self.const_value(a.value, scope) if a.name not in self._values or \
                self._values.get(a.name) is a else self.const_value(a.value, scope)
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
                values = [self.const_value(x, scope) for x in a.enum]
                value = self.const_value(a.value, scope)
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
        for d in check_sequence(seq):
            self.bag.items.append(d)
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
                v = self.const_value(arm.percent, scope)
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
        near = self.rule_near_misses(name, scope)
        if near:  # a typo of a rule (issue 32): deriving would silently drop that rule's work
            self.bag.error(f"unknown rule '{name}'; did you mean '{near[0]}'?", span,
                           hint=f"write `{name}.` to make a leaf named '{name}' on purpose",
                           code="unknown-rule")
            return
        self.bag.warning(f"no rule '{name}': the shape becomes a leaf named '{name}'", span,
                         hint="write `" + name + ".` to make a leaf on purpose", code="undefined-successor")

    def rule_near_misses(self, name: str, scope: _Scope) -> list[str]:
        """Rules (and snippet-bound names) visible in `scope` that `name` is a near miss of."""
        key = (id(scope.rules), id(scope.outer_rules))
        finder = self._near_misses.get(key)
        if finder is None:
            names = set(scope.rules) | set(scope.outer_rules) | set(self.anchors) | set(self.defaults)
            finder = self._near_misses[key] = (NearMisses(names), scope)  # scope: keeps the ids alive
        return finder[0](name)

    def check_op(self, op: OpCall, scope: _Scope) -> None:
        spec = self.reg.operations.get(op.name)
        if spec is None:
            near = self.rule_near_misses(op.name, scope)
            if near:  # `Flor(split.index)`: a misspelt rule, not an operation
                self.bag.error(f"unknown operation or rule '{op.name}'; did you mean the rule "
                               f"'{near[0]}'?", op.span, code="unknown-operation",
                               hint=f"'{near[0]}' is a rule of this grammar; no operation is "
                                    f"called '{op.name}'")
            else:
                self.bag.error(f"unknown operation '{op.name}'", op.span,
                               hint=_known_hint("operations", op.name, self.reg.operations),
                               code="unknown-operation")
            for a in op.args:
                if not (isinstance(a.value, Ref) and "." not in a.value.name):
                    self.check_expr(a.value, scope)  # a bare name may be an axis or selector
            for it in op.block or ():
                self.check_block_item(it, scope)
            return
        binding = bind_operation(op, spec, fold=lambda e: self.const_value(e, scope), registries=self.reg,
                                 fold_fixed=lambda e: self.const_value(e, scope, fixed_only=True))
        self.bag.items.extend(binding.problems)
        for bound in binding.arguments:
            if bound.value is not None and bound.param.type not in ("axis", "selector", "name"):
                self.check_expr(bound.value, scope)
        for value in binding.extra:
            self.check_expr(value, scope)
        named = {p.name for p in spec.params}
        for a in op.args:  # values of unknown named arguments are still expressions to check
            if a.name is not None and a.name not in named:
                self.check_expr(a.value, scope)
        self.bag.items.extend(check_block(op, spec))
        sizes = spec.block in ("sizes", "optional-sizes")
        for it in op.block or ():
            self.check_block_item(it, scope, sizes)

    def check_block_item(self, it: Any, scope: _Scope, sizes: bool = False) -> None:
        """The expressions and bodies of a block entry (its key's kind is check_block's)."""
        if isinstance(it, Repeat):
            for sub in it.items:
                self.check_block_item(sub, scope, sizes)
            return
        if not isinstance(it, Branch):
            return
        if sizes:
            self.check_expr(it.key, scope)
        self.check_seq(it.body, scope)

    # -- snippets --------------------------------------------------------------------------
    def check_snippet(self, s: Snippet, top_values: set[str]) -> None:
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
            self.check_attr(a, _Scope(values, {}, local_attrs=names))
            self.check_attr_override(s, a)
        for r in s.rules:
            self.check_rule(r, _Scope(values | set(r.params), local_rules, self.top_rules,
                                      params=frozenset(r.params), local_attrs=names))
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
            elif known and v.options and total <= 0:
                self.bag.error(f"variants {v.object_type}: the weights add up to 0", v.span,
                               code="bad-percent")

    def check_asset_dirs(self) -> None:
        """`asset_dir` takes one non-empty string literal (a folder, not an expression: it
        is resolved before any attr has a value)."""
        for a in self.g.asset_dir_statements:
            where = a.value.span if a.value.span is not None and a.value.span.line else a.span
            if a.path is None:
                self.bag.error("asset_dir takes a folder name in double quotes, e.g. "
                               '`asset_dir "assets"`', where, code="bad-asset-dir")
            elif not a.path.strip():
                self.bag.error("asset_dir names no folder (the path is empty)", where,
                               code="bad-asset-dir")
            elif "\0" in a.path:
                self.bag.error("asset_dir path contains a NUL character", where,
                               code="bad-asset-dir")

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
        used_sites: set[tuple[str, str]] = set()
        for d in g.docks:
            for part, site in ((d.a, d.a_site), (d.b, d.b_site)):
                if site is not None:
                    used_sites.add((part, site))
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
        for key, s in sites.items():
            # a site no dock names constrains nothing (unless it is required); say so
            if key not in used_sites and not s.required:
                self.bag.warning(f"site {s.part}.{s.name} is not used by any dock (it allows and "
                                 "requires nothing)", s.span, hint=f"dock it: `dock {s.part}.{s.name} -- Other`"
                                 f" or mark it `required`", code="unused-site")
        ups = g.ups
        for extra in ups[1:]:
            self.bag.error("the grammar's up axis is given twice", extra.span,
                           hint=f"the first `up` is at {ups[0].span}", code="duplicate")
        for p in g.parts:
            for d in p.up:
                for x in d:
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
            axis_args: set[int] = set()  # arguments bound to axis/selector parameters
            if spec is not None:
                binding = bind_operation(c, spec, fold=lambda e: self.const_value(e, values),
                                         label=f"constraint {c.name}")
                self.bag.items.extend(binding.problems)
                axis_args = {id(b.value) for b in binding.arguments
                             if b.value is not None and b.param.type in ("axis", "selector")}
            for a in c.args:
                v = a.value
                if id(v) in axis_args:
                    continue
                if isinstance(v, Ref) and "." not in v.name:
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
