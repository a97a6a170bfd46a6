"""The checker's split-grammar half: rule bodies (walked with grammarkit.ir.walk),
successors (a near miss of a rule is an error), operation calls bound like the compiler binds
them, snippets and their bindings, asset folders, reachability. A mixin of `Checker`, whose
definitions, values and expressions (checker.py) it uses."""
from __future__ import annotations

from typing import Any, Iterable

from ..ir import (
    Attr, Case, Choice, OpCall, Pattern, Ref, Rule, Seq, Snippet, Successor, Variants,
    block_branches, successor_names, walk, walk_seqs,
)
from ..ir.base import Span
from .binding import bind_operation, check_block, check_sequence
from .check_common import START, _num, _Scope, _where
from .suggest import NearMisses, known_hint as _known_hint

MAX_OP_NEAR_MISSES = 500  # unknown operation calls per file whose did-you-mean searches the rules


class SplitChecks:
    # -- rules -----------------------------------------------------------------------------
    def rule_target(self, name: str, scope: _Scope) -> Rule | None:
        return scope.rules.get(name) or scope.outer_rules.get(name)

    def is_defined_successor(self, name: str, scope: _Scope) -> bool:
        return (self.rule_target(name, scope) is not None or name in self.anchors
                or name in self.defaults)

    def check_rule(self, r: Rule, scope: _Scope) -> None:
        self.check_seq(r.body, scope)

    def check_seq(self, seq: Seq, scope: _Scope) -> None:
        """Every sequence and item of a body (grammarkit.ir.walk), each item checking only its
        own expressions: the walker descends into blocks, pushes and arms."""
        for nested in walk_seqs(seq):
            self.bag.items.extend(check_sequence(nested))
        for item in walk(seq):
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
        elif isinstance(item, Case):
            for arm in item.arms:
                self.check_expr(arm.cond, scope)
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
            if known and total > 100 + 1e-9:
                self.bag.error(f"stochastic percentages add up to {_num(total)}%, more than 100%",
                               item.span, code="bad-percent")
        # Push, Terminal, Nil: nothing of their own (the walk visits a push's body)

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
        # one finder per rule table (the grammar's, or a snippet's with the grammar's around it),
        # not per scope: every rule body has a scope of its own, and a finder indexes all names
        key = (id(scope.rules), id(scope.outer_rules) if scope.outer_rules else 0)
        finder = self._near_misses.get(key)
        if finder is None:
            names = set(scope.rules) | set(scope.outer_rules) | set(self.anchors) | set(self.defaults)
            # the tables are kept with the finder, so their ids stay theirs
            finder = self._near_misses[key] = (NearMisses(names), scope.rules, scope.outer_rules)
        return finder[0](name)

    def check_op(self, op: OpCall, scope: _Scope) -> None:
        spec = self.reg.operations.get(op.name)
        if spec is None:
            # a rule's near miss only changes the wording here (an unknown operation is an error
            # either way), so it is looked for in the first MAX_OP_NEAR_MISSES unknown calls
            # only: a generated file of 14,000 unknown calls checks in bounded work
            self._unknown_ops = getattr(self, "_unknown_ops", 0) + 1
            near = self.rule_near_misses(op.name, scope) if self._unknown_ops <= MAX_OP_NEAR_MISSES else []
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
        if spec.block in ("sizes", "optional-sizes"):
            self.check_block_keys(op.block, scope)

    def check_block_keys(self, block: Any, scope: _Scope) -> None:
        """The size expressions of a split block's entries (their kind is check_block's; the
        bodies are visited by the walk)."""
        for branch in block_branches(block):
            self.check_expr(branch.key, scope)

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

    def _snippet_named(self, name: str, span: Span | None) -> Snippet | None:
        """The snippet `name`, or None after a located error with a did-you-mean."""
        s = self.snippets.get(name)
        if s is None:
            self.bag.error(f"unknown snippet '{name}'", span, code="unknown-snippet",
                           hint=_known_hint("snippets", name, self.snippets))
        return s

    def check_snippet_bindings(self) -> None:
        for u in self.g.uses:
            s = self._snippet_named(u.snippet, u.span)
            if s is None:
                continue
            owners = self.object_types.get(u.anchor)
            if owners and u.anchor != s.object_type:
                self.bag.error(f"`use {u.snippet} as {u.anchor}`: {u.anchor} is an object type "
                               f"(of snippet {owners[0].name}), but {u.snippet} makes a "
                               f"{s.object_type}", u.span, code="object-type")
        for d in self.g.defaults:
            s = self._snippet_named(d.snippet, d.span)
            if s is not None and s.object_type != d.object_type:
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
                s = self._snippet_named(o.snippet, o.span or v.span)
                if s is not None and s.object_type != v.object_type:
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
                todo.extend(successor_names(r.body))
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
        variants = self.g.variants  # a filter over every statement: once, not per reached name
        while todo:
            n = todo.pop()
            if n in seen:
                continue
            seen.add(n)
            r = self.top_rules.get(n)
            if r is not None:
                todo.extend(successor_names(r.body))
                continue
            bound = []
            if n in self.anchors and self.anchors[n].snippet in self.snippets:
                bound.append(self.snippets[self.anchors[n].snippet])
            elif n in self.defaults and self.defaults[n].snippet in self.snippets:
                bound.append(self.snippets[self.defaults[n].snippet])
            for v in variants:
                if v.object_type == n:
                    bound.extend(self.snippets[o.snippet] for o in v.options if o.snippet in self.snippets)
            for s in bound:
                local = {r.name for r in s.rules}
                for name in snippet_names(s):
                    rr = next((r for r in s.rules if r.name == name), None)
                    if rr is not None:
                        todo.extend(x for x in successor_names(rr.body) if x not in local)
        for r in rules:
            if r.span is not None and self.main_file is not None and r.span.file != self.main_file:
                continue  # an imported library may hold rules this grammar does not need
            if r.name not in seen and self.top_rules.get(r.name) is r:
                self.bag.warning(f"rule '{r.name}' is never used (unreachable from the start rule "
                                 f"'{start.name}')", r.span, code="unreachable")
