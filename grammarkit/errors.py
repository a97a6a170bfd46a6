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
from typing import TYPE_CHECKING, Iterable, Literal

if TYPE_CHECKING:  # pragma: no cover - spans are IR (pydantic); this module stays import-light
    from .ir.base import Span

Severity = Literal["error", "warning", "note"]
SHOWN_COLUMNS = 200  # columns of a source line shown under a diagnostic


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
            # a long line is shown as a window of at most SHOWN_COLUMNS around the column, so a
            # one-line 500 KB file does not print half a megabyte per diagnostic
            start = 0
            if len(line_text) > SHOWN_COLUMNS:
                start = max(0, min(caret_col - 1 - SHOWN_COLUMNS // 4, len(line_text) - SHOWN_COLUMNS))
                line_text = ("..." if start else "") + line_text[start:start + SHOWN_COLUMNS] + (
                    "..." if start + SHOWN_COLUMNS < len(line_text) else "")
                caret_col = caret_col - start + (3 if start else 0)
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
    lines = _lines_of(source) if source is not None else (
        _file_lines(span.file) if span.file else None)
    if lines is not None and 1 <= span.line <= len(lines):
        return lines[span.line - 1].rstrip("\r")
    return None


# The lines of the last text and the last few files shown: printing N diagnostics of one file
# reads and splits it once, not N times (which made `check` quadratic in the number of errors).
_last_text: list = [None, None]  # [text, its lines]
_file_cache: dict[tuple, list[str] | None] = {}


def _lines_of(text: str) -> list[str]:
    # split at "\n" only, as the parser counts lines: str.splitlines() also breaks at \f,
    # \x85, U+2028, ..., which would show another line than the one the location names
    if _last_text[0] is not text:
        _last_text[0], _last_text[1] = text, text.split("\n")
    return _last_text[1]


def _file_lines(file: str) -> list[str] | None:
    import os

    try:
        st = os.stat(file)
    except (OSError, ValueError):
        return None
    key = (file, st.st_mtime_ns, st.st_size, st.st_ino)
    if key not in _file_cache:
        if len(_file_cache) >= 8:
            _file_cache.pop(next(iter(_file_cache)))
        data = _read_regular(file, _SHOWN_FILE_BYTES)
        lines = None if data is None else (
            data.decode("utf-8", "replace").removeprefix("\ufeff").split("\n"))
        _file_cache[key] = lines
    return _file_cache[key]


_SHOWN_FILE_BYTES = 2 * 1024 * 1024  # a diagnostic shows lines of files up to this size


def _read_regular(file: str, max_bytes: int) -> bytes | None:
    """The bytes of a regular file of at most `max_bytes`, else None. A diagnostic never reads
    a FIFO or a device. Written here rather than taken from grammarkit.fileio because this
    module is the bottom floor that fileio itself builds on (docs/architecture.md)."""
    import os
    import stat

    try:
        fd = os.open(file, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError):
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > max_bytes:
            return None
        os.set_blocking(fd, True)
        data = os.read(fd, max_bytes + 1)
        return None if len(data) > max_bytes else data
    except OSError:
        return None
    finally:
        os.close(fd)


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

    def __str__(self) -> str:
        """`file:line:col: message` of the first error (as the CLI prints it, without the
        source line), and how many more there are; `format()` gives them all."""
        errors = [d for d in self.diagnostics if d.severity == "error"] or self.diagnostics
        first = errors[0]
        span = first.span
        loc = f"{span}: " if span is not None and span.line else (
            f"{span.file}: " if span is not None and span.file else "")
        more = f" (and {len(errors) - 1} more error{'s' if len(errors) > 2 else ''})" \
            if len(errors) > 1 else ""
        text = first.message if first.message else (self.args[0] if self.args else "")
        return f"{loc}{text}{more}"

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
