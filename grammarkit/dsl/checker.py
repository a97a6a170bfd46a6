"""Semantic checks of a Grammar IR: every problem reported at once into a DiagnosticBag.

Operations, functions and constraints are looked up in the registries the caller passes
(`grammarkit.registry.Registries`), so a plugin's new operation is checked exactly like a
built-in one. Operation calls are bound by the compiler's own binder (binding.py), and
constant expressions are folded by the engines' own evaluator (`grammarkit.expr_eval`), so
`check` reports what deriving would refuse, with the same messages and codes. The checker
never evaluates geometry.
"""
from __future__ import annotations

from typing import Any, Iterable

from ..errors import Diagnostic, DiagnosticBag
from ..expr_eval import NOT_CONSTANT, FunctionTable, arity_problem, fold_constant, folding_table
from ..ir import (
    Attr, Binary, Call, Const, Default, ExampleDef, Function,
    Grammar, Num, PartDef, Ref, Rule, Snippet, Unary, Use, Vector,
)
from ..ir.base import Span
from ..registry import Registries
from .check_common import BUILTIN_CONSTRAINTS, BUILTIN_REFS, START, _num, _same, _Scope, _show, _where  # noqa: F401
from .check_split import SplitChecks
from .check_tiling import TilingChecks
from .suggest import NearMisses, closest_first, known_hint

_known_hint = known_hint
__all__ = ["BUILTIN_CONSTRAINTS", "BUILTIN_REFS", "Checker", "Registries", "check_grammar", "closest_first"]


class Checker(SplitChecks, TilingChecks):
    """Definitions, values and expressions here; the split and tiling checks in check_split.py
    and check_tiling.py."""

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
        self._near_misses: dict[tuple[int, int], tuple[NearMisses, Any, Any]] = {}

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


def check_grammar(grammar: Grammar, registries: Registries | None = None,
                  main_file: str | None = None) -> list[Diagnostic]:
    return Checker(grammar, registries, main_file).run()
