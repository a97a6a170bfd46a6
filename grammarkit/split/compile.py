"""From IR to runnable rules: snippet binding, name resolution, closures for every step.

Compilation happens once per grammar (and per snippet binding, for variations); deriving a
building then runs plain Python closures with no pydantic access in the hot loop.

Snippet combination (Nishida 2016):
- `use S as A`: a copy of snippet S whose `Start` is renamed `A`. The copy's other rules are
  private to it (internally `A::Rule`, shown as `Rule`), its attrs become `A.attr`.
- `default S for T`: a successor `T` that no rule or `use` defines is bound to a copy of S.
- Inside a copy, names resolve to the copy's own rules first, then to the grammar's rules and
  anchors. A name that resolves to nothing becomes a leaf (with a warning), as in CGA.
- `variants T { ... }` tables are used by `variations()` to swap the snippet bound to anchors
  of object type T; `choices={anchor: snippet}` passed here overrides the bindings.

Re-entrancy: a CompiledGrammar is immutable once built. The values of one derivation (attrs
with their overrides, consts, evaluated with the run seed) are a dict made by
`evaluate_values` and carried by the derivation's shapes (`shape.values`); compiled closures
read attrs from the shape they are evaluated on. So one compiled grammar serves any number
of derivations at once, in threads or interleaved.

Operation calls are bound by `grammarkit.dsl.binding`, the binder `grammarkit check` uses, so
both refuse the same text with the same codes.
"""
from __future__ import annotations

import weakref
from pathlib import Path
from typing import Any, Callable, Mapping

from ..dsl.binding import bind_operation, check_block, check_sequence, parse_color
from ..errors import GrammarError
from ..expr_eval import FunctionTable, compile_expr, constant, is_constant
from ..ir import expr as E
from ..ir import split as S
from ..ir.base import Span
from ..ir.grammar import Grammar
from .seeds import label_of
from .lookup import asset_dirs_of, find_asset, resolving
from .attrs import LOT_PENDING, AttrInfo, ValueEnv, check_attr_value, lot_order, lot_values_step
from .static import set_targets, shape_free
from .steps import case_step, choice_step, make_block, nil_step, op_step, terminal_step

BUILTIN_NAMES = {
    "scope.sx": 0, "scope.sy": 1, "scope.sz": 2,
}
ORIGIN_NAMES = {"scope.tx": 0, "scope.ty": 1, "scope.tz": 2}  # scope origin, world coordinates


class CRule:
    """A compiled rule: display name, object type, parameters and steps."""

    __slots__ = ("name", "key", "otype", "params", "steps", "span", "label", "snippet")

    def __init__(self, name: str, key: str, otype: str | None, params: tuple[str, ...],
                 span: Span | None, snippet: str | None = None):
        self.name, self.key, self.otype, self.params = name, key, otype, params
        self.span, self.snippet = span, snippet
        self.steps: tuple = ()
        self.label = label_of("rule", key)

    def __repr__(self) -> str:
        return f"CRule({self.key})"


class Slot:
    """One entry of an operation block (a split part, a selector branch, or a repeat group)."""

    __slots__ = ("mode", "size", "sel", "body", "items", "label", "span")

    def __init__(self, mode: str, size: Callable | None = None, sel: str | None = None,
                 body: tuple = (), items: tuple = (), label: int = 0, span: Span | None = None):
        self.mode, self.size, self.sel, self.body, self.items = mode, size, sel, body, items
        self.label, self.span = label, span


