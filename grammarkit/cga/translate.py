"""A parsed CGA file -> grammarkit IR, recording what happened to every construct.

The translation is syntax-directed and frame-aware: each rule is translated for the kind of
shape it receives (frames.py), starting from the start rule with the lot (`Y`), and a rule
reached with both kinds is emitted twice (`Name` and `Name_z`/`Name_y`). The output is IR
only; text comes from grammarkit's printer (importer.py).

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
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lark import Token, Tree

from ..errors import Diagnostic
from ..ir import (
    Arg, Attr, Binary, Bool, Branch, Call, Case, CaseArm, Choice, ChoiceArm, Const, Grammar, Nil, Num,
    OpCall, Function as GkFunction, Push, Ref, Repeat, Rule, Seq, Str, Successor, Terminal, Unary,
)
from ..ir.base import Span
from . import frames
from .expressions import (
    ExprContext, Function, Untranslatable, call_args, children, is_text, span_of, static_value,
    translate_expr, unquote,
)
from .names import gk_name
from .report import Construct, ImportReport

_HEAD = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_.]*)\s*(?:\(([^()]*)\))?\s*(?:-->|=)\s*\Z", re.S)

# UI annotations of attrs and rules: no geometric meaning (listed as ignored in the report).
_UI_ANNOTATIONS = {"@Order", "@Group", "@Description", "@Hidden", "@Color", "@Distance",
                   "@File", "@Directory", "@Angle", "@Percent", "@Handle", "@InPlace",
                   "@Enabled", "@Location", "@ValueRange", "@Macro"}

# CGA operations grammarkit has no counterpart for yet. They are dropped with a warning whose
# feature is `op:<name>`; listed here only to word the message.
_TEXTURING = {"copyUV", "insertAlongUV", "setNormals", "softenNormals"}
_METADATA: set[str] = set()  # (print is translated: grammarkit has print())


@dataclass
class RuleDef:
    name: str
    params: tuple[str, ...]
    body: Tree
    span: Span | None
    start: bool = False
    annotations: list = field(default_factory=list)
    imported: bool = False  # from an imported file (counted in that file's own report)


@dataclass
class ValueDef:
    kind: str            # "attr" | "const"
    name: str
    value: Any
    span: Span | None
    annotations: list
    imported: bool = False  # declared in an imported file (counted in that file's own report)


@dataclass
class _RuleCtx:
    key: tuple[str, int]
    gk: str
    params: dict[str, str]
    counting: bool


class Translator:
    def __init__(self, tree: Tree, filename: str | None, source: str, *,
                 asset_dirs: tuple[Path, ...] = (), missing_assets: str = "keep",
                 operations: frozenset[str] = frozenset()):
        self.tree = tree
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

    # -- reporting ------------------------------------------------------------------------------
    frame_change: str | None = None  # set by a handler that changes the frame of what follows

    def _record(self, kind: str, name: str, status: str, span: Span | None, *,
                feature: str | None = None, message: str | None = None, counting: bool = True) -> None:
        if not counting:
            return
        self.report.add(Construct(kind, name, status, span, feature, message))
        if status != "translated":
            verb = "approximated" if status == "approximated" else "not translated"
            self.diagnostics.append(Diagnostic(
                "warning", f"{verb}: {message}", span, code=f"cga-{status}",
                hint=f"missing feature: {feature}" if feature else None))

    def _span(self, node: Any) -> Span | None:
        return span_of(node, self.filename)

    # -- declarations ---------------------------------------------------------------------------
    def collect(self) -> None:
        for node in self.tree.children:
            if node.data == "version":
                self.report.ignored["version"] += 1
                continue
            annotations = [c for c in node.children if isinstance(c, Tree) and c.data == "annotation"]
            decl = node.children[-1]
            if decl.data == "import_stmt":
                self._collect_import(decl, annotations)
                continue
            kind = decl.data
            head_tok = decl.children[1] if kind in ("attr_decl", "const_decl") else decl.children[0]
            m = _HEAD.match(head_tok.value)
            name = m.group(1)
            params = _params(m.group(2))
            span = self._span(head_tok)
            if kind == "rule_decl":
                start = any(a.children[0].value == "@StartRule" for a in annotations)
                key = (name, len(params))
                if key in self.rules:
                    self.diagnostics.append(Diagnostic(
                        "warning", f"rule {name} with {len(params)} parameter(s) is defined twice; "
                        "the first definition is used", span, code="cga-duplicate"))
                    continue
                self.rules[key] = RuleDef(name, params, decl.children[1], span, start, annotations)
                self.rule_arities.setdefault(name, set()).add(len(params))
            elif m.group(2) is not None or (kind == "func_decl"):
                # `f(x) = ...` and `f = ...` (no attr/const) are functions, evaluated at each use.
                self.functions[(name, len(params))] = Function(name, params, decl.children[-1])
                self.function_spans[(name, len(params))] = span
                for a in annotations:
                    self.report.ignored[a.children[0].value] += 1
            else:
                self.values.append(ValueDef("attr" if kind == "attr_decl" else "const", name,
                                            decl.children[-1], span, annotations))

    def _collect_import(self, decl: Tree, annotations: list) -> None:
        kids = [c for c in decl.children if isinstance(c, Token)]
        alias = kids[0].value if kids[0].type == "NAME" else None
        path = unquote(kids[-1].value)
        span = self._span(decl)
        if alias:
            self.imports[alias] = span
        for a in annotations:
            self.report.ignored[a.children[0].value] += 1
        found = self._import_file(path) if alias else None
        if found is None:
            why = ("an import without a name" if not alias else
                   "the file was not found beside this one" if found is None else "")
            self._record("import", alias or path, "dropped", span, feature="import",
                         message=f"import of {path!r}: {why}; calls into it become leaves")
            return
        child, problem = self._load_import(found)
        if child is None:
            self._record("import", alias, "dropped", span, feature="import",
                         message=f"import of {path!r}: {problem}; calls into it become leaves")
            return
        overrides = {}
        args = next((c for c in decl.children if isinstance(c, Tree) and c.data == "import_args"), None)
        for arg in (args.children if args is not None else ()):
            if isinstance(arg, Tree) and arg.data == "import_set":
                overrides[arg.children[0].value] = arg.children[1]
        self._merge_import(alias, child, overrides)
        self._record("import", alias, "translated", span)

    MAX_IMPORT_DEPTH = 8

    def _import_file(self, path: str) -> Path | None:
        """The imported file: the path relative to this file's folder, else (CityEngine's
        project paths like /ESRI.lib/rules/...) a file of that name beside this one."""
        base = Path(self.filename).parent if self.filename else Path(".")
        for cand in (base / path.lstrip("/"), base / Path(path).name):
            if cand.is_file():
                return cand
        return None

    def _load_import(self, path: Path) -> tuple["Translator | None", str]:
        from .parser import parse_cga, read_cga

        chain = getattr(self, "_import_chain", ())
        key = str(path.resolve())
        if key in chain or (self.filename and key == str(Path(self.filename).resolve())):
            return None, "an import cycle"
        if len(chain) >= self.MAX_IMPORT_DEPTH:
            return None, f"imports nested more than {self.MAX_IMPORT_DEPTH} deep"
        text, diags = read_cga(path)
        if text is None:
            return None, diags[0].message if diags else "unreadable"
        parsed = parse_cga(text, str(path))
        if not parsed.ok:
            return None, "the file has syntax errors (import it on its own to see them)"
        child = Translator(parsed.tree, str(path), parsed.source, asset_dirs=self.asset_dirs,
                           missing_assets=self.missing_assets, operations=self.operations)
        child._import_chain = (*chain, key)  # type: ignore[attr-defined]
        child.collect()
        return child, ""

    def _merge_import(self, alias: str, child: "Translator", overrides: dict) -> None:
        """The imported file's declarations under `alias.` (CGA's `alias.Rule`, `alias.attr`).
        Its attrs take the value given in the import's arguments, else the value of this
        file's attr of the same name (CGA's attribute propagation), else their own."""
        names = ({k[0] for k in child.rules} | {v.name for v in child.values}
                 | {k[0] for k in child.functions})
        own_attrs = {v.name for v in self.values if v.kind == "attr"}

        def rename(node: Any, params: frozenset) -> Any:
            if isinstance(node, Token):
                tok = node
                if node.type == "NAME" and node.value in names and node.value not in params:
                    tok = node.update(value=f"{alias}.{node.value}")
                try:
                    tok.cga_file = getattr(node, "cga_file", child.filename)  # type: ignore[attr-defined]
                except AttributeError:
                    pass
                return tok
            if isinstance(node, Tree):
                kids = [rename(c, params) for c in node.children]
                out = Tree(node.data, kids, meta=node.meta)
                if not getattr(node.meta, "empty", True) and not hasattr(node.meta, "cga_file"):
                    node.meta.cga_file = child.filename  # type: ignore[attr-defined]
                return out
            return node
        for (name, n), r in child.rules.items():
            key = (f"{alias}.{name}", n)
            if key in self.rules:
                continue
            body = rename(r.body, frozenset(r.params))
            self.rules[key] = RuleDef(f"{alias}.{name}", r.params, body, r.span, False, [], imported=True)
            self.rule_arities.setdefault(key[0], set()).add(n)
        for (name, n), fn in child.functions.items():
            key = (f"{alias}.{name}", n)
            self.functions[key] = Function(key[0], fn.params, rename(fn.body, frozenset(fn.params)))
            self.function_spans[key] = child.function_spans.get((name, n))
            self.imported_functions.add(key[0])
        for v in child.values:
            if v.name in overrides:
                value = overrides[v.name]  # an expression of this file
            elif v.kind == "attr" and v.name in own_attrs:
                value = Tree("ref", [Token("NAME", v.name)])
            else:
                value = rename(v.value, frozenset())
            self.values.append(ValueDef(v.kind, f"{alias}.{v.name}", value, v.span, [], imported=True))
        for sub, span in child.imports.items():
            self.imports.setdefault(f"{alias}.{sub}", span)

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

    # -- recursive functions --------------------------------------------------------------------
    def _recursive_functions(self) -> list[tuple[str, int]]:
        """The functions that call themselves, directly or through others (in source order)."""
        calls: dict[tuple[str, int], set[tuple[str, int]]] = {}
        for key, fn in self.functions.items():
            out: set[tuple[str, int]] = set()
            if isinstance(fn.body, Tree):
                for t in fn.body.iter_subtrees():
                    if t.data == "func_call" and t.children and isinstance(t.children[0], Token):
                        out.add((t.children[0].value, len(call_args(t))))
                    elif t.data == "ref" and t.children and isinstance(t.children[0], Token) \
                            and t.children[0].value not in fn.params:
                        out.add((t.children[0].value, 0))
            calls[key] = {k for k in out if k in self.functions}

        def reaches_itself(key: tuple[str, int]) -> bool:
            seen: set[tuple[str, int]] = set()
            todo = list(calls[key])
            while todo:
                k = todo.pop()
                if k == key:
                    return True
                if k not in seen:
                    seen.add(k)
                    todo.extend(calls.get(k, ()))
            return False
        return [k for k in self.functions if reaches_itself(k)]

    def _emit_functions(self) -> list[GkFunction]:
        """Recursive CGA functions cannot be inlined: each becomes a grammarkit function (its
        overloads by arity share the grammarkit name), translated once per frame of the scope
        axes when its body reads the scope (else one function serves both). A function whose
        body does not translate is not emitted: its calls raise the body's Untranslatable.
        Non-recursive functions stay inlined (so translations without recursion do not change)."""
        keys = self._recursive_functions()
        if not keys:
            return []
        from ..functions import BUILTIN_FUNCTIONS
        from .expressions import _FUNCTIONS

        taken = {spec.name for spec in BUILTIN_FUNCTIONS} | {gk for gk, _, _ in _FUNCTIONS.values()}
        names: dict[str, str] = {}
        for name, _ in keys:
            if name not in names:
                base = gk_name(name)
                names[name] = self._claim(base + "_" if base in taken else base)
        for key in keys:
            self.emitted[key] = {"Y": names[key[0]], "Z": names[key[0]]}
        bodies: dict[tuple[tuple[str, int], str], Any] = {}
        while True:  # until stable: a body that calls a function that failed fails too, and a
            # function whose body is text makes `+` with its calls concatenate
            changed = False
            bodies.clear()
            for key in keys:
                if isinstance(self.emitted[key]["Y"], Untranslatable):
                    continue
                fn = self.functions[key]
                params = {p: gk_name(p) for p in fn.params}
                try:
                    for frame in ("Y", "Z"):
                        bodies[(key, frame)] = translate_expr(fn.body, self._ctx(frame, params))
                except Untranslatable as exc:
                    self.emitted[key] = {"Y": exc, "Z": exc}
                    changed = True
            text = {self.emitted[k]["Y"] for k in keys if (k, "Y") in bodies
                    and is_text(bodies[(k, "Y")], self.text_functions)}
            if text - self.text_functions:
                self.text_functions |= text
                changed = True
            if not changed:
                break
        done = [k for k in keys if (k, "Y") in bodies]
        if any(bodies[(k, "Y")] != bodies[(k, "Z")] for k in done):
            # a body reads the scope: the face frame (Z) gets copies calling each other
            znames = {name: self._claim(f"{names[name]}_z") for name in {k[0] for k in done}}
            for k in done:
                self.emitted[k]["Z"] = znames[k[0]]
            for k in done:
                fn = self.functions[k]
                bodies[(k, "Z")] = translate_expr(fn.body, self._ctx("Z", {p: gk_name(p) for p in fn.params}))
        out: list[GkFunction] = []
        for frame in ("Y", "Z"):
            for k in done:
                name = self.emitted[k][frame]
                if frame == "Z" and name == self.emitted[k]["Y"]:
                    continue
                out.append(GkFunction(name=name, params=tuple(gk_name(p) for p in self.functions[k].params),
                                      value=bodies[(k, frame)], span=self.function_spans.get(k)))
        return out

    def _functions_report(self) -> None:
        for key, fn in self.functions.items():
            if fn.name in self.imported_functions:
                continue  # reported when its file is imported on its own
            span = self.function_spans.get(key)
            target = self.emitted.get(key, {}).get("Y")
            if isinstance(target, Untranslatable):
                self._record("function", fn.name, "dropped", span, feature=target.feature,
                             message=f"function {fn.name}(): {target.message}")
                continue
            if target is not None:
                self._record("function", fn.name, "translated", span)
                continue
            if fn.name in self.inlined:
                self._record("function", fn.name, "translated", span)
                continue
            ctx = self._ctx("Y", {})
            ctx.bound = {p: Ref(name="x") for p in fn.params}
            try:
                translate_expr(fn.body, ctx)
                self._record("function", fn.name, "translated", span)
            except Untranslatable as exc:
                self._record("function", fn.name, "dropped", span, feature=exc.feature,
                             message=f"function {fn.name}(): {exc.message}")

    def _ctx(self, frame: str, params: dict[str, str]) -> ExprContext:
        return ExprContext(self.filename, frame, params, self.value_names, self.functions,
                           on_inline=self.inlined.add, emitted=self.emitted,
                           text_functions=self.text_functions)

    # -- attrs and consts -------------------------------------------------------------------------
    def _value(self, v: ValueDef) -> Any:
        gk = self.value_names[v.name]
        ctx = self._ctx("Y", {})
        status, feature, message = "translated", None, None
        try:
            value = translate_expr(v.value, ctx)
        except Untranslatable as exc:
            value, how = self._fallback_value(v.value, ctx)
            feature = exc.feature
            if how is not None:
                status, message = "approximated", f"{v.kind} {v.name}: {exc.message}; {how}"
            else:
                status = "dropped"
                value = Num(value=0) if not _looks_like_string(v.value) else Str(value="")
                message = (f"{v.kind} {v.name}: {exc.message}; defined as "
                           f"{'0' if isinstance(value, Num) else chr(34) * 2} instead")
        self._record(v.kind, v.name, status, v.span, feature=feature, message=message,
                     counting=not v.imported)
        if v.kind == "const":
            for a in v.annotations:
                self.report.ignored[a.children[0].value] += 1
            return Const(name=gk, value=value, span=v.span)
        rng, enum = self._annotations(v, value)
        return Attr(name=gk, value=value, range=rng, enum=enum, span=v.span)

    def _fallback_value(self, tree: Any, ctx: ExprContext) -> tuple[Any, str | None]:
        """A value for an attr/const whose CGA value grammarkit cannot express."""
        if not isinstance(tree, Tree):
            return None, None
        kids = children(tree)
        if tree.data == "case_expr":
            env = self._static_env()
            conds, vals, other = kids[0:-1:2], kids[1:-1:2], kids[-1]
            for cond, val in zip(conds, vals):
                try:
                    c = static_value(translate_expr(cond, ctx), env)
                except Untranslatable:
                    c = None
                if c is None:
                    break
                if c is True:
                    try:
                        return translate_expr(val, ctx), "the arm that holds for the default attr values is used"
                    except Untranslatable:
                        return None, None
            else:
                try:
                    return translate_expr(other, ctx), "the else arm (the value for the default attrs) is used"
                except Untranslatable:
                    return None, None
            try:
                return translate_expr(other, ctx), "the else arm is used"
            except Untranslatable:
                return None, None
        if tree.data == "stoch_expr":
            pcts, vals = kids[0:-1:2], kids[1:-1:2]
            best, best_p = kids[-1], None
            for p, val in zip(pcts, vals):
                try:
                    pv = static_value(translate_expr(p, ctx), self._static_env())
                except Untranslatable:
                    pv = None
                if isinstance(pv, (int, float)) and (best_p is None or pv > best_p):
                    best, best_p = val, pv
            try:
                return translate_expr(best, ctx), "its most likely value is used"
            except Untranslatable:
                return None, None
        return None, None

    def _static_env(self) -> dict[str, Any]:
        env: dict[str, Any] = {}
        ctx = self._ctx("Y", {})
        for v in self.values:
            try:
                env[self.value_names[v.name]] = translate_expr(v.value, ctx)
            except Untranslatable:
                pass
        return env

    def _annotations(self, v: ValueDef, value: Any) -> tuple[Any, Any]:
        rng = enum = None
        default = static_value(value, self._static_env())
        for a in v.annotations:
            aname = a.children[0].value
            span = self._span(a)
            args = a.children[1].children if len(a.children) > 1 else []
            named = {c.children[0].value: c.children[1] for c in args if c.data == "ann_named"}
            positional = [c.children[0] for c in args if c.data == "ann_positional"]
            if aname == "@StartRule":
                continue
            if aname not in ("@Range", "@Enum"):
                self.report.ignored[aname] += 1
                continue
            try:
                ctx = self._ctx("Y", {})
                if aname == "@Range" and "min" in named and "max" in named:
                    rng = (translate_expr(named["min"], ctx), translate_expr(named["max"], ctx))
                elif aname == "@Range" and len(positional) == 2 and all(
                        isinstance(translate_expr(p, ctx), Num) for p in positional):
                    rng = tuple(translate_expr(p, ctx) for p in positional)
                elif positional:
                    enum = tuple(translate_expr(p, ctx) for p in positional)
                else:
                    raise Untranslatable(f"annotation:{aname}", f"{aname} without values "
                                         f"({', '.join(named) or 'no arguments'})", span)
                for e in (rng or ()) + (enum or ()):
                    if not isinstance(e, (Num, Str, Bool)):
                        raise Untranslatable(f"annotation:{aname}", f"{aname} with non-constant values",
                                             span)
            except Untranslatable as exc:
                rng = enum = None
                self._record("annotation", aname, "dropped", span, feature=exc.feature,
                             message=exc.message)
                continue
            status, message = "translated", None
            if rng is not None and isinstance(default, (int, float)) and not isinstance(default, bool):
                lo, hi = rng[0].value, rng[1].value
                if lo > hi:
                    lo, hi = hi, lo
                if not lo <= default <= hi:
                    status = "approximated"
                    message = (f"@Range of attr {v.name} does not contain its default {default:g} "
                               "(CGA allows it with restricted=false); the range is widened")
                    lo, hi = min(lo, default), max(hi, default)
                rng = (Num(value=lo), Num(value=hi))
            if enum is not None and default is not None and default not in [e.value for e in enum]:
                status = "approximated"
                message = f"the default of attr {v.name} is not among its values; it is added"
                enum = enum + (_literal(default),)
            self._record("annotation", aname, status, span, feature="annotation:default-outside"
                         if status != "translated" else None, message=message)
        return rng, enum

    # -- rules --------------------------------------------------------------------------------------
    def _rule(self, key: tuple[str, int], frame: str, counting: bool) -> Rule:
        r = self.rules[key]
        gk = self._rule_names[(key, frame)]
        params = {p: gk_name(p) for p in r.params}
        for a in r.annotations:
            if a.children[0].value != "@StartRule":
                if counting:
                    self.report.ignored[a.children[0].value] += 1
            else:
                self._record("annotation", "@StartRule", "translated", self._span(a),
                             counting=counting)
        self._record("rule", r.name, "translated", r.span, counting=counting)
        rctx = _RuleCtx(key, gk, params, counting)
        items = self._body(r.body.children, frame, rctx)
        if not items:
            items = [Terminal(name=gk, span=r.span)]
        return Rule(name=gk, params=tuple(params.values()), body=Seq(items=tuple(items)), span=r.span)

    def _body(self, nodes: list, frame: str, rctx: _RuleCtx) -> list:
        """A rule body / arm / entry (items, then maybe a case or stochastic tail)."""
        out: list = []
        i = 0
        while i < len(nodes):
            node = nodes[i]
            if node.data == "tail":
                out.extend(self._tail(node.children[0], frame, rctx))
                i += 1
                continue
            if node.data == "call" and node.children[0].value == "offset" and len(call_args(node)) == 2:
                consumed = self._offset_part(node, nodes[i + 1:], frame, rctx, out)
                if consumed:
                    return out
                i += 1
                continue
            items = self._item(node, frame, rctx, out)
            if self.frame_change is not None:  # alignScopeToGeometry(yUp | zUp, ...)
                frame, self.frame_change = self.frame_change, None
            is_last = i == len(nodes) - 1
            for it in items:
                if isinstance(it, OpCall) and it.block is not None and not is_last:
                    it = Push(body=Seq(items=(it,)), span=it.span)
                out.append(it)
            i += 1
        return out

    def _tail(self, block: Tree, frame: str, rctx: _RuleCtx) -> list:
        span = self._span(block)
        arms = [c for c in block.children if c.data in ("case_arm", "stoch_arm")]
        else_arm = next(c for c in block.children if c.data == "else_arm")
        other = self._arm_body(else_arm.children[-1], frame, rctx, span)
        ctx = self._ctx(frame, rctx.params)
        if block.data == "case_block":
            out_arms = []
            for arm in arms:
                cond_tree = arm.children[1]
                try:
                    cond = translate_expr(cond_tree, ctx)
                except Untranslatable as exc:
                    self._record("case-arm", "case", "dropped", self._span(arm), feature=exc.feature,
                                 message=f"case arm: its condition uses {exc.message}; the arm is "
                                 "left out", counting=rctx.counting)
                    self._arm_body(arm.children[-1], frame, rctx, span)  # count its constructs
                    continue
                out_arms.append(CaseArm(cond=cond, body=self._arm_body(arm.children[-1], frame,
                                                                        rctx, span)))
            self._record("case", "case", "translated", span, counting=rctx.counting)
            if not out_arms:
                return list(other.items)
            return [Case(arms=tuple(out_arms), otherwise=other, span=span)]
        out_arms = []
        for arm in arms:
            pct_tok = arm.children[0]
            body = self._arm_body(arm.children[-1], frame, rctx, span)
            if pct_tok.type == "NUMBER":
                pct: Any = Num(value=float(pct_tok.value))
            elif pct_tok.value in self.value_names:
                pct = Ref(name=self.value_names[pct_tok.value])
            else:
                self._record("choice-arm", "%", "dropped", self._span(pct_tok), feature="expr:percent",
                             message=f"a percentage {pct_tok.value}% that is not a number or attr",
                             counting=rctx.counting)
                continue
            out_arms.append(ChoiceArm(percent=pct, body=body))
        self._record("choice", "%", "translated", span, counting=rctx.counting)
        if not out_arms:
            return list(other.items)
        return [Choice(arms=tuple(out_arms), otherwise=other, span=span)]

    def _arm_body(self, node: Tree, frame: str, rctx: _RuleCtx, span: Span | None) -> Seq:
        items = self._body(node.children, frame, rctx)
        if not items:
            items = [Terminal(name=rctx.gk, span=span)]
        return Seq(items=tuple(items))

    # -- items --------------------------------------------------------------------------------------
    def _item(self, node: Tree, frame: str, rctx: _RuleCtx, out: list) -> list:
        kind = node.data
        span = self._span(node)
        counting = rctx.counting
        if kind == "nil":
            self._record("nil", "NIL", "translated", span, counting=counting)
            return [Nil(span=span)]
        if kind == "noop":
            self._record("noop", ".", "translated", span, counting=counting)
            return []
        if kind == "terminal":
            name = node.children[0].value
            self._record("terminal", name, "translated", span, counting=counting)
            return [Terminal(name=gk_name(name), span=span)]
        if kind == "push":
            body = self._body(node.children[0].children, frame, rctx)
            self._record("push", "[]", "translated", span, counting=counting)
            return [Push(body=Seq(items=tuple(body)), span=span)] if body else []
        name = node.children[0].value
        args = call_args(node)
        if kind == "name":
            if (name, 0) in self.rules:
                self._record("successor", name, "translated", span, counting=counting)
                return [Successor(name=self._rule_name((name, 0), frame), span=span)]
            if name in _BARE_OPS:
                return self._op(name, [], None, False, node, frame, rctx, out)
            prefix = name.split(".", 1)[0]
            if "." in name and prefix in self.imports:
                self._record("successor", name, "dropped", span, feature="import",
                             message=f"{name} is a rule of the imported file {prefix!r}",
                             counting=counting)
                return [Terminal(name=gk_name(name), span=span)]
            self._record("leaf", name, "translated", span, counting=counting)
            return [Terminal(name=gk_name(name), span=span)]
        if kind == "call" and name in self.rule_arities:
            key = (name, len(args))
            if key not in self.rules:
                self._record("successor", name, "dropped", span, feature="rule-arity",
                             message=f"{name}() has no rule with {len(args)} argument(s)",
                             counting=counting)
                return []
            ctx = self._ctx(frame, rctx.params)
            try:
                values = tuple(translate_expr(a, ctx) for a in args)
            except Untranslatable as exc:
                self._record("successor", name, "dropped", span, feature=exc.feature,
                             message=f"{name}(...): an argument uses {exc.message}",
                             counting=counting)
                return []
            self._record("successor", name, "translated", span, counting=counting)
            return [Successor(name=self._rule_name(key, frame), args=values, span=span)]
        if kind == "call" and "." in name and name.split(".", 1)[0] in self.imports:
            self._record("successor", name, "dropped", span, feature="import",
                         message=f"{name}(...) is a rule of an imported file", counting=counting)
            return []
        block = node.children[-2] if kind == "block_call" and isinstance(node.children[-1], Token) \
            else (node.children[-1] if kind == "block_call" else None)
        star = kind == "block_call" and isinstance(node.children[-1], Token)
        return self._op(name, args, block, star, node, frame, rctx, out)

    def _op(self, name: str, args: list, block: Tree | None, star: bool, node: Tree, frame: str,
            rctx: _RuleCtx, out: list) -> list:
        span = self._span(node)
        handler = _HANDLERS.get(name)
        ctx = self._ctx(frame, rctx.params)
        if handler is None and block is None and name[:1].isupper() and name not in _TEXTURING \
                and name not in _METADATA:
            # a call of a rule that no rule of this file defines (any arity): in CGA the shape
            # is a leaf, its arguments unused, as for a bare undefined name
            self._record("leaf", name, "translated", span, counting=rctx.counting)
            return [Terminal(name=gk_name(name), span=span)]
        if handler is None:
            if name in _TEXTURING:
                why = ("grammarkit's texturing has no such operation (it has setupProjection, projectUV, "
                       "translateUV, scaleUV, rotateUV, deleteUV, tileUV, normalizeUV, texture)")
            elif name in _METADATA:
                why = "prints are not collected (report() is)"
            elif name[:1].isupper():
                why = ("no rule of this name and arity in this file (a rule that an importing "
                       "file defines?)")
            else:
                why = "grammarkit has no such operation"
            # Still translate the block's bodies so that their constructs are counted.
            if block is not None and rctx.counting:
                self._count_block(block, frame, rctx)
            feature = "rule:undefined" if name[:1].isupper() else f"op:{name}"
            self._record("op", name, "dropped", span, feature=feature,
                         message=f"{name}(): {why}", counting=rctx.counting)
            return []
        try:
            items, approx = handler(self, args, block, star, frame, rctx, ctx, span, out)
        except Untranslatable as exc:
            if block is not None and rctx.counting:
                self._count_block(block, frame, rctx)
            self._record("op", name, "dropped", span, feature=exc.feature,
                         message=f"{name}(): {exc.message}", counting=rctx.counting)
            return []
        if approx is not None:
            feature, message = approx
            self._record("op", name, "approximated", span, feature=feature,
                         message=f"{name}(): {message}", counting=rctx.counting)
        else:
            self._record("op", name, "translated", span, counting=rctx.counting)
        return items

    def _count_block(self, block: Tree, frame: str, rctx: _RuleCtx) -> None:
        for entry in block.children:
            if entry.data in ("entry", "merged_entry"):
                self._body(entry.children[-1].children, frame, rctx)
            elif entry.data in ("repeat_entry", "group_entry"):
                self._count_block(entry.children[0], frame, rctx)

    def _offset_part(self, node: Tree, rest: list, frame: str, rctx: _RuleCtx, out: list) -> bool:
        """`offset(d, inside|border)`: keep one part; returns True if it consumed `rest`."""
        span = self._span(node)
        d_tree, sel_tree = call_args(node)
        ctx = self._ctx(frame, rctx.params)
        part = sel_tree.children[0].value if isinstance(sel_tree, Tree) and sel_tree.data == "ref" else None
        try:
            d = translate_expr(d_tree, ctx)
            if part not in ("inside", "border"):
                raise Untranslatable("op:offset", f"offset part {part!r} is not supported", span)
        except Untranslatable as exc:
            self._record("op", "offset", "dropped", span, feature=exc.feature,
                         message=f"offset(): {exc.message}", counting=rctx.counting)
            return False
        self._record("op", "offset", "translated", span, counting=rctx.counting)
        if part == "inside":
            out.append(OpCall(name="offset", args=(Arg(value=d),), span=span))
            return False
        body = self._body(rest, frame, rctx) or [Terminal(name=rctx.gk, span=span)]
        out.append(OpCall(name="offset", args=(Arg(value=d),), block=(
            Branch(key=Ref(name="border"), body=Seq(items=tuple(body))),), span=span))
        return True

    # -- blocks ---------------------------------------------------------------------------------------
    def split_entries(self, block: Tree, frame: str, rctx: _RuleCtx, ctx: ExprContext) -> list:
        out: list = []
        for entry in block.children:
            span = self._span(entry)
            if entry.data == "repeat_entry":
                out.append(Repeat(items=tuple(self.split_entries(entry.children[0], frame, rctx, ctx)),
                                  span=span))
                continue
            if entry.data == "group_entry":
                self._record("split-group", "{}", "approximated", span, feature="split:group",
                             message="a nested { } without * is read as its entries, once",
                             counting=rctx.counting)
                out.extend(self.split_entries(entry.children[0], frame, rctx, ctx))
                continue
            if entry.data in ("bare_entry", "bare_name_entry", "merged_entry"):
                raise Untranslatable("split:entry", "a split entry without a size", span)
            mode, key_tree = _hoist_size(entry.children[0].children[0])
            key = translate_expr(key_tree, ctx)
            body = self._body(entry.children[-1].children, frame, rctx) or [
                Terminal(name=rctx.gk, span=span)]
            out.append(Branch(mode=mode, key=key, body=Seq(items=tuple(body)), span=span))
        return out

    def comp_entries(self, block: Tree, frame: str, rctx: _RuleCtx, mode: str) -> list:
        out: list = []
        for entry in block.children:
            span = self._span(entry)
            if entry.data not in ("entry", "merged_entry"):
                self._count_block(Tree("block", [entry]), frame, rctx) if entry.data not in (
                    "bare_entry", "bare_name_entry") else None
                self._record("selector", "?", "dropped", span, feature="comp:entry",
                             message="a comp entry without a selector", counting=rctx.counting)
                continue
            key_tree = entry.children[0].children[0]
            sel = key_tree.children[0].value if isinstance(key_tree, Tree) and key_tree.data in (
                "ref", "number") else None
            approx_sel = None
            if mode == "offset-parts":
                mapped = (sel,) if sel in ("inside", "border") else None
                body_frame = frame
            elif mode == "shape-parts":
                mapped = (sel,) if sel in ("shape", "remainder") else None
                body_frame = frame
            elif mode == "components":
                # edges and vertices: their scope is x along, y the normal, as CGA's faces (frame Z)
                body_frame = "Z"
                if sel is not None and key_tree.data == "number":
                    mapped = (int(float(sel)),) if float(sel).is_integer() and float(sel) >= 0 else None
                elif sel in ("all", "border", "inside", "eave", "ridge", "hip", "valley"):
                    mapped = (sel,)
                elif frame == "Y" and sel in ("front", "back", "left", "right", "top", "bottom", "side",
                                              "vertical", "horizontal", "aslant", "nutant"):
                    mapped = (sel,)  # classified about the up axis: CGA's y is grammarkit's z here
                else:
                    mapped = None
            elif mode == "edges":
                if sel is not None and key_tree.data == "number":
                    mapped = (int(float(sel)),) if float(sel).is_integer() else None
                else:
                    mapped, approx_sel = frames.edge_selectors(frame, sel) if sel else (None, None)
                body_frame = frame  # setback faces and the remainder lie in the face's plane
            elif sel is not None and key_tree.data == "number":
                # an index: CGA's and grammarkit's face orders agree (bottom 0, top 1, sides)
                mapped = (int(float(sel)),) if float(sel).is_integer() and float(sel) >= 0 else None
                body_frame = "Z"
            else:
                mapped = frames.comp_selectors(frame, sel) if sel else None
                body_frame = "Z"
            body = self._body(entry.children[-1].children, body_frame, rctx) or [
                Terminal(name=rctx.gk, span=span)]
            if mapped is None:
                self._record("selector", str(sel), "dropped", span, feature=f"comp-selector:{sel}",
                             message=f"comp selector {sel!r} is not supported", counting=rctx.counting)
                continue
            if entry.data == "merged_entry" and mode != "shape-parts":
                self._record("selector", f"{sel}=", "approximated", span, feature="comp:merge",
                             message=f"'{sel} =' (the selected faces as one shape) sends each face "
                             "on its own", counting=rctx.counting)
            elif approx_sel is not None:
                self._record("selector", sel, "approximated", span, feature=f"setback-selector:{sel}",
                             message=approx_sel, counting=rctx.counting)
            else:
                self._record("selector", sel, "translated", span, counting=rctx.counting)
            for gsel in mapped:
                key = Num(value=float(gsel)) if isinstance(gsel, int) else Ref(name=gsel)
                out.append(Branch(key=key, body=Seq(items=tuple(body)), span=span))
        return out

    # -- assets -----------------------------------------------------------------------------------------
    def asset(self, path: str, span: Span | None) -> bool:
        """Record an asset; True if it was found."""
        found = None
        candidates = []
        rel = path.lstrip("/")
        base = Path(self.filename).parent if self.filename else Path(".")
        candidates.append(base / path)
        for d in (base, base.parent, *self.asset_dirs):
            candidates.extend([d / rel, d / "assets" / rel])
        for c in candidates:
            if c.is_file():
                found = c
                break
        if path not in self._seen_assets:
            self._seen_assets.add(path)
            self.report.assets.append({"path": path, "found": found is not None,
                                       "resolved": str(found) if found else None,
                                       "line": span.line if span else None})
        return found is not None


def _params(text: str | None) -> tuple[str, ...]:
    if not text or not text.strip():
        return ()
    return tuple(p.strip().split()[-1] for p in text.split(",") if p.strip())


def _looks_like_string(tree: Any) -> bool:
    return isinstance(tree, Tree) and any(
        isinstance(t, Token) and t.type == "STRING" for t in tree.scan_values(lambda v: True))


def _literal(value: Any) -> Any:
    if isinstance(value, bool):
        return Bool(value=value)
    if isinstance(value, (int, float)):
        return Num(value=float(value))
    return Str(value=str(value))


def _hoist_size(tree: Any) -> tuple[str, Any]:
    """`~a / n` parses as `(~a) / n`; CGA means `~(a / n)`: move the mark to the whole key."""
    if isinstance(tree, Tree):
        if tree.data == "rel":
            return "rel", tree.children[-1]
        if tree.data == "floating":
            return "float", tree.children[-1]
        if tree.data in ("binop", "or_op", "and_op"):
            mode, left = _hoist_size(tree.children[0])
            if mode != "abs":
                return mode, Tree(tree.data, [left, *tree.children[1:]], meta=tree.meta)
    return "abs", tree


# -- operation handlers ---------------------------------------------------------------------------
# handler(translator, args, block, star, frame, rule ctx, expr ctx, span, out)
#   -> (items, None) or (items, (feature, message)) for an approximation; raises Untranslatable.

def _axis_name(tree: Any) -> str | None:
    if isinstance(tree, Tree) and tree.data == "ref":
        return tree.children[0].value
    return None


def _need(args: list, lo: int, hi: int, name: str, span: Span | None) -> None:
    if not lo <= len(args) <= hi:
        raise Untranslatable(f"op:{name}/{len(args)}", f"{name}() with {len(args)} arguments is not "
                             "supported", span)


def _h_extrude(t, args, block, star, frame, rctx, ctx, span, out):
    if len(args) == 1:
        return [OpCall(name="extrude", args=(Arg(value=translate_expr(args[0], ctx)),), span=span)], None
    if len(args) == 2:
        how = _axis_name(args[0]) or "an axis"
        h = translate_expr(args[1], ctx)
        return [OpCall(name="extrude", args=(Arg(value=h),), span=span)], (
            "extrude:axis", f"extrusion along {how} is made along the face normal")
    raise Untranslatable("op:extrude/" + str(len(args)), "extrude() with these arguments", span)


def _h_split(t, args, block, star, frame, rctx, ctx, span, out):
    if block is None:
        raise Untranslatable("op:split", "split() without a block", span)
    a = _axis_name(args[0]) if args else None
    if a not in ("x", "y", "z"):
        raise Untranslatable("split:axis", f"split axis {a!r}", span)
    gk_axis, reverse = frames.axis(frame, a)
    items = t.split_entries(block, frame, rctx, ctx)
    if star:
        items = [Repeat(items=tuple(items), span=span)]
    if reverse:
        items = _reversed(items)
    call = OpCall(name="split", args=(Arg(value=Ref(name=gk_axis)),), block=tuple(items), span=span)
    if len(args) > 1:
        return [call], ("split:adjust", "split options after the axis (adjustment, unit space) are "
                        "ignored")
    return [call], None


def _reversed(items: list) -> list:
    out = []
    for it in reversed(items):
        if isinstance(it, Repeat):
            it = it.model_copy(update={"items": tuple(_reversed(list(it.items)))})
        out.append(it)
    return out


def _h_comp(t, args, block, star, frame, rctx, ctx, span, out):
    mode = _axis_name(args[0]) if args else None
    if block is None:
        raise Untranslatable("op:comp", "comp() without a block", span)
    selectors = {e.children[0].children[0].children[0].value for e in block.children
                 if e.data in ("entry", "merged_entry") and isinstance(e.children[0].children[0], Tree)
                 and e.children[0].children[0].data == "ref"}
    prev = out[-1] if out else None
    if mode == "f" and selectors and selectors <= {"inside", "border"} and isinstance(prev, OpCall) \
            and prev.name == "offset" and prev.block is None:
        entries = t.comp_entries(block, frame, rctx, "offset-parts")
        out.pop()
        return [prev.model_copy(update={"block": tuple(entries)})], None
    if mode in ("e", "v"):
        entries = t.comp_entries(block, frame, rctx, "components")
        if not entries:
            raise Untranslatable("comp:no-selector", "none of its selectors is supported", span)
        return [OpCall(name="comp", args=(Arg(value=Ref(name=mode)),), block=tuple(entries), span=span)], None
    if mode != "f":
        raise Untranslatable(f"op:comp({mode})", f"comp({mode}) is not supported (only comp(f), comp(e), "
                             "comp(v))", span)
    entries = t.comp_entries(block, frame, rctx, "faces")
    if not entries:
        raise Untranslatable("comp:no-selector", "none of its selectors is supported", span)
    return [OpCall(name="comp", args=(Arg(value=Ref(name="f")),), block=tuple(entries), span=span)], None


def _h_offset(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "offset", span)
    d = translate_expr(args[0], ctx)
    if block is not None:
        entries = t.comp_entries(block, frame, rctx, "offset-parts")
        return [OpCall(name="offset", args=(Arg(value=d),), block=tuple(entries), span=span)], None
    return [OpCall(name="offset", args=(Arg(value=d),), span=span)], None


def _roof(gk: str, max_args: int):
    def handler(t, args, block, star, frame, rctx, ctx, span, out):
        if args and isinstance(args[0], Tree) and args[0].data == "ref" and args[0].children[0].value in (
                "byHeight", "byAngle"):
            if args[0].children[0].value == "byHeight":
                raise Untranslatable(f"{gk}:byHeight", f"{gk}(byHeight, ...) is not supported", span)
            args = args[1:]
        if not args:
            raise Untranslatable(f"op:{gk}", f"{gk}() without an angle", span)
        angle = translate_expr(args[0], ctx)
        call_args_: list = [Arg(value=angle)]
        if len(args) >= 2 and gk != "roofPyramid" and gk != "roofShed":
            call_args_.append(Arg(name="overhang", value=translate_expr(args[1], ctx)))
        call = OpCall(name=gk, args=tuple(call_args_), span=span)
        extra = len(args) - (1 if gk in ("roofPyramid", "roofShed") else 2)
        if extra > 0:
            what = {"roofGable": "the second overhang, even and index arguments are ignored",
                    "roofHip": "the even argument is ignored",
                    "roofShed": "the edge index is ignored (the roof rises towards +y)",
                    "roofPyramid": "extra arguments are ignored"}[gk]
            return [call], (f"{gk}:options", what)
        return [call], None
    return handler


def _rel_or_abs(tree: Any, size_ref: str, ctx: ExprContext) -> Any:
    """An s()/t() argument: `'v` is v times the scope size along that axis, also inside the
    argument's expression (`'1 + 0.3`: the size plus 0.3)."""
    return translate_expr(tree, ctx.with_relative(size_ref))


def _is_rel_one(tree: Any) -> bool:
    return (isinstance(tree, Tree) and tree.data == "rel" and isinstance(tree.children[-1], Tree)
            and tree.children[-1].data == "number" and float(tree.children[-1].children[0].value) == 1)


def _h_s(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 3, 3, "s", span)
    cx, cy, cz = (_rel_or_abs(a, frames.scope_name(frame, "scope.s" + c), ctx)
                  for a, c in zip(args, "xyz"))
    if frame == "Z":
        return [OpCall(name="s", args=(Arg(value=cx), Arg(value=cy), Arg(value=cz)), span=span)], None
    # Frame Y: CGA keeps its scope origin, at the back (z = 0 is grammarkit's y = sy); shift
    # grammarkit's origin so the back stays where it is when the depth changes.
    items = []
    if not _is_rel_one(args[2]):
        items.append(OpCall(name="t", args=(Arg(value=Num(value=0)), Arg(value=Binary(
            op="-", left=Ref(name="scope.sy"), right=cz)), Arg(value=Num(value=0))), span=span))
    items.append(OpCall(name="s", args=(Arg(value=cx), Arg(value=cz), Arg(value=cy)), span=span))
    return items, None


def _h_t(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 3, 3, "t", span)
    cx, cy, cz = (_rel_or_abs(a, frames.scope_name(frame, "scope.s" + c), ctx)
                  for a, c in zip(args, "xyz"))
    if frame == "Y":
        neg = cz.model_copy(update={"value": -cz.value}) if isinstance(cz, Num) else Unary(op="-", operand=cz)
        cx, cy, cz = cx, neg, cy
    return [OpCall(name="t", args=(Arg(value=cx), Arg(value=cy), Arg(value=cz)), span=span)], None


def _h_r(t, args, block, star, frame, rctx, ctx, span, out):
    approx = None
    if len(args) == 4:
        approx = ("r:pivot", f"rotation about {_axis_name(args[0]) or 'a pivot'} is made about the "
                  "scope origin")
        args = args[1:]
    _need(args, 3, 3, "r", span)
    return _turns("r", [translate_expr(a, ctx) for a in args], frame, span), approx


def _turns(op: str, angles: list, frame: str, span: Span | None) -> list:
    """CGA's `op(x, y, z)` turn (r or rotateScope) as grammarkit operations. In frame Z the
    axes are the same; in frame Y CGA rotates about x, then its y (grammarkit z), then its z
    (grammarkit -y): one operation per non-zero angle, in that order."""
    rx, ry, rz = angles
    if frame == "Z":
        return [OpCall(name=op, args=(Arg(value=rx), Arg(value=ry), Arg(value=rz)), span=span)]
    zero = Num(value=0)
    steps = []
    for gk_axis, value in (("x", rx), ("z", ry), ("y", rz)):
        if isinstance(value, Num) and value.value == 0:
            continue
        if gk_axis == "y":
            value = Num(value=-value.value) if isinstance(value, Num) else Unary(op="-", operand=value)
        vec = [zero, zero, zero]
        vec["xyz".index(gk_axis)] = value
        steps.append(OpCall(name=op, args=tuple(Arg(value=v) for v in vec), span=span))
    return steps


def _h_center(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "center", span)
    axes = _axis_name(args[0])
    mapped = frames.center_axes(frame, axes) if axes else None
    if mapped is None:
        raise Untranslatable("center:axes", f"center({axes})", span)
    return [OpCall(name="center", args=(Arg(value=Ref(name=mapped)),), span=span)], None


def _hex(v: float) -> str:
    return f"{max(0, min(255, round(v * 255))):02x}"


def _h_color(t, args, block, star, frame, rctx, ctx, span, out):
    values = [translate_expr(a, ctx) for a in args]
    if len(values) == 1:
        v = values[0]
        if isinstance(v, Str):
            text = v.value.strip()
            if re.fullmatch(r"#[0-9A-Fa-f]{3}", text):
                text = "#" + "".join(c * 2 for c in text[1:])
            if not re.fullmatch(r"#[0-9A-Fa-f]{6}", text):
                raise Untranslatable("color:format", f"colour {text!r} is not #rrggbb", span)
            return [OpCall(name="color", args=(Arg(value=Str(value=text.lower())),), span=span)], None
        return [OpCall(name="color", args=(Arg(value=v),), span=span)], None
    if len(values) in (3, 4) and all(isinstance(v, Num) for v in values):
        text = "#" + "".join(_hex(v.value) for v in values[:3])
        call = OpCall(name="color", args=(Arg(value=Str(value=text)),), span=span)
        return [call], (("color:alpha", "the opacity is ignored") if len(values) == 4 else None)
    raise Untranslatable("color:rgb-expr", "color(r, g, b) from expressions (not constants)", span)


def _h_set(t, args, block, star, frame, rctx, ctx, span, out):
    target = _axis_name(args[0]) if args else None
    if target == "material.name" and len(args) == 2:
        return [OpCall(name="material", args=(Arg(value=translate_expr(args[1], ctx)),), span=span)], None
    if target in ("material.color.rgb",) and len(args) == 2:
        return _h_color(t, args[1:], block, star, frame, rctx, ctx, span, out)
    if target in ("trim.vertical", "trim.horizontal") and len(args) == 2:
        value = translate_expr(args[1], ctx)
        if target == "trim.vertical":
            return [OpCall(name="trim", args=(Arg(value=value),), span=span)], None
        # grammarkit makes vertical trim planes only: turning horizontal ones off changes nothing
        if isinstance(value, Bool) and not value.value:
            return [], None
        return [], ("set(trim.horizontal)", "grammarkit makes no horizontal trim planes")
    if target and target.startswith("material.") and len(args) == 2:
        value = translate_expr(args[1], ctx)
        if target.endswith("map"):
            known = value.value if isinstance(value, Str) else _known_file_name(t, value)
            if known:
                t.asset(known, span)  # listed in the report; a literal is made relative on writing
        return [OpCall(name="set", args=(Arg(value=Ref(name=target)), Arg(value=value)), span=span)], None
    if target and len(args) == 2:
        kinds = {v.name: v.kind for v in t.values}
        if kinds.get(target) == "attr":
            value = translate_expr(args[1], ctx)
            return [OpCall(name="set", args=(Arg(value=Ref(name=t.value_names[target])), Arg(value=value)),
                           span=span)], None
        if kinds.get(target) == "const":
            raise Untranslatable("op:set(const)", f"set({target}, ...) of a const", span)
    raise Untranslatable("op:set", f"set({target}, ...): only attrs of this file can be set", span)


def _h_i(t, args, block, star, frame, rctx, ctx, span, out):
    if not args:
        raise Untranslatable("op:i", "i() without a file", span)
    path = translate_expr(args[0], ctx)
    if not isinstance(path, Str):
        # a computed file name (an attr, a parameter, fileRandom(...), "dir/" + name): grammarkit
        # evaluates it at derive time too; a value known from the attrs' defaults is looked up
        # (and, with missing_assets="drop", left out when missing) like a literal
        known = _known_file_name(t, path)
        if known is not None and not t.asset(known, span) and t.missing_assets == "drop":
            raise Untranslatable("asset:missing", f"asset {known!r} was not found (the i() is "
                                 "left out; --missing-assets keep keeps it)", span)
        call = OpCall(name="i", args=(Arg(value=path),), span=span)
        approx = ("i:options", "the up axis and insert mode arguments are ignored") if len(args) > 1 else None
        if known is None and t.missing_assets == "drop":
            # which file is only known while deriving: `(case fileExists(p): i(p))` leaves the
            # i() out there when the file is missing, as "drop" does here for a known one
            guard = Case(arms=(CaseArm(cond=Call(func="fileExists", args=(path,), span=span),
                                       body=Seq(items=(call,)), span=span),), span=span)
            return [guard], approx
        return [call], approx
    if path.value.startswith("builtin:"):
        return _builtin(path.value[len("builtin:"):], frame, span, len(args) > 1)
    found = t.asset(path.value, span)
    if not found and t.missing_assets == "drop":
        raise Untranslatable("asset:missing", f"asset {path.value!r} was not found (the i() is "
                             "left out; --missing-assets keep keeps it)", span)
    call = OpCall(name="i", args=(Arg(value=path),), span=span)
    if len(args) > 1:
        return [call], ("i:options", "the up axis and insert mode arguments are ignored")
    return [call], None


def _h_nil_op(t, args, block, star, frame, rctx, ctx, span, out):
    return [Nil(span=span)], None


def _literal_number(tree: Any) -> float | None:
    if isinstance(tree, Tree) and tree.data == "number":
        return float(tree.children[0].value)
    if isinstance(tree, Tree) and tree.data == "neg":
        v = _literal_number(tree.children[-1])
        return None if v is None else -v
    return None


_FACE_SELECTORS = {"world.lowest": "lowest", "largest": "largest", "any": "any"}


def _h_align_scope_to_geometry(t, args, block, star, frame, rctx, ctx, span, out):
    """alignScopeToGeometry(upAxis, faceIndex | world.lowest | largest | any, edgeIndex |
    longest | world.lowest): z along the face's normal and x along the edge (grammarkit's
    alignScopeToGeometry(edge, face)); the up axis says which CGA frame the shape is in
    afterwards (yUp: the normal is CGA's y, frame Y; zUp: its z, frame Z)."""
    _need(args, 2, 3, "alignScopeToGeometry", span)
    up = _axis_name(args[0])
    if up not in ("yUp", "zUp"):
        raise Untranslatable("alignScopeToGeometry:up", f"up axis {up!r}", span)
    face_name = _axis_name(args[1])
    face: Any
    if face_name in _FACE_SELECTORS:
        face = Str(value=_FACE_SELECTORS[face_name])
    elif face_name is not None and "." in face_name:
        raise Untranslatable("alignScopeToGeometry:face", f"face selector {face_name!r}", span)
    else:
        face = translate_expr(args[1], ctx)
    edge: Any = Num(value=0)
    if len(args) == 3:
        if _axis_name(args[2]) == "longest":
            edge = Str(value="longest")
        elif _axis_name(args[2]) == "world.lowest":
            edge = Str(value="lowest")
        elif _axis_name(args[2]) is not None and "." in (_axis_name(args[2]) or ""):
            raise Untranslatable("alignScopeToGeometry:orientation", f"edge orientation "
                                 f"{_axis_name(args[2])!r}", span)
        else:
            edge = translate_expr(args[2], ctx)
    if isinstance(face, Str) and face.value == "any" and not isinstance(edge, Str):
        raise Untranslatable("alignScopeToGeometry:face", "face selector any with an edge index", span)
    t.frame_change = "Y" if up == "yUp" else "Z"
    call_args = (Arg(value=edge),) if isinstance(face, Num) and face.value == 0 else (Arg(value=edge), Arg(value=face))
    return [OpCall(name="alignScopeToGeometry", args=call_args, span=span)], None


_MAKES_VOLUME = {"extrude", "i", "taper", "roofGable", "roofHip", "roofPyramid", "roofShed", "roofMansard"}

# CGA alignScopeToAxes(axis) -> (grammarkit axis, the CGA frames it is exact in). Afterwards
# the CGA scope is y-up with its z towards the world's +z (south), which is frame Y: CGA's
# world.y (up) is grammarkit's z with x projected in both systems; world.z (south) is
# grammarkit's -y, x projected; world.x is x with CGA's z projected, which is grammarkit's -y
# only in frame Y.
_ALIGN_AXES = {None: ("xyz", "YZ"), "world.xyz": ("xyz", "YZ"), "xyz": ("xyz", "YZ"),
               "y": ("z", "YZ"), "world.y": ("z", "YZ"), "z": ("y", "YZ"), "world.z": ("y", "YZ"),
               "x": ("x", "Y"), "world.x": ("x", "Y")}


def _h_align_scope_to_axes(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 0, 1, "alignScopeToAxes", span)
    name = _axis_name(args[0]) if args else None
    if args and name is None:
        raise Untranslatable("alignScopeToAxes:axis", "alignScopeToAxes() of a computed axis", span)
    mapped = _ALIGN_AXES.get(name)
    if frame == "Z" and not (out and isinstance(out[-1], OpCall) and out[-1].name in _MAKES_VOLUME):
        # a face of frame Z may be a facade (vertical: CGA's y up keeps it in its plane, which
        # grammarkit's z up does not) or a top (horizontal: the other way round); the importer
        # cannot tell them apart, so only a shape just made a volume (a balcony extruded from
        # a facade) is translated
        raise Untranslatable("alignScopeToAxes:face", "alignScopeToAxes() on a face of a volume "
                             "(a vertical face would leave its scope plane in grammarkit's y-up frame); "
                             "on a volume made in the same rule it is translated", span)
    if mapped is None or frame not in mapped[1]:
        raise Untranslatable("alignScopeToAxes:axis", f"alignScopeToAxes({name})"
                             + (" on a face's frame (CGA's z projected is not grammarkit's)" if mapped else ""),
                             span)
    t.frame_change = "Y"
    call_args = () if mapped[0] == "xyz" else (Arg(value=Str(value=mapped[0])),)
    return [OpCall(name="alignScopeToAxes", args=call_args, span=span)], None


def _h_report(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 2, 2, "report", span)
    key, value = translate_expr(args[0], ctx), translate_expr(args[1], ctx)
    return [OpCall(name="report", args=(Arg(value=key), Arg(value=value)), span=span)], None


def _h_print(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "print", span)
    return [OpCall(name="print", args=(Arg(value=translate_expr(args[0], ctx)),), span=span)], None


def _h_convexify(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 0, 1, "convexify", span)
    return [OpCall(name="convexify", args=tuple(Arg(value=translate_expr(a, ctx)) for a in args), span=span)], None


def _h_reverse_normals(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 0, 0, "reverseNormals", span)
    return [OpCall(name="reverseNormals", span=span)], None


def _h_rotate_scope(t, args, block, star, frame, rctx, ctx, span, out):
    """rotateScope(x, y, z): the scope turned about its axes, x first (as r()); in frame Y,
    CGA's y is grammarkit's z and its z grammarkit's -y (the steps of _h_r)."""
    _need(args, 3, 3, "rotateScope", span)
    return _turns("rotateScope", [translate_expr(a, ctx) for a in args], frame, span), None


def _flag_args(args: list, frame: str, ctx: Any) -> list:
    """mirror flags (x, y, z) in CGA's axes -> grammarkit's axes (frame Y: y and z swap)."""
    flags = [translate_expr(a, ctx) for a in args]
    return flags if frame == "Z" else [flags[0], flags[2], flags[1]]


def _h_mirror_scope(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 3, 3, "mirrorScope", span)
    flags = _flag_args(args, frame, ctx)
    if all(isinstance(f, Bool) for f in flags) and sum(f.value for f in flags) % 2:
        raise Untranslatable("mirrorScope:handedness", "reversing one or three scope axes makes a "
                             "left-handed scope, which grammarkit's shapes cannot carry", span)
    return [OpCall(name="mirrorScope", args=tuple(Arg(value=f) for f in flags), span=span)], None


def _h_mirror(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 3, 3, "mirror", span)
    flags = _flag_args(args, frame, ctx)
    return [OpCall(name="mirrorGeometry", args=tuple(Arg(value=f) for f in flags), span=span)], None


def _h_set_pivot(t, args, block, star, frame, rctx, ctx, span, out):
    """setPivot(axes, corner): CGA's pivot is the frame that r() and rotateScope() turn about
    and that scope.r / convert(pivot) read. grammarkit turns about the scope's own axes and has
    no pivot, and CGA's r() turns about the scope origin whatever the pivot's corner: so
    setPivot(xyz, n) (the pivot's axes along the scope's) changes nothing; other orientations
    would change the axes of later rotations, which is approximated."""
    _need(args, 2, 2, "setPivot", span)
    orientation = _axis_name(args[0])
    if orientation == "xyz":
        return [], None
    return [], ("setPivot:orientation", f"setPivot({orientation}, ...): later rotations turn about "
                "the scope's axes, not the pivot's")


# CGA's built-in assets and primitive operations -> grammarkit's built-in primitives
# (grammarkit/split/assets.py). CGA's primitives are y-up; in frame Y that is grammarkit's z.
_BUILTIN_NAMES = {"cube": "cube", "cube:notex": "cube:notex", "cylinder": "cylinder",
                  "sphere": "sphere", "cone": "cone", "quad": "quad", "disk": "disk"}
_PRIMITIVE_OPS = {"primitiveCube": "cube", "primitiveCylinder": "cylinder", "primitiveSphere": "sphere",
                  "primitiveCone": "cone", "primitiveQuad": "quad", "primitiveDisk": "disk"}


def _builtin(name: str, frame: str, span: Span | None, options: bool) -> tuple:
    gk = _BUILTIN_NAMES.get(name)
    if gk is None:
        raise Untranslatable("i:builtin", f"built-in asset 'builtin:{name}' has no grammarkit "
                             "counterpart", span)
    if gk == "cylinder" and frame == "Z":
        gk = "cylinder:y"  # CGA's cylinder axis is its scope's y: grammarkit's y on a face
    call = OpCall(name="i", args=(Arg(value=Str(value="builtin:" + gk)),), span=span)
    if options:
        return [call], ("i:options", "the up axis and insert mode arguments are ignored")
    return [call], None


def _h_primitive(cga: str):
    def handler(t, args, block, star, frame, rctx, ctx, span, out):
        items, approx = _builtin(_PRIMITIVE_OPS[cga], frame, span, False)
        if args:
            approx = (f"{cga}:options", "the number of segments (and other arguments) is "
                      "grammarkit's fixed 16")
        return items, approx
    return handler


def _h_taper(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "taper", span)
    return [OpCall(name="taper", args=(Arg(value=translate_expr(args[0], ctx)),), span=span)], None


# -- lots (grammarkit/split/lots.py) --------------------------------------------------------------
def _h_setback(gk: str):
    def handler(t, args, block, star, frame, rctx, ctx, span, out):
        if block is None:
            raise Untranslatable(f"op:{gk}", f"{gk}() without a block", span)
        _need(args, 1, 2, gk, span)
        dist_tree = args[0]
        op = gk
        # setback(comp(fe) { all: expr }) is CGA's long form of setbackPerEdge(expr)
        if isinstance(dist_tree, Tree) and dist_tree.data == "func_block_call":
            inner = _comp_fe_all(dist_tree) if gk == "setback" else None
            if inner is None:
                raise Untranslatable("setback:array", "per-edge distances other than "
                                     "comp(fe) { all: ... }", span)
            op, dist_tree = "setbackPerEdge", inner
        d = translate_expr(dist_tree, ctx)
        entries = t.comp_entries(block, frame, rctx, "edges")
        if not entries:
            raise Untranslatable("setback:no-selector", "none of its selectors is supported", span)
        call = OpCall(name=op, args=(Arg(value=d),), block=tuple(entries), span=span)
        if len(args) == 2:
            return [call], (f"{gk}:uvSet", "the uv set of uv selectors is ignored")
        return [call], None
    return handler


def _comp_fe_all(tree: Tree) -> Any:
    """The expression of `comp(fe) { all: expr }` (CGA's comp function), or None."""
    name = next((c.value for c in tree.children if isinstance(c, Token)), None)
    args = call_args(tree)
    block = next((c for c in tree.children if isinstance(c, Tree) and c.data == "block"), None)
    if name != "comp" or len(args) != 1 or _axis_name(args[0]) != "fe" or block is None:
        return None
    entries = [e for e in block.children if isinstance(e, Tree)]
    if len(entries) != 1 or entries[0].data != "entry":
        return None
    key = entries[0].children[0].children[0]
    if not (isinstance(key, Tree) and key.data == "ref" and key.children[0].value == "all"):
        return None
    body = entries[0].children[-1]
    if isinstance(body, Tree) and body.data == "entry_body":
        if len(body.children) != 1 or not isinstance(body.children[0], Tree):
            return None
        body = body.children[0]
    # the entry was parsed as a rule body: its one item read back as an expression
    if body.data == "call":
        return Tree("func_call", body.children)
    if body.data == "name":
        return Tree("ref", body.children)
    return body


def _h_shape_op(gk: str, n: int):
    def handler(t, args, block, star, frame, rctx, ctx, span, out):
        if block is None:
            raise Untranslatable(f"op:{gk}", f"{gk}() without a block", span)
        _need(args, n, n, gk, span)
        if frame != "Y":
            raise Untranslatable(f"{gk}:face", f"{gk}() on a face of a volume (its front is CGA's "
                                 "scope -z, which grammarkit's faces do not have)", span)
        entries = t.comp_entries(block, frame, rctx, "shape-parts")
        if not entries:
            raise Untranslatable(f"{gk}:no-selector", "none of its selectors is supported", span)
        return [OpCall(name=gk, args=tuple(Arg(value=translate_expr(a, ctx)) for a in args),
                       block=tuple(entries), span=span)], None
    return handler


def _h_label(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "label", span)
    name = translate_expr(args[0], ctx)
    return [OpCall(name="label", args=(Arg(value=name),), span=span)], None


def _h_inner_rectangle(t, args, block, star, frame, rctx, ctx, span, out):
    if block is None:
        raise Untranslatable("op:innerRectangle", "innerRectangle without a block", span)
    _need(args, 0, 1, "innerRectangle", span)
    mode = _axis_name(args[0]) if args else "scope"
    if mode not in ("scope", "edge"):
        raise Untranslatable("innerRectangle:align", f"innerRectangle({mode})", span)
    entries = t.comp_entries(block, frame, rctx, "shape-parts")
    if not entries:
        raise Untranslatable("innerRectangle:no-selector", "none of its selectors is supported", span)
    return [OpCall(name="innerRectangle", args=(Arg(value=Ref(name=mode)),), block=tuple(entries), span=span)], None


_SCATTER_MEANS = ("center", "front", "back", "left", "right", "top", "bottom")


def _h_scatter(t, args, block, star, frame, rctx, ctx, span, out):
    """`scatter(domain, n, uniform|gaussian [, mean, stddev]) { Rule }` -> `{ all: Rule }`."""
    _need(args, 3, 5, "scatter", span)
    domain, dist = _axis_name(args[0]), _axis_name(args[2])
    if domain not in ("surface", "volume", "scope"):
        raise Untranslatable("scatter:domain", f"scatter domain {domain!r}", span)
    if dist not in ("uniform", "gaussian"):
        raise Untranslatable("scatter:distribution", f"scatter distribution {dist!r}", span)
    entries = [e for e in (block.children if block is not None else ()) if isinstance(e, Tree)]
    if len(entries) != 1 or entries[0].data not in ("bare_entry", "bare_name_entry"):
        raise Untranslatable("scatter:block", "scatter needs a block of one rule call { Rule }", span)
    e = entries[0]
    item = Tree("call" if e.data == "bare_entry" else "name", e.children)
    # CGA turns a point's y (its up axis) to the surface normal, grammarkit its z: CGA's y-up
    # frame (Y); in a volume or the scope the points keep the shape's axes and frame
    body = t._body([item], "Y" if domain == "surface" else frame, rctx) or [Terminal(name=rctx.gk, span=span)]
    call_args = [Arg(value=Ref(name=domain)), Arg(value=translate_expr(args[1], ctx)), Arg(value=Ref(name=dist))]
    approx = None
    if len(args) >= 4:
        mean = _axis_name(args[3])
        if mean not in _SCATTER_MEANS:
            raise Untranslatable("scatter:mean", f"scatter mean {mean!r}", span)
        # CGA's scope sides in grammarkit's: frame Y maps CGA's +y (top) to +z and CGA's +z
        # (front) to -y, so the names agree; in frame Z (axes as they are) CGA's front is +z
        if frame != "Y":
            mean = {"front": "top", "back": "bottom", "top": "back", "bottom": "front"}.get(mean, mean)
        call_args.append(Arg(value=Ref(name=mean)))
    if len(args) == 5:
        sd = args[4]
        if isinstance(sd, Tree) and sd.data == "rel":
            call_args.append(Arg(value=translate_expr(sd.children[0], ctx)))
        else:  # an absolute stddev (metres): relative to the scope's largest size
            def size(a: str) -> Tree:
                return Tree("ref", [Token("NAME", f"scope.s{a}")])

            largest = Tree("func_call", [Token("NAME", "max"), Tree("args", [size("x"), Tree(
                "func_call", [Token("NAME", "max"), Tree("args", [size("y"), size("z")])])])])
            call_args.append(Arg(value=translate_expr(Tree("binop", [sd, Token("SLASH", "/"), largest]), ctx)))
            approx = ("scatter:stddev", "an absolute stddev is made relative to the scope's largest "
                      "size (grammarkit's stddev is relative, per axis)")
    return [OpCall(name="scatter", args=tuple(call_args), block=(Branch(key=Ref(name="all"), body=Seq(
        items=tuple(body)), span=span),), span=span)], approx


# -- texturing (grammarkit/split/texturing.py) -----------------------------------------------------
# A CGA axis letter of setupProjection -> (grammarkit letter, reversed). World axes are y-up in
# CGA and z-up in grammarkit, as the lot's scope (frame Y); a face's scope is the identity.
def _projection_axis(frame: str, world: bool, letter: str) -> tuple[str, bool]:
    return frames.axis("Y" if world else frame, letter)


def _texture_size(tree: Any, size_ref: str, ctx: ExprContext) -> Any:
    """A texture width/height: `'v` is v times the scope size along that axis, `~v` the size
    nearest to v that fits a whole number of times into the scope (CGA's floating size)."""
    if isinstance(tree, Tree) and tree.data == "floating":
        v = translate_expr(tree.children[-1], ctx)
        size = Ref(name=size_ref)
        count = Call(func="max", args=(Num(value=1), Call(func="round", args=(Binary(op="/", left=size, right=v),))))
        return Binary(op="/", left=size, right=count)
    return _rel_or_abs(tree, size_ref, ctx)


def _negated(e: Any) -> Any:
    return Num(value=-e.value) if isinstance(e, Num) else Unary(op="-", operand=e)


def _h_setup_projection(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 4, 7, "setupProjection", span)
    axes = _axis_name(args[1]) or ""
    origin, _, pair = axes.partition(".")
    if origin not in ("scope", "world") or len(pair) != 2 or any(c not in "xyz" for c in pair) or pair[0] == pair[1]:
        raise Untranslatable("setupProjection:axes", f"projection axes {axes!r}", span)
    world = origin == "world"
    uv_set = translate_expr(args[0], ctx)
    letters, sizes, offs = [], [], []
    for k, letter in enumerate(pair):
        gk, rev = _projection_axis(frame, world, letter)
        size = _texture_size(args[2 + k], "scope.s" + gk, ctx)
        off = _rel_or_abs(args[4 + k], "scope.s" + gk, ctx) if len(args) > 4 + k else Num(value=0)
        if rev:
            # CGA's coordinate along this axis is -(grammarkit's) (world) or sy - y (a lot's
            # scope: CGA's z runs from the back): the same tiles with a mirrored size
            size = _negated(size)
            off = _negated(off) if world else Binary(op="-", left=Ref(name="scope.s" + gk), right=off)
        letters.append(gk)
        sizes.append(size)
        offs.append(off)
    call_args_ = [Arg(value=uv_set), Arg(value=Ref(name=f"{origin}.{letters[0]}{letters[1]}")),
                  Arg(value=sizes[0]), Arg(value=sizes[1])]
    if not all(isinstance(o, Num) and o.value == 0 for o in offs):
        call_args_ += [Arg(value=offs[0]), Arg(value=offs[1])]
    call = OpCall(name="setupProjection", args=tuple(call_args_), span=span)
    if len(args) == 7 and _literal_number(args[6]) != 0:
        return [call], ("setupProjection:uwFactor", "the w texture coordinate (uwFactor) is not made")
    return [call], None


def _uv_op(gk: str, lo: int, hi: int):
    def handler(t, args, block, star, frame, rctx, ctx, span, out):
        _need(args, lo, hi, gk, span)
        return [OpCall(name=gk, args=tuple(Arg(value=translate_expr(a, ctx)) for a in args), span=span)], None
    return handler


def _h_tile_uv(t, args, block, star, frame, rctx, ctx, span, out):
    """`tileUV(k, w, h)`; `~w` and `'w` are taken over the scope's x (u) and y (v) sizes, as
    setupProjection's are (CGA measures the uv extent of the geometry: the same for a
    projection along the scope's axes)."""
    _need(args, 3, 3, "tileUV", span)
    sizes = [_texture_size(a, f"scope.s{c}", ctx) for a, c in zip(args[1:], "xy")]
    approx = None
    if any(isinstance(a, Tree) and a.data in ("floating", "rel") for a in args[1:]):
        approx = ("tileUV:relative", "~ and ' tile sizes are measured over the scope's x and y sizes "
                  "(CGA: over the uv extent of the geometry)")
    return [OpCall(name="tileUV", args=(Arg(value=translate_expr(args[0], ctx)), *(Arg(value=v) for v in sizes)),
                   span=span)], approx


def _h_normalize_uv(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 3, 3, "normalizeUV", span)
    which, mode = _axis_name(args[1]), _axis_name(args[2])
    if which not in ("uv", "u", "v") or mode not in ("separatePerFace", "collectiveAllFaces"):
        raise Untranslatable("normalizeUV:args", f"normalizeUV(.., {which}, {mode})", span)
    approx = None
    if mode == "separatePerFace":
        approx = ("normalizeUV:separatePerFace", "separatePerFace normalises over the whole shape (exact "
                  "for a face; a volume's faces together)")
    return [OpCall(name="normalizeUV", args=(Arg(value=translate_expr(args[0], ctx)), Arg(value=Ref(name=which)),
                                             Arg(value=Ref(name=mode))), span=span)], approx


def _known_file_name(t: Any, value: Any) -> str | None:
    """The file name a computed expression has with the attrs' default values, when that is
    known without deriving (an attr set to a string, "dir/" + such an attr), else None."""
    known = static_value(value, t._static_env())
    return known if isinstance(known, str) and known and not known.startswith("builtin:") else None


def _h_texture(t, args, block, star, frame, rctx, ctx, span, out):
    _need(args, 1, 1, "texture", span)
    path = translate_expr(args[0], ctx)
    # a computed file name is evaluated at derive time (relative to the grammar's folder)
    known = path.value if isinstance(path, Str) else _known_file_name(t, path)
    if known:
        t.asset(known, span)  # listed in the report; a literal is made relative on writing
    return [OpCall(name="texture", args=(Arg(value=path),), span=span)], None


_HANDLERS = {
    "extrude": _h_extrude, "split": _h_split, "comp": _h_comp, "offset": _h_offset,
    "roofGable": _roof("roofGable", 5), "roofHip": _roof("roofHip", 3),
    "roofPyramid": _roof("roofPyramid", 1), "roofShed": _roof("roofShed", 2),
    "s": _h_s, "t": _h_t, "r": _h_r, "center": _h_center, "color": _h_color, "set": _h_set,
    "i": _h_i, **{name: _h_primitive(name) for name in _PRIMITIVE_OPS},
    "alignScopeToGeometry": _h_align_scope_to_geometry, "alignScopeToAxes": _h_align_scope_to_axes,
    "rotateScope": _h_rotate_scope, "mirrorScope": _h_mirror_scope, "mirror": _h_mirror,
    "setPivot": _h_set_pivot, "report": _h_report, "print": _h_print, "convexify": _h_convexify, "reverseNormals": _h_reverse_normals,
    "setupProjection": _h_setup_projection, "projectUV": _uv_op("projectUV", 1, 1),
    "texture": _h_texture, "translateUV": _uv_op("translateUV", 3, 3), "scaleUV": _uv_op("scaleUV", 3, 3),
    "rotateUV": _uv_op("rotateUV", 2, 2), "deleteUV": _uv_op("deleteUV", 1, 1),
    "tileUV": _h_tile_uv, "normalizeUV": _h_normalize_uv,
    "setback": _h_setback("setback"), "setbackPerEdge": _h_setback("setbackPerEdge"),
    "setbackToArea": _h_setback("setbackToArea"), "shapeL": _h_shape_op("shapeL", 2),
    "shapeU": _h_shape_op("shapeU", 3), "shapeO": _h_shape_op("shapeO", 4),
    "innerRectangle": _h_inner_rectangle, "label": _h_label, "scatter": _h_scatter,
}
# Operations CGA writes without parentheses.
_BARE_OPS = {"reverseNormals", "cleanupGeometry", "deleteHoles", "resetGeometry", "resetMaterial",
             "convexify", "innerRectangle", "alignScopeToAxes", "alignScopeToGeometry",
             "primitiveCube", "primitiveQuad", "primitiveDisk", "setPivot", "trim"}

# lot, roof and face-edge operations (translate_lot_ops.py); imported last because its
# handlers use this module's helpers
from .translate_lot_ops import LOT_HANDLERS  # noqa: E402

_HANDLERS.update(LOT_HANDLERS)

__all__ = ["Translator"]
