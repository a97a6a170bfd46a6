"""A parsed CGA file -> grammarkit IR, recording what happened to every construct.

The translation is syntax-directed and frame-aware: each rule is translated for the kind of
shape it receives (frames.py), starting from the start rule with the lot (`Y`), and a rule
reached with both kinds is emitted twice (`Name` and `Name_z`/`Name_y`). The output is IR
only; text comes from grammarkit's printer (importer.py).

The class is assembled from one mixin per concern: declarations (collect, imports), values
(attrs, consts), recursion (recursive functions), body (rules, items, operation calls) and
entries (split/comp blocks, assets); the operations themselves are handlers (handlers/),
registered in context.HANDLERS.

CGA semantics kept on purpose:
- an operation with a `{ }` block that is not the last item of its sequence leaves the
  current shape in place for the items after it (CGA keeps the shape), so it becomes a
  push `[ op {...} ]` in grammarkit;
- a name without a rule is a leaf (`Name.`), as in CGA;
- `offset(d) comp(f) { inside: A | border: B }` (CGA's way to use an offset's parts) is
  grammarkit's `offset(d) { inside: A | border: B }`; `offset(d, border)` keeps the border.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from lark import Token, Tree

from ...errors import Diagnostic
from ...ir import (
    Grammar,
    Rule,
)
from ...ir.base import Span
from ..expressions import (
    ExprContext,
    Function,
    span_of,
)
from ..names import gk_name
from ..report import Construct, ImportReport
from ..tables import find_table, read_table
from .body import BodyMixin
from .declarations import DeclarationsMixin
from .entries import EntriesMixin
from .model import (
    RuleDef,
    ValueDef,
)
from .recursion import FunctionsMixin
from .values import ValuesMixin


class Translator(DeclarationsMixin, ValuesMixin, FunctionsMixin, BodyMixin, EntriesMixin):
    """Translates one parsed CGA file (and the files it imports) to a grammarkit Grammar."""

    def __init__(self, tree: Tree, filename: str | None, source: str, *,
                 asset_dirs: tuple[Path, ...] = (), missing_assets: str = "keep",
                 operations: frozenset[str] = frozenset(), project: Any = None, style: str | None = None):
        self.tree = tree
        self.project = project  # cga.project.Project: CityEngine's lookup of assets and imports
        self.style = style      # the CGA style whose attrs and rules are used (None: Default)
        self.filename = filename
        self.source = source
        self.report = ImportReport(filename)
        self.diagnostics: list[Diagnostic] = []
        self.asset_dirs = asset_dirs
        self.missing_assets = missing_assets
        self.operations = operations
        self.values: list[ValueDef] = []
        self.functions: dict[tuple[str, int], Function] = {}
        self.function_spans: dict[tuple[str, int], Span | None] = {}
        self.rules: dict[tuple[str, int], RuleDef] = {}
        self.rule_arities: dict[str, set[int]] = {}
        self.imports: dict[str, Span | None] = {}
        self.value_names: dict[str, str] = {}
        self.inlined: set[str] = set()
        self.imported_functions: set[str] = set()
        self._rule_names: dict[tuple[tuple[str, int], str], str] = {}
        self._used_names: set[str] = set()
        self._pending: list[tuple[tuple[str, int], str]] = []
        self._seen_assets: set[str] = set()
        # recursive CGA functions, emitted as grammarkit functions (see _emit_functions)
        self.emitted: dict[tuple[str, int], dict[str, Any]] = {}
        self.text_functions: set[str] = set()
        self._imported_seen: set[tuple] = set()
        self.sources: dict[str, str] = {filename: source} if filename else {}  # for carets

    # -- reporting ------------------------------------------------------------------------------
    frame_change: str | None = None  # set by a handler that changes the frame of what follows

    def _record(self, kind: str, name: str, status: str, span: Span | None, *,
                feature: str | None = None, message: str | None = None, counting: bool = True) -> None:
        if not counting:
            if status != "translated" and span is not None and span.file and span.file != self.filename:
                self._imported_warning(Construct(kind, name, status, span, feature, message))
            return
        self.report.add(Construct(kind, name, status, span, feature, message))
        if status != "translated":
            verb = "approximated" if status == "approximated" else "not translated"
            self.diagnostics.append(Diagnostic(
                "warning", f"{verb}: {message}", span, code=f"cga-{status}",
                hint=f"missing feature: {feature}" if feature else None))

    def _imported_warning(self, construct: Construct) -> None:
        """A warned construct of an imported file: counted in that file's own report (its
        `import-cga` of its own), but never silent here: a located warning (in that file) and
        the report's `imported` list, once per place and message (a rule translated for two
        frames, or a file imported twice, says it once)."""
        s = construct.span
        key = (s.file, s.line, s.column, construct.message)
        if key in self._imported_seen:
            return
        self._imported_seen.add(key)
        self.report.imported.append(construct)
        verb = "approximated" if construct.status == "approximated" else "not translated"
        self.diagnostics.append(Diagnostic(
            "warning", f"{verb}: {construct.message}", s, code=f"cga-{construct.status}",
            hint=f"missing feature: {construct.feature}" if construct.feature else None))

    def _span(self, node: Any) -> Span | None:
        return span_of(node, self.filename)

    # -- names ----------------------------------------------------------------------------------
    def _claim(self, base: str) -> str:
        name = base
        k = 2
        while name in self._used_names:
            name = f"{base}_{k}"
            k += 1
        self._used_names.add(name)
        return name

    def _rule_name(self, key: tuple[str, int], frame: str) -> str:
        if (key, frame) in self._rule_names:
            return self._rule_names[(key, frame)]
        name, arity = key
        base = gk_name(name)
        if base in self.operations:
            base += "_"
        if len(self.rule_arities.get(name, ())) > 1 and arity != min(self.rule_arities[name]):
            base = f"{base}_{arity}"
        if any(k == key for k, _ in self._rule_names):
            base = f"{base}_{frame.lower()}"
        gk = self._claim(base)
        self._rule_names[(key, frame)] = gk
        self._pending.append((key, frame))
        return gk

    # -- the whole file ---------------------------------------------------------------------------
    def translate(self) -> Grammar:
        self.collect()
        for v in self.values:
            self.value_names[v.name] = self._claim(gk_name(v.name))
        functions_out = self._emit_functions()
        statements: list[Any] = [self._value(v) for v in self.values]
        statements.extend(functions_out)
        if not self.rules:
            self.diagnostics.append(Diagnostic("error", "the CGA file has no rules", Span(
                file=self.filename, line=1, column=1), code="cga-no-rules"))
        starts = [k for k, r in self.rules.items() if r.start] or self._default_start()
        rules_out: list[Rule] = []
        translated_keys: set[tuple[str, int]] = set()
        for key in starts:
            self._rule_name(key, "Y")
        done: set[tuple[tuple[str, int], str]] = set()
        while True:
            while self._pending:
                key, frame = self._pending.pop(0)
                if (key, frame) in done:
                    continue
                done.add((key, frame))
                rules_out.append(self._rule(key, frame, counting=key not in translated_keys
                                            and not self.rules[key].imported))
                translated_keys.add(key)
            # rules nothing calls are translated too (a file of rules for other files); those
            # of imported files only when called
            unreached = [k for k in self.rules if k not in translated_keys and not self.rules[k].imported]
            if not unreached:
                break
            self._rule_name(unreached[0], "Y")
        statements.extend(rules_out)
        self._functions_report()
        name = gk_name(Path(self.filename).stem) if self.filename else "cga"
        return Grammar(name=name, statements=tuple(statements),
                       comments=(f" Imported from CGA by `grammarkit import-cga`"
                                 f"{': ' + os.path.basename(self.filename) if self.filename else ''}",),
                       span=Span(file=self.filename, line=1, column=1))

    def _default_start(self) -> list:
        """Without @StartRule: the first rule, unless it takes parameters (a lot gets no
        arguments); then, of the rules without parameters that no other rule calls (roots of
        the file's call graph), the one that reaches the most rules."""
        keys = [k for k, r in self.rules.items() if not r.imported]
        if not keys:
            return []
        if not self.rules[keys[0]].params:
            return keys[:1]
        names = {k[0] for k in keys}
        calls: dict[str, set[str]] = {}
        for key, r in self.rules.items():
            toks = r.body.scan_values(lambda v: isinstance(v, Token)) if isinstance(r.body, Tree) else ()
            calls.setdefault(key[0], set()).update(t.value for t in toks if t.value in names and t.value != key[0])
        called = set().union(*calls.values()) if calls else set()

        def reach(name: str) -> int:
            seen, todo = {name}, [name]
            while todo:
                for nxt in calls.get(todo.pop(), ()):
                    if nxt not in seen:
                        seen.add(nxt)
                        todo.append(nxt)
            return len(seen)
        plain = [k for k in keys if not self.rules[k].params]
        pool = [k for k in plain if k[0] not in called] or plain
        chosen = max(pool, key=lambda k: (reach(k[0]), -keys.index(k))) if pool else None
        first = self.rules[keys[0]]
        if chosen is None or reach(chosen[0]) * 4 < len(names):
            # no parameterless rule leads to most of the file (a library of rules called with
            # arguments from another file): keep the first rule; deriving then says that the
            # start rule takes parameters, rather than deriving a small side branch
            self._record("start-rule", first.name, "dropped", first.span, feature="start:params",
                         message=f"the first rule {first.name!r} takes parameters and no rule without "
                         "parameters leads to most of the file: the file needs a start rule that "
                         "calls it with arguments", counting=True)
            return keys[:1]
        self._record("start-rule", first.name, "approximated", first.span, feature="start:params",
                     message=f"the first rule {first.name!r} takes parameters and cannot start from "
                     f"the lot: {chosen[0]!r} (the rule without parameters that reaches the most "
                     "rules) is the start rule", counting=True)
        return [chosen]

    def _ctx(self, frame: str, params: dict[str, str]) -> ExprContext:
        return ExprContext(self.filename, frame, params, self.value_names, self.functions,
                           on_inline=self.inlined.add, emitted=self.emitted,
                           text_functions=self.text_functions, read_table=self._read_table,
                           array_names=self._array_names())

    def _array_names(self) -> frozenset[str]:
        """The attrs and consts whose CGA value is an array literal or a table read (cached by
        the number of values, which only grows while declarations are collected)."""
        cached = self.__dict__.get("_array_names_cache")
        if cached is not None and cached[0] == len(self.values):
            return cached[1]
        names = frozenset(v.name for v in self.values if isinstance(v.value, Tree) and (
            v.value.data == "array" or v.value.data == "func_call" and v.value.children
            and getattr(v.value.children[0], "value", None) in ("readStringTable", "readFloatTable")))
        self._array_names_cache = (len(self.values), names)
        return names

    def _read_table(self, expr: Any) -> "tuple[str | None, list[list[str]] | None]":
        """readStringTable's file (a name the attrs' and consts' defaults give), read once per
        import (tables.py): (its name or None, its rows or None if it was not found)."""
        if self.__dict__.get("_reading_table"):
            # the consts' defaults are being collected for the file name: a table is none of them
            raise ValueError("a table read while its own file name is worked out")
        self._reading_table = True
        try:
            name = self.constant_value(expr)
        finally:
            self._reading_table = False
        if not isinstance(name, str) or not name:
            return None, None
        cache = self.__dict__.setdefault("_tables", {})
        if name not in cache:
            found = find_table(name, self.filename, self.project, self.asset_dirs)
            cache[name] = read_table(found) if found is not None else None
        return name, cache[name]