class CompiledGrammar:
    """The runnable form of a split grammar (one snippet binding, one set of registries).
    Immutable once compiled: per-derivation values live in the derivation (see module doc)."""

    def __init__(self, grammar: Grammar):
        # no strong reference to the grammar or the registries: compile caches are keyed by
        # them weakly, and an entry must not keep its own key alive
        self._grammar = weakref.ref(grammar)
        self.name = grammar.name
        self.rules: dict[str, CRule] = {}
        self.axiom: CRule | None = None
        self.attrs: dict[str, AttrInfo] = {}
        self.consts: dict[str, Callable] = {}
        self.warnings: list[tuple[str, Span | None]] = []
        self.bindings: dict[str, str] = {}  # anchor -> snippet name
        self.base_dir = str(Path(grammar.source_path).parent) if grammar.source_path else None
        self.asset_dirs = asset_dirs_of(grammar, self.base_dir)  # `asset_dir` statements, absolute
        self._defaults: dict[str, Any] | None = None
        # attrs and consts whose value reads the shape, in dependency order: evaluated on the
        # lot by the start rule's first step (CGA evaluates them on the initial shape)
        self.lot_keys: tuple[str, ...] = ()
        # whether an expression asks inside()/overlaps()/touches(): derivations then keep
        # their terminals as occluders (grammarkit/split/occlusion.py)
        self.uses_occlusion = False

    @property
    def grammar(self) -> Grammar | None:
        """The grammar this was compiled from (None once nothing else holds it)."""
        return self._grammar()

    # -- values ----------------------------------------------------------------------------
    def resolve_attr_keys(self, name: str) -> list[str]:
        """Keys an `--set name=...` refers to: an exact key, else every attr with that name."""
        if name in self.attrs:
            return [name]
        return [k for k, a in self.attrs.items() if a.name == name]

    def default_values(self) -> dict[str, Any]:
        """Every attr and const at its default (run seed 0): what overrides are checked
        against (types, ranges and enums whose bounds may use other values)."""
        found = self._defaults
        if found is None:
            found = self._evaluate({}, 0)
            self._defaults = found  # a benign race: every thread computes the same dict
        return found

    def evaluate_values(self, overrides: Mapping[str, Any] | None, seed: int) -> dict[str, Any]:
        """The values of one derivation: attrs (with `overrides`, checked) and consts, as a new
        dict. Nothing is stored in the compiled grammar."""
        checked: dict[str, Any] = {}
        if overrides:
            env = None
            for name, value in overrides.items():
                keys = self.resolve_attr_keys(name)
                if not keys:
                    known = ", ".join(sorted(self.attrs)) or "none"
                    raise GrammarError(f"unknown attr {name!r} (known attrs: {known})", None,
                                       code="unknown-attr")
                if env is None:
                    env = ValueEnv(0, dict(self.default_values()))
                for key in keys:
                    checked[key] = check_attr_value(self.attrs[key], value, env)
        return self._evaluate(checked, seed)

    def _evaluate(self, fixed: Mapping[str, Any], seed: int) -> dict[str, Any]:
        env = ValueEnv(seed)
        V = env.values
        pending: dict[str, Callable] = {}
        for key, info in self.attrs.items():
            pending[key] = info.default
        for name, f in self.consts.items():
            pending[name] = f
        for key, value in fixed.items():
            V[key] = value
            pending.pop(key, None)
        todo = tuple(k for k in self.lot_keys if k not in fixed)
        # evaluate in dependency order: retry what needed a value not computed yet
        while pending:
            progress = False
            for key in list(pending):
                try:
                    V[key] = pending[key](env)
                except KeyError:
                    continue
                del pending[key]
                progress = True
            if not progress:
                key = next(iter(pending))
                info = self.attrs.get(key)
                span = info.attr.span if info else None
                raise GrammarError(f"cannot evaluate {key!r}: its value depends on itself "
                                   f"(a cycle among {', '.join(sorted(pending))})", span, code="cycle")
        if todo:
            # evaluated here without a shape (geometry and scope read 0), again on the lot
            V[LOT_PENDING] = (todo, seed)
        return V

    def attr_values(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """The attrs (not the consts) of a derivation's values, in declaration order."""
        return {k: values[k] for k in self.attrs}


# ---------------------------------------------------------------------------------------------
def compile_grammar(grammar: Grammar, registries: Any, choices: Mapping[str, str] | None = None,
                    start: str | None = None) -> CompiledGrammar:
    """Compile `grammar` with the operations and functions of `registries` (a
    grammarkit.registry.Registries); no cache here (grammarkit.split.compile caches)."""
    if registries is None:
        raise TypeError("compile_grammar: registries= is required (grammarkit.registry.Registries)")
    return _Compiler(grammar, registries, choices or {}).run(start)


class _Scope:
    """Where a rule body lives: the grammar itself or a bound snippet copy."""

    def __init__(self, anchor: str | None = None, snippet: S.Snippet | None = None):
        self.anchor = anchor
        self.snippet = snippet
        self.local_rules = {r.name for r in snippet.rules} if snippet else set()
        self.local_attrs = {a.name for a in snippet.attrs} if snippet else set()

    def rule_key(self, name: str) -> str | None:
        if self.snippet is None:
            return None
        if name == "Start":
            return self.anchor
        if name in self.local_rules:
            return f"{self.anchor}::{name}"
        return None


class _Compiler:
    def __init__(self, grammar: Grammar, registries: Any, choices: Mapping[str, str]):
        self.g = grammar
        self.registries = registries
        self.ops = registries.operations
        self.functions = registries.functions
        self.out = CompiledGrammar(grammar)
        self.top = {}
        for r in grammar.rules:
            if r.name in self.top:
                raise GrammarError(f"rule {r.name!r} is defined twice", r.span, code="duplicate-rule")
            self.top[r.name] = r
        self.snippets = {s.name: s for s in grammar.snippets}
        self.uses: dict[str, str] = {}
        self.use_spans: dict[str, Span | None] = {}
        for u in grammar.uses:
            self._check_snippet(u.snippet, u.span)
            self.uses[u.anchor] = u.snippet
            self.use_spans[u.anchor] = u.span
        for anchor, snip in choices.items():
            self._check_snippet(snip, None)
            self.uses[anchor] = snip
        self.defaults: dict[str, str] = {}
        for d in grammar.defaults:
            self._check_snippet(d.snippet, d.span)
            self.defaults[d.object_type] = d.snippet
        self.global_names = {a.name for a in grammar.attrs} | {c.name for c in grammar.consts}
        # A grammar attr named like a snippet attr configures it: the copy uses the grammar's
        # attr (value and range) instead of its own, so a building can tune its snippets.
        self.grammar_attrs = {a.name for a in grammar.attrs}
        # attrs that `set(attr, value)` changes somewhere: their value depends on the shape, so
        # expressions reading them are not shape-free (split layouts are not cached for them)
        self.set_attrs = frozenset(set_targets(grammar))
        self.pending: list[tuple[CRule, S.Rule, _Scope]] = []
        # user functions (`func`): bodies see the grammar's attrs, consts and the built-in values
        # of the shape the calling expression is evaluated on; compiled once, at their first call
        self.user = FunctionTable(grammar.functions, self._resolver(_Scope(), ()), self.functions,
                                  prepare=self._occlusion_refs) if grammar.functions else None
        self.user_names = frozenset(self.user.overloads) if self.user else frozenset()

    def _check_snippet(self, name: str, span: Span | None) -> None:
        if name not in self.snippets:
            known = ", ".join(sorted(self.snippets)) or "none"
            raise GrammarError(f"unknown snippet {name!r} (known: {known})", span, code="unknown-snippet")

    # -- entry -------------------------------------------------------------------------------
    def run(self, start: str | None) -> CompiledGrammar:
        out = self.out
        value_scope = _Scope()
        for a in self.g.attrs:
            out.attrs[a.name] = self._attr_info(a.name, a, None, None, value_scope)
        for c in self.g.consts:
            out.consts[c.name] = self._expr(c.value, value_scope, ())
        if start is None:
            if not self.top:
                raise GrammarError("the grammar has no rules to start from", None, code="no-axiom")
            start = next(iter(self.top))
        axiom = self._lookup(start, _Scope(), None)
        if axiom is None:
            raise GrammarError(f"start rule {start!r} is not defined", None, code="no-axiom")
        if axiom.params:
            # the lot is handed to the start rule without arguments: a rule with parameters
            # would read missing ones (CityEngine's start rules take none either)
            raise GrammarError(
                f"start rule {axiom.name!r} takes parameters ({', '.join(axiom.params)}): the start "
                "rule is applied to the lot without arguments", axiom.span, code="axiom-params",
                hint="start from a rule without parameters (put it first, or pass start=...)")
        out.axiom = axiom
        while self.pending:
            crule, rule, scope = self.pending.pop()
            crule.steps = self._seq(rule.body, scope, rule.params, crule)
        self._lot_values(axiom)
        return out

    def _lot_values(self, axiom: CRule) -> None:
        """Attrs and consts that read the shape are evaluated on the lot, before the start
        rule's first operation (CGA's attrs are evaluated once, on the initial shape)."""
        out = self.out
        exprs: dict[str, tuple[Any, str | None]] = {k: (i.attr.value, i.scope) for k, i in out.attrs.items()}
        for c in self.g.consts:
            exprs.setdefault(c.name, (c.value, None))
        out.lot_keys = lot_order(exprs, frozenset(self.user_names))
        if out.lot_keys:
            fns = {k: (out.attrs[k].default if k in out.attrs else out.consts[k]) for k in out.lot_keys}
            axiom.steps = (lot_values_step(fns),) + axiom.steps

    def _attr_info(self, key: str, a: S.Attr, anchor: str | None, snippet: str | None,
                   scope: _Scope) -> AttrInfo:
        info = AttrInfo(key, a.name, a, anchor, snippet, self._expr(a.value, scope, ()))
        if a.range is not None:
            info.lo = self._expr(a.range[0], scope, ())
            info.hi = self._expr(a.range[1], scope, ())
        if a.enum is not None:
            info.choices = tuple(self._expr(x, scope, ()) for x in a.enum)
        return info

    # -- rules and names -----------------------------------------------------------------------
    def _lookup(self, name: str, scope: _Scope, span: Span | None) -> CRule | None:
        """The compiled rule a successor `name` refers to from `scope` (None: undefined)."""
        rules = self.out.rules
        key = scope.rule_key(name)
        if key is not None:
            if key not in rules:
                if name == "Start":
                    return self._bind(scope.anchor, scope.snippet.name, span)  # type: ignore[arg-type]
                rule = next(r for r in scope.snippet.rules if r.name == name)  # type: ignore[union-attr]
                cr = CRule(name, key, scope.snippet.object_type, rule.params, rule.span, scope.snippet.name)
                rules[key] = cr
                self.pending.append((cr, rule, scope))
            return rules[key]
        if name in rules:
            return rules[name]
        if name in self.uses:
            if name in self.top:
                self.out.warnings.append((f"rule {name!r} is also bound by `use {self.uses[name]} as "
                                          f"{name}`; the snippet wins", self.top[name].span))
            return self._bind(name, self.uses[name], span)
        if name in self.top:
            rule = self.top[name]
            cr = CRule(name, name, None, rule.params, rule.span)
            rules[name] = cr
            self.pending.append((cr, rule, _Scope()))
            return cr
        if name in self.defaults:
            return self._bind(name, self.defaults[name], span)
        return None

    def _bind(self, anchor: str, snippet_name: str, span: Span | None) -> CRule:
        snip = self.snippets[snippet_name]
        start = next((r for r in snip.rules if r.name == "Start"), None)
        if start is None:
            raise GrammarError(f"snippet {snippet_name!r} has no Start rule", snip.span, code="no-start")
        scope = _Scope(anchor, snip)
        self.out.bindings[anchor] = snippet_name
        for a in snip.attrs:
            if a.name in self.grammar_attrs:
                continue
            key = f"{anchor}.{a.name}"
            self.out.attrs[key] = self._attr_info(key, a, anchor, snippet_name, _Scope(anchor, snip))
        cr = CRule(anchor, anchor, snip.object_type, start.params, start.span, snippet_name)
        self.out.rules[anchor] = cr
        self.pending.append((cr, start, scope))
        return cr

    # -- expressions ---------------------------------------------------------------------------
    def _expr(self, e: Any, scope: _Scope, params: tuple[str, ...]) -> Callable:
        e = self._occlusion_refs(e)
        f = compile_expr(e, self._resolver(scope, params), self.functions, user=self.user)
        try:
            f._shape_free = shape_free(e, params, self.set_attrs, self.user_names)  # type: ignore[attr-defined]
        except AttributeError:  # a shared constant closure: constants are shape-free anyway
            pass
        return f

    def _resolver(self, scope: _Scope, params: tuple[str, ...]) -> Callable:
        """How the names of an expression in `scope` (with rule parameters `params`) read the
        shape it is evaluated on."""
        glob = self.global_names
        grammar_attrs = self.grammar_attrs

        def resolve(name: str, span: Span | None) -> Callable | None:
            if name in params:
                i = params.index(name)
                return lambda s, _i=i: s.params[_i]
            if name in BUILTIN_NAMES:
                i = BUILTIN_NAMES[name]
                return lambda s, _i=i: s.sz[_i]
            if name in ORIGIN_NAMES:
                i = ORIGIN_NAMES[name]
                return lambda s, _i=i: s.o[_i]
            if name in ("split.index", "comp.index"):
                return lambda s: s.si
            if name in ("split.total", "comp.total"):
                return lambda s: s.st
            if name == "comp.sel":
                return lambda s: s.csel if type(s) is not ValueEnv else ""
            if name.startswith("occlusion:"):
                from .occlusion import query

                _kind, kind, target, label = name.split(":", 3)
                lab = label or None
                return lambda s, _k=kind, _t=target, _l=lab: (
                    query(_k, s, _t, _l) if type(s) is not ValueEnv else False)
            if name.startswith("geometry."):
                from .geometry_queries import GEOMETRY_QUERIES

                query = GEOMETRY_QUERIES.get(name)
                if query is not None:
                    # attr and const values are evaluated without a shape (ValueEnv: the scope
                    # is 0 there too), so the geometry reads as 0 / false in them
                    return lambda s, _q=query: _q(s) if type(s) is not ValueEnv else 0
            # attrs and consts: the derivation's values, carried by the shape evaluated on
            if name in scope.local_attrs and name not in grammar_attrs:
                key = f"{scope.anchor}.{name}"
                return lambda s, _k=key: s.values[_k]
            if name in glob:
                return lambda s, _k=name: s.values[_k]
            return None
        return resolve

    # -- sequences -----------------------------------------------------------------------------
    def _seq(self, seq: S.Seq, scope: _Scope, params: tuple[str, ...], rule: CRule) -> tuple:
        _raise_first(check_sequence(seq))
        items = list(seq.items)
        steps: list[Callable] = []
        i = 0
        n = len(items)
        while i < n:
            item = items[i]
            last = i == n - 1
            if isinstance(item, S.OpCall) and item.name == "repeat":
                steps.append(self._repeat(item, items[i + 1], scope, params, rule, len(steps)))
                i += 2
                continue
            steps.append(self._item(item, scope, params, rule, last, len(steps)))
            i += 1
        return tuple(steps)

    def _item(self, item: Any, scope: _Scope, params: tuple[str, ...], rule: CRule, last: bool,
              index: int) -> Callable:
        if isinstance(item, S.OpCall):
            return self._op(item, scope, params, rule, index)
        if isinstance(item, S.Successor):
            return self._successor(item.name, item.args, item.span, scope, params, last)
        if isinstance(item, S.Terminal):
            return terminal_step(item.name, last)
        if isinstance(item, S.Nil):
            return nil_step
        if isinstance(item, S.Push):
            body = self._seq(item.body, scope, params, rule)

            def push(ctx: Any, s: Any, _body=body) -> Any:
                ctx.push(s.copy(), _body)
                return s
            return push
        if isinstance(item, S.Case):
            arms = tuple((self._expr(a.cond, scope, params), self._seq(a.body, scope, params, rule))
                         for a in item.arms)
            other = self._seq(item.otherwise, scope, params, rule) if item.otherwise is not None else None
            return case_step(arms, other)
        if isinstance(item, S.Choice):
            arms = tuple((self._expr(a.percent, scope, params), self._seq(a.body, scope, params, rule),
                          a.span) for a in item.arms)
            other = self._seq(item.otherwise, scope, params, rule) if item.otherwise is not None else None
            return choice_step(arms, other, item.span)
        raise GrammarError(f"unexpected item {type(item).__name__}", getattr(item, "span", None))

    def _successor(self, name: str, args: tuple, span: Span | None, scope: _Scope,
                   params: tuple[str, ...], last: bool) -> Callable:
        target = self._lookup(name, scope, span)
        if target is None:
            self.out.warnings.append((f"no rule for {name!r}: it becomes a leaf", span))
            return terminal_step(name, last)
        if len(args) != len(target.params):
            raise GrammarError(f"rule '{name}' takes {len(target.params)} argument(s), got {len(args)}",
                               span, code="successor-arity")
        fns = tuple(self._expr(a, scope, params) for a in args)
        if last:
            def succ_last(ctx: Any, s: Any) -> None:
                ctx.enter(s, target, tuple(f(s) for f in fns) if fns else ())
                return None
            return succ_last

        def succ(ctx: Any, s: Any) -> Any:
            ctx.enter(s.copy(), target, tuple(f(s) for f in fns) if fns else ())
            return s
        return succ

    def _args(self, call: S.OpCall, spec: Any, scope: _Scope, params: tuple[str, ...]) -> list:
        """Compiled arguments in the spec's parameter order (defaults filled in, variadic extras
        appended), bound by the binder `grammarkit check` uses."""
        binding = bind_operation(call, spec, registries=self.registries)
        _raise_first(binding.problems)
        fns: list[Callable] = []
        for bound in binding.arguments:
            p = bound.param
            if bound.value is None:
                fns.append(constant(p.default))
            else:
                fns.append(self._arg(bound.value, p, call, bound.span, scope, params))
        fns.extend(self._expr(v, scope, params) for v in binding.extra)
        return fns

    def _arg(self, value: Any, p: Any, call: S.OpCall, span: Span | None, scope: _Scope,
             params: tuple[str, ...]) -> Callable:
        if p.type in ("axis", "selector", "name"):
            return constant(value.name)  # the binder checked it is a bare name it accepts
        f = self._expr(value, scope, params)
        if p.type == "color" and is_constant(f):
            color = parse_color(f._value)  # type: ignore[attr-defined]
            if color is None:
                raise GrammarError(f"argument '{p.name}' of {call.name} must be a colour '#rrggbb' or "
                                   f"'#rgb', got {f._value!r}", span, code="bad-argument-value")  # type: ignore[attr-defined]
            return constant(color)
        return f

    def _op(self, call: S.OpCall, scope: _Scope, params: tuple[str, ...], rule: CRule, index: int) -> Callable:
        spec = self.ops.get(call.name)
        if spec is None:
            known = ", ".join(sorted(self.ops))
            raise GrammarError(f"unknown operation '{call.name}'", call.span, hint=f"known operations: {known}",
                               code="unknown-operation")
        apply = spec.apply
        if apply is None:
            raise GrammarError(f"operation {call.name!r} (plugin {spec.plugin!r}) has no implementation",
                               call.span, code="operation-without-apply")
        # a plugin's operation is named with its plugin in errors (built-ins carry their spec,
        # grammarkit.split.ops.helpers.operation)
        plugin = "" if hasattr(apply, "spec") else (spec.plugin or "?")
        fns = self._args(call, spec, scope, params)
        if call.name == "set" and fns:
            fns[0] = constant(self._set_key(call, scope))
        # an `expr` parameter is handed over compiled but unevaluated: the operation evaluates
        # it itself, on shapes of its own (setbackPerEdge, envelopePerEdge: once per edge)
        for k, p in enumerate(spec.params):
            if p.type == "expr" and k < len(fns):
                fns[k] = constant(fns[k])
        # file names are relative to the grammar file that says them: made absolute here
        path_arg = 0 if call.name in ("i", "texture") else (
            1 if call.name == "set" and len(fns) > 1 and str(fns[0](None)).startswith("material.")
            and str(fns[0](None)).endswith("map") else None)
        # (or in one of the grammar's asset_dir folders: grammarkit/split/lookup.py); a computed
        # name is looked up when the shape is derived
        if path_arg is not None and path_arg < len(fns):
            base = Path(call.span.file).parent if call.span and call.span.file else (
                Path(self.out.base_dir) if self.out.base_dir else Path("."))
            if not is_constant(fns[path_arg]):
                fns[path_arg] = resolving(fns[path_arg], base, self.out.asset_dirs)
            elif isinstance(fns[path_arg](None), str):
                fns[path_arg] = constant(find_asset(fns[path_arg](None), base, self.out.asset_dirs))
        _raise_first(check_block(call, spec))
        block = None
        if call.block is not None:
            block = self._block(call, spec, scope, params, rule, index)
        return op_step(apply, tuple(fns), block, call.span, call.name, plugin)

    def _occlusion_refs(self, e: Any) -> Any:
        """CGA's occlusion queries `inside("intra", "label")` as references the resolver binds
        to the shape evaluated on (their arguments must be literal strings)."""
        from .occlusion import OCCLUSION_FUNCTIONS, TARGETS

        if isinstance(e, E.Call) and e.func in OCCLUSION_FUNCTIONS:
            args = list(e.args)
            if len(args) > 2 or not all(isinstance(a, E.Str) for a in args):
                raise GrammarError(f"{e.func}() takes a target (\"intra\", \"inter\" or \"all\") and a label, "
                                   "as literal strings", e.span, code="bad-argument-value")
            target = args[0].value if args else "intra"
            if target not in TARGETS:
                raise GrammarError(f"{e.func}(): the target must be \"intra\", \"inter\" or \"all\", got "
                                   f"{target!r}", e.span, code="bad-argument-value")
            label = args[1].value if len(args) > 1 else ""
            self.out.uses_occlusion = True
            return E.Ref(name=f"occlusion:{e.func}:{target}:{label}", span=e.span)
        if isinstance(e, (E.Call, E.Unary, E.Binary, E.Vector)):
            updates = {}
            for field_name in ("args", "items"):
                v = getattr(e, field_name, None)
                if v is not None:
                    new = tuple(self._occlusion_refs(x) for x in v)
                    if any(a is not b for a, b in zip(new, v)):
                        updates[field_name] = new
            for field_name in ("operand", "left", "right"):
                v = getattr(e, field_name, None)
                if v is not None:
                    new = self._occlusion_refs(v)
                    if new is not v:
                        updates[field_name] = new
            return e.model_copy(update=updates) if updates else e
        return e

    def _set_key(self, call: S.OpCall, scope: _Scope) -> str:
        """The values key of the attr `set(name, ...)` changes (a snippet's own attr, or the
        grammar's); a const, a parameter or an unknown name is an error at the name."""
        ref = call.args[0].value
        name = ref.name
        if name.startswith("material."):  # CGA's material attributes (grammarkit.split.ops.texturing)
            return name
        if name in scope.local_attrs and name not in self.grammar_attrs:
            return f"{scope.anchor}.{name}"
        if name in self.grammar_attrs:
            return name
        what = "a const" if name in self.global_names else "not an attr"
        raise GrammarError(f"set() changes attrs: {name!r} is {what}", ref.span or call.span,
                           code="set-not-attr", hint="declare it with `attr` to change it per shape")

    def _block(self, call: S.OpCall, spec: Any, scope: _Scope, params: tuple[str, ...], rule: CRule,
               index: int) -> tuple:
        sizes = spec.block in ("sizes", "optional-sizes")

        def build(items: tuple, path: str) -> tuple:
            out = []
            for j, it in enumerate(items):
                lab = label_of(rule.key, index, path, j) << 12
                if isinstance(it, S.Repeat):
                    out.append(Slot("repeat", items=build(it.items, f"{path}.{j}"), label=lab, span=it.span))
                    continue
                body = self._seq(it.body, scope, params, rule)
                if sizes:
                    out.append(Slot(it.mode, size=self._expr(it.key, scope, params), body=body,
                                    label=lab, span=it.span))
                elif isinstance(it.key, E.Num):  # an index selector (check_block checked it)
                    out.append(Slot("sel", sel=int(it.key.value), body=body, label=lab, span=it.span))
                else:  # check_block made sure the key is one of the spec's selectors
                    out.append(Slot("sel", sel=it.key.name, body=body, label=lab, span=it.span))
            return tuple(out)
        return make_block(build(call.block or (), ""))

    def _repeat(self, call: S.OpCall, pat: S.Pattern, scope: _Scope, params: tuple[str, ...],
                rule: CRule, index: int) -> Callable:
        spec = self.ops.get("repeat")
        if spec is None or spec.apply is None:
            raise GrammarError("operation 'repeat' is not available", call.span)
        fns = self._args(call, spec, scope, params)
        axis_fn, size_fn, sep_fn = fns[0], fns[1], fns[2]
        span = pat.span

        def succ_body(name: str) -> tuple:
            return (self._successor(name, (), span, scope, params, True),)
        group = []
        for j, name in enumerate(pat.group):
            lab = label_of(rule.key, index, "pattern", j) << 12
            if j == 0:
                group.append(Slot("float", size=size_fn, body=succ_body(name), label=lab, span=span))
            else:
                group.append(Slot("abs", size=sep_fn, body=succ_body(name), label=lab, span=span))
        slots = [Slot("repeat", items=tuple(group), label=label_of(rule.key, index, "pattern-group") << 12,
                      span=span)]
        if pat.tail is not None:
            slots.append(Slot("float", size=size_fn, body=succ_body(pat.tail),
                              label=label_of(rule.key, index, "pattern-tail") << 12, span=span))
        return op_step(spec.apply, (axis_fn, size_fn, sep_fn), make_block(slots), call.span, "repeat")


def _raise_first(problems: list) -> None:
    """The compiler stops at the first problem the binder found (`check` lists them all)."""
    if problems:
        d = problems[0]
        raise GrammarError(d.message, d.span, hint=d.hint, code=d.code)


__all__ = ["AttrInfo", "CRule", "CompiledGrammar", "Slot", "ValueEnv", "check_attr_value", "compile_grammar"]
