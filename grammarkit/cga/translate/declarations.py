"""Declarations of a CGA file: rules, attrs, consts, functions and imported files (merged under their alias)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from lark import Token, Tree

from ...errors import Diagnostic
from ...ir.base import Span
from ..expressions import (
    Function,
    unquote,
)
from ..parser import parse_cga, read_cga
from .model import (
    HEAD,
    RuleDef,
    ValueDef,
    params_of,
)


class DeclarationsMixin:
    """Collects the declarations of the file and of the files it imports."""

    # -- declarations ---------------------------------------------------------------------------
    def collect(self) -> None:
        current = "Default"  # the style the declarations belong to (CGA: Default until `style`)
        styles: dict[str, Any] = {"Default": None}
        wanted = self.style or "Default"
        for node in self.tree.children:
            if node.data == "version":
                self.report.ignored["version"] += 1
                continue
            annotations = [c for c in node.children if isinstance(c, Tree) and c.data == "annotation"]
            decl = node.children[-1]
            if decl.data == "style_stmt":
                names = [t.value for t in decl.children if isinstance(t, Token) and t.type == "NAME"]
                current = names[0]
                styles[current] = (self._span(decl), names[1] if len(names) > 1 else None)
                for a in annotations:
                    self.report.ignored[a.children[0].value] += 1
                continue
            if current != "Default" and not self._style_applies(current, wanted, styles):
                self.report.ignored[f"style {current}"] += 1  # a declaration of another style
                continue
            if current != "Default" and self._override(decl, annotations):
                continue
            if decl.data == "import_stmt":
                self._collect_import(decl, annotations)
                continue
            if decl.data == "import_unquoted":
                # `import lib.cga`: CGA's import names its file in quotes; said where, not guessed
                self.diagnostics.append(Diagnostic(
                    "error", f"import {decl.children[0].value}: the file name must be in quotes "
                    f"(import alias : \"file.cga\")", self._span(decl), code="cga-syntax"))
                continue
            kind = decl.data
            head_tok = decl.children[1] if kind in ("attr_decl", "const_decl") else decl.children[0]
            m = HEAD.match(head_tok.value)
            name = m.group(1)
            params = params_of(m.group(2))
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

        self._check_style(wanted, styles)

    @staticmethod
    def _style_applies(current: str, wanted: str, styles: dict) -> bool:
        """Whether declarations of style `current` apply when `wanted` is chosen (the chosen
        style and the styles it extends)."""
        seen = set()
        name: Any = wanted
        while name and name != "Default" and name not in seen:
            if name == current:
                return True
            seen.add(name)
            info = styles.get(name)
            name = info[1] if info else None
        return False

    def _check_style(self, wanted: str, styles: dict) -> None:
        if wanted != "Default" and wanted not in styles:
            self.diagnostics.append(Diagnostic(
                "error", f"no style {wanted!r} in this file; its styles are: " + ", ".join(styles),
                Span(file=self.filename, line=1, column=1), code="cga-no-style"))
        for name, info in styles.items():
            if info is None:
                continue
            status = "translated" if self._style_applies(name, wanted, styles) else "ignored"
            if status == "translated":
                self._record("style", name, "translated", info[0])
            else:
                self.report.ignored["style"] += 1

    def _override(self, decl: Tree, annotations: list) -> bool:
        """A declaration of the chosen style: it replaces the Default style's declaration of
        the same name (an attr keeps the Default's annotations unless it has its own); True
        if it replaced one, False if it is new (then it is collected as usual)."""
        kind = decl.data
        if kind not in ("attr_decl", "const_decl", "rule_decl", "func_decl"):
            return False
        head_tok = decl.children[1] if kind in ("attr_decl", "const_decl") else decl.children[0]
        m = HEAD.match(head_tok.value)
        name, params = m.group(1), params_of(m.group(2))
        if kind == "rule_decl":
            key = (name, len(params))
            old = self.rules.get(key)
            if old is None:
                return False
            self.rules[key] = RuleDef(name, params, decl.children[1], self._span(head_tok),
                                      old.start or any(a.children[0].value == "@StartRule" for a in annotations),
                                      annotations or old.annotations)
            return True
        if kind == "func_decl" or m.group(2) is not None:
            key = (name, len(params))
            if key not in self.functions:
                return False
            self.functions[key] = Function(name, params, decl.children[-1])
            return True
        for i, v in enumerate(self.values):
            if v.name == name and not v.imported:
                self.values[i] = ValueDef(v.kind, name, decl.children[-1], self._span(head_tok),
                                          annotations or v.annotations)
                return True
        return False

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
        if self.project is not None and self.project.root is not None:
            found = self.project.resolve(path, relative_to=base)
            if found is not None:
                return found
        for cand in (base / path.lstrip("/"), base / Path(path).name):
            if cand.is_file():
                return cand
        return None

    def _load_import(self, path: Path) -> tuple[Any, str]:
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
        child = type(self)(parsed.tree, str(path), parsed.source, asset_dirs=self.asset_dirs,
                           missing_assets=self.missing_assets, operations=self.operations,
                           project=self.project)  # an import uses its own default style
        child._import_chain = (*chain, key)  # type: ignore[attr-defined]
        child.collect()
        # what the child's declarations left out is this import's to say (never silent)
        for c in child.report.constructs + child.report.imported:
            if c.status != "translated" and c.span is not None:
                self._imported_warning(c)
        self.sources.update(child.sources)
        return child, ""

    def _merge_import(self, alias: str, child: Any, overrides: dict) -> None:
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

