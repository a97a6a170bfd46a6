"""The `.cga` importer: read, parse, translate to IR, print, check — nothing half-done.

    result = translate_cga(text_or_path)      # ImportResult: grammar, text, diagnostics, report
    grammar, diagnostics = import_cga(text_or_path)

The grammar text is produced by grammarkit's printer from the IR and then checked by
`grammarkit.check`; `result.ok` is False (and the CLI writes nothing unless `--force`) when
the CGA text has errors or the translation does not check.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import Diagnostic, GrammarError
from ..ir import Grammar
from ..ir.base import Span
from .assets import place_assets
from .parser import DEFAULT_MAX_BYTES, decode_cga, parse_cga, read_cga
from .report import ImportReport

MISSING_ASSETS = ("keep", "drop", "error")


@dataclass
class ImportResult:
    grammar: Grammar | None
    text: str | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    report: ImportReport = field(default_factory=lambda: ImportReport(None))
    source: str = ""
    filename: str | None = None
    sources: dict = field(default_factory=dict)  # file -> text, of this file and those it imports

    def format(self, d: Diagnostic) -> str:
        """A diagnostic with the caret under its own file's line (an imported file's too)."""
        own = self.sources.get(d.span.file) if d.span is not None and d.span.file else None
        return d.format(own if own is not None else self.source)

    @property
    def ok(self) -> bool:
        """The CGA parsed and the translation is a grammar that `grammarkit check` accepts."""
        return self.text is not None and not any(d.severity == "error" for d in self.diagnostics)


def _load(source: Any, filename: str | None, max_bytes: int) -> tuple[str | None, str | None, list[Diagnostic]]:
    if isinstance(source, str) and "\n" not in source and source.strip().lower().endswith(".cga"):
        source = Path(source.strip())
    if isinstance(source, Path):
        text, diags = read_cga(source, max_bytes=max_bytes)
        return text, filename or str(source), diags
    if isinstance(source, bytes):
        text, diags = decode_cga(source, filename)
        return text, filename, diags
    if not isinstance(source, str):
        return None, filename, [Diagnostic("error", f"expected CGA text or a path, got "
                                           f"{type(source).__name__}", None, code="bad-argument")]
    return source, filename, []


def _operation_names() -> frozenset[str]:
    try:
        from ..plugins import get_plugin_manager
        return frozenset(get_plugin_manager().registries().operations)
    except Exception:  # noqa: BLE001 - a broken plugin must not stop an import; names are a guard
        from ..split.operations import SPECS
        return frozenset(s.name for s in SPECS)


def translate_cga(source: "str | Path | bytes", *, filename: str | None = None,
                  output: "str | Path | None" = None, asset_dirs: tuple = (),
                  missing_assets: str = "keep", max_bytes: int = DEFAULT_MAX_BYTES,
                  project: Any = None, style: str | None = None) -> ImportResult:
    """Translate CGA (text, bytes or a path) to a checked grammar. Never raises for bad input.

    output:         where the grammar will be written (asset paths are made relative to it).
    asset_dirs:     extra folders to look for assets in (CityEngine projects keep them in
                    `assets/` beside `rules/`; both are searched from the .cga file's folder).
    missing_assets: "keep" (default): `i()` of an asset that is not found is kept (the report
                    lists it) as `i(..., missing=skip)`: while deriving, a file that is still
                    not there leaves the shape out with a located warning, as CityEngine does;
                    "drop": such an `i()` is left out at import, with a warning; "error": kept
                    as a plain `i()`, so the derivation stops at a missing file (strict).
    project:        a `cga.project.Project` (from `open_input`: a .cga in a CityEngine project,
                    a project folder, an .rpk): assets and imports are looked up as CityEngine
                    does, and the grammar gets the project's folders as `asset_dir` lines.
    style:          the CGA style to translate (default: the Default style).
    """
    if missing_assets not in MISSING_ASSETS:
        raise ValueError(f"missing_assets must be one of {MISSING_ASSETS}, got {missing_assets!r}")
    text, fname, diags = _load(source, filename, max_bytes)
    result = ImportResult(None, None, list(diags), ImportReport(fname), text or "", fname)
    if text is None:
        return result
    parsed = parse_cga(text, fname, max_bytes=max_bytes)
    result.source = parsed.source
    if not parsed.ok:
        result.diagnostics.extend(parsed.diagnostics)
        return result
    from .translate import Translator
    translator = Translator(parsed.tree, fname, parsed.source,
                            asset_dirs=tuple(Path(d) for d in asset_dirs),
                            missing_assets=missing_assets, operations=_operation_names(),
                            project=project, style=style)
    try:
        grammar = translator.translate()
    except RecursionError:
        result.diagnostics.append(Diagnostic("error", "CGA expressions nested too deeply to translate",
                                             Span(file=fname, line=1, column=1), code="too-deep"))
        return result
    result.report = translator.report
    result.sources = dict(translator.sources)
    result.diagnostics.extend(sorted(translator.diagnostics, key=_position))
    if any(d.severity == "error" for d in translator.diagnostics):
        return result
    dirs = project.search_dirs() if project is not None and project.root is not None else ()
    grammar = place_assets(grammar, translator.report, output, dirs,
                           project.workspace_projects() if dirs else None)
    result.grammar = grammar
    from ..printer import print_grammar
    try:
        out_text = print_grammar(grammar)
    except GrammarError as exc:
        result.diagnostics.extend(exc.diagnostics)
        return result
    _check(result, out_text, output)
    return result


def _position(d: Diagnostic) -> tuple:
    s = d.span
    return (s.line, s.column) if s else (0, 0)


def _check(result: ImportResult, out_text: str, output: "str | Path | None") -> None:
    from ..dsl import check
    out_name = str(output) if output else (
        str(Path(result.filename).with_suffix(".grammar")) if result.filename else "<imported>")
    problems = check(out_text, filename=out_name)
    errors = [d for d in problems if d.severity == "error"]
    result.report.checks = not errors
    result.report.check_errors = [d.format(out_text) for d in errors]
    if errors:
        result.diagnostics.append(Diagnostic(
            "error", f"the translated grammar does not pass `grammarkit check` "
            f"({len(errors)} error(s)); first: {errors[0].message}", Span(file=result.filename),
            code="cga-check-failed", hint="nothing is written (use --force to write it anyway)"))
    result.text = out_text


def import_cga(source: "str | Path | bytes", **kwargs: Any) -> tuple[Grammar | None, list[Diagnostic]]:
    """CGA text or file -> (grammar IR, diagnostics). The grammar is None if the CGA has errors.

    Keyword arguments are those of `translate_cga`. Warnings name every CGA construct that
    was approximated or left out (file:line:col of the CGA source)."""
    result = translate_cga(source, **kwargs)
    return result.grammar, result.diagnostics


__all__ = ["ImportResult", "import_cga", "translate_cga", "MISSING_ASSETS"]
