"""One exception family for everything a user can get wrong, each carrying a location.

- `Diagnostic`: one message with severity and span (what `grammarkit check` prints).
- `GrammarError`: raised when a grammar has errors; carries all diagnostics at once.
- `DerivationError` / `LimitError`: runtime problems of an engine, naming the rule and source line.
- `ShapeError`: a bad shape/mesh input, naming the file and part.
- `PluginError`: a plugin failed to load or misbehaved, naming the plugin.

The CLI prints these as `file:line:col: error: message`, the source line and a caret,
and exits non-zero; it never shows a traceback for them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Literal

if TYPE_CHECKING:  # pragma: no cover - spans are IR (pydantic); this module stays import-light
    from .ir.base import Span

Severity = Literal["error", "warning", "note"]


@dataclass(frozen=True)
class Diagnostic:
    severity: Severity
    message: str
    span: Span | None = None
    hint: str | None = None  # extra plain-words help, e.g. "expected one of: ..."
    code: str | None = None  # stable machine-readable identifier, e.g. "undefined-successor"

    def to_json(self) -> dict:
        span = self.span
        return {
            "severity": self.severity,
            "message": self.message,
            "code": self.code,
            "hint": self.hint,
            "file": span.file if span else None,
            "line": span.line if span else None,
            "column": span.column if span else None,
            "end_line": span.end_line if span else None,
            "end_column": span.end_column if span else None,
        }

    def format(self, source: str | None = None) -> str:
        """`file:line:col: severity: message`, then the source line with a caret if known."""
        loc = f"{self.span}: " if self.span and self.span.line else (
            f"{self.span.file}: " if self.span and self.span.file else "")
        out = [f"{loc}{self.severity}: {self.message}"]
        line_text = _source_line(self.span, source)
        if line_text is not None and self.span is not None:
            caret_col = max(self.span.column, 1)
            width = 1
            if self.span.end_line == self.span.line and self.span.end_column > self.span.column:
                width = self.span.end_column - self.span.column
            width = max(1, min(width, max(1, len(line_text) - caret_col + 1)))
            shown = line_text.expandtabs(1)
            out.append(f"    {shown}")
            out.append("    " + " " * (caret_col - 1) + "^" + "~" * (width - 1))
        if self.hint:
            out.append(f"    = {self.hint}")
        return "\n".join(out)


def _source_line(span: Span | None, source: str | None) -> str | None:
    if span is None or not span.line:
        return None
    if source is None and span.file:
        try:
            source = Path(span.file).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return None
    if source is None:
        return None
    lines = source.splitlines()
    if 1 <= span.line <= len(lines):
        line = lines[span.line - 1]
        return line if len(line) <= 400 else line[:400]
    return None


class GrammarkitError(Exception):
    """Base of all user-facing errors. `diagnostics` holds at least one entry."""

    def __init__(self, message: str, span: Span | None = None, *, hint: str | None = None,
                 code: str | None = None, diagnostics: Iterable[Diagnostic] | None = None):
        self.diagnostics: list[Diagnostic] = list(diagnostics) if diagnostics else [
            Diagnostic("error", message, span, hint, code)]
        super().__init__(message)

    @property
    def span(self) -> Span | None:
        return self.diagnostics[0].span

    def format(self, source: str | None = None) -> str:
        return "\n".join(d.format(source) for d in self.diagnostics)


class GrammarError(GrammarkitError):
    """The grammar text or IR has errors (syntax or semantics)."""


class DerivationError(GrammarkitError):
    """A derivation failed at runtime; the span points at the rule or operation."""


class LimitError(DerivationError):
    """A resource limit (depth, shape count, repeat count, triangles) was exceeded."""


class ShapeError(GrammarkitError):
    """A mesh or assembly input is unusable; the message names the file and part."""


class PluginError(GrammarkitError):
    """A plugin failed to load or misbehaved; the message names the plugin."""


@dataclass
class DiagnosticBag:
    """Collects diagnostics so that every problem in a file is reported at once."""

    items: list[Diagnostic] = field(default_factory=list)

    def error(self, message: str, span: Span | None = None, *, hint: str | None = None,
              code: str | None = None) -> None:
        self.items.append(Diagnostic("error", message, span, hint, code))

    def warning(self, message: str, span: Span | None = None, *, hint: str | None = None,
                code: str | None = None) -> None:
        self.items.append(Diagnostic("warning", message, span, hint, code))

    @property
    def has_errors(self) -> bool:
        return any(d.severity == "error" for d in self.items)

    def raise_if_errors(self, cls: type[GrammarkitError] = GrammarError) -> None:
        errors = [d for d in self.items if d.severity == "error"]
        if errors:
            raise cls(errors[0].message, errors[0].span, diagnostics=self.items)
