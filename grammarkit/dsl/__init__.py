"""The .grammar language: text -> IR, semantic checks, imports.

    parse(source, *, filename=None) -> Grammar        # syntax only; GrammarError lists all errors
    check(source, *, filename=None) -> [Diagnostic]   # syntax + imports + semantics, never raises
                                                      # for bad grammar input
    load(source, *, filename=None) -> Grammar         # parse + inline imports + check; raises
                                                      # GrammarError if there are errors

`source` is grammar text, a pathlib.Path, or (for check/load) an already built Grammar.
Files larger than `max_bytes` (default 5 MB) are refused with a located error.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import Diagnostic, GrammarError
from ..ir import Grammar
from ..registry import Registries
from .checker import BUILTIN_CONSTRAINTS, BUILTIN_REFS, check_grammar
from .frontend import Parsed, load_text, parse_source
from .imports import resolve_calls, resolve_imports
from .parser import DEFAULT_MAX_BYTES, KEYWORDS, paused_gc

# resolve_calls is part of the toolkit for engines that build grammars in code
__all__ = ["parse", "check", "load", "parse_with_header", "check_text", "KEYWORDS", "BUILTIN_REFS",
           "BUILTIN_CONSTRAINTS", "DEFAULT_MAX_BYTES", "Registries", "resolve_calls"]


def _parsed(source: Any, filename: str | None, max_bytes: int) -> Parsed:
    text, fname = load_text(source, filename, max_bytes=max_bytes)
    return parse_source(text, fname, max_bytes=max_bytes)  # parse_source pauses the GC itself


def _raise(diagnostics: list[Diagnostic]) -> None:
    errors = [d for d in diagnostics if d.severity == "error"]
    if errors:
        raise GrammarError(errors[0].message, errors[0].span, diagnostics=diagnostics)


def parse(source: "str | Path", *, filename: str | None = None,
          max_bytes: int = DEFAULT_MAX_BYTES) -> Grammar:
    """Grammar text (or a file) -> IR. Raises GrammarError carrying every syntax error."""
    parsed = _parsed(source, filename, max_bytes)
    _raise(parsed.diagnostics)
    assert parsed.grammar is not None
    return parsed.grammar


def parse_with_header(source: "str | Path", *, filename: str | None = None,
                      max_bytes: int = DEFAULT_MAX_BYTES) -> tuple[Grammar, bool]:
    """Like parse, also telling whether the text had a `grammar NAME` line (for `fmt`)."""
    parsed = _parsed(source, filename, max_bytes)
    _raise(parsed.diagnostics)
    assert parsed.grammar is not None
    return parsed.grammar, parsed.has_header


def _sorted(diags: list[Diagnostic]) -> list[Diagnostic]:
    def key(d: Diagnostic):
        s = d.span
        return (s.file or "" if s else "", s.line if s else 0, s.column if s else 0)
    return sorted(diags, key=key)


def _check(source: Any, filename: str | None, max_bytes: int,
           registries: Registries | None) -> tuple[Grammar | None, list[Diagnostic]]:
    if isinstance(source, Grammar):
        grammar = source
        diags: list[Diagnostic] = []
    else:
        try:
            parsed = _parsed(source, filename, max_bytes)
        except GrammarError as exc:
            return None, list(exc.diagnostics)
        diags = list(parsed.diagnostics)
        if parsed.grammar is None or any(d.severity == "error" for d in diags):
            return None, diags
        grammar = parsed.grammar
    main_file = grammar.source_path
    merged, import_diags = resolve_imports(grammar, max_bytes=max_bytes)
    diags.extend(import_diags)
    if any(d.severity == "error" for d in import_diags):
        return None, diags
    if registries is None:  # the public API edge: the installed plugins' registries
        from ..plugins import default_registries

        registries = default_registries()
    with paused_gc():  # as parse_source does: the checker allocates ~1 object per byte
        diags.extend(_sorted(check_grammar(merged, registries, main_file)))
    return merged, diags


def check(source: "str | Path | Grammar", *, filename: str | None = None,
          max_bytes: int = DEFAULT_MAX_BYTES, registries: Registries | None = None
          ) -> list[Diagnostic]:
    """Every problem of a grammar (errors and warnings), without raising for bad input."""
    return _check(source, filename, max_bytes, registries)[1]


def check_text(source: "str | Path | Grammar", **kwargs: Any) -> tuple[Grammar | None, list[Diagnostic]]:
    """(merged grammar or None, diagnostics): what `grammarkit check --emit-ir` needs."""
    return _check(source, kwargs.get("filename"), kwargs.get("max_bytes", DEFAULT_MAX_BYTES),
                  kwargs.get("registries"))


def load(source: "str | Path | Grammar", *, filename: str | None = None,
         max_bytes: int = DEFAULT_MAX_BYTES, registries: Registries | None = None) -> Grammar:
    """Parse, inline imports and check; raises GrammarError if there is any error.

    Warnings (e.g. undefined successors that become leaves) are available via `check`.
    """
    grammar, diags = _check(source, filename, max_bytes, registries)
    _raise(diags)
    assert grammar is not None
    return grammar
