"""CGA text -> Lark tree, with located syntax errors in plain words.

The grammar is `cga.lark` (LALR, contextual lexer). Parsing never raises for bad input: a
file that does not parse gives one located error (`file:line:col`) naming what was found and
what was expected there; CGA has no statement separator to resynchronise on reliably, so the
first error is the one reported.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from lark import Lark, Token, Tree
from lark.exceptions import (
    LarkError,
    UnexpectedCharacters,
    UnexpectedEOF,
    UnexpectedToken,
)

from ..errors import Diagnostic, GrammarkitError
from ..fileio import DEFAULT_MAX_BYTES as CHECK_MAX_BYTES
from ..fileio import read_bounded
from ..ir.base import Span

# the same limit as `grammarkit check` (the largest corpus file is 31 KB; a 2.7 MB file of
# 60,000 rules took 120 s and 1.2 GB to translate: issue 31); `--max-size` raises it
DEFAULT_MAX_BYTES = CHECK_MAX_BYTES
# Brackets deeper than this are refused before parsing: the translator walks the tree
# recursively, and real rule files nest a handful of levels.
MAX_NESTING = 48


@functools.lru_cache(maxsize=None)
def get_parser() -> Lark:
    """The LALR parser for CGA, built once per process."""
    text = resources.files("grammarkit.cga").joinpath("cga.lark").read_text(encoding="utf-8")
    return Lark(text, parser="lalr", lexer="contextual", propagate_positions=True,
                maybe_placeholders=False, cache=False)


@dataclass
class CgaParse:
    tree: Tree | None
    source: str
    filename: str | None
    diagnostics: list[Diagnostic] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.tree is not None


def read_cga(path: Path, *, max_bytes: int = DEFAULT_MAX_BYTES) -> tuple[str | None, list[Diagnostic]]:
    """(text, diagnostics) of a .cga file: unreadable, too large or non-text files are errors.

    CityEngine writes UTF-8; older files may be Latin-1 (umlauts in comments), which is
    accepted with a warning rather than refused."""
    fname = str(path)
    try:
        # regular files only, never more than max_bytes + 1 bytes (a device such as /dev/zero
        # has st_size 0 and no end: issue 31)
        data = read_bounded(path, max_bytes=max_bytes)
    except GrammarkitError as exc:
        return None, list(exc.diagnostics)
    return decode_cga(data, fname)


def decode_cga(data: bytes, filename: str | None) -> tuple[str | None, list[Diagnostic]]:
    if b"\x00" in data:
        at = data.index(b"\x00")
        line = data[:at].count(b"\n") + 1
        col = at - (data[:at].rfind(b"\n") + 1) + 1
        return None, [Diagnostic("error", "not a text file (NUL byte)",
                                 Span(file=filename, line=line, column=col), code="encoding")]
    try:
        return data.decode("utf-8"), []
    except UnicodeDecodeError as exc:
        before = data[:exc.start]
        line = before.count(b"\n") + 1
        col = exc.start - (before.rfind(b"\n") + 1) + 1
        return data.decode("latin-1"), [Diagnostic(
            "warning", f"file is not valid UTF-8 (byte 0x{data[exc.start]:02x}); read as Latin-1",
            Span(file=filename, line=line, column=col, end_line=line, end_column=col + 1),
            code="encoding")]


def parse_cga(source: str, filename: str | None = None, *,
              max_bytes: int = DEFAULT_MAX_BYTES) -> CgaParse:
    """Parse CGA text. On a syntax error `tree` is None and `diagnostics` holds a located error."""
    if source.startswith("\ufeff"):
        source = source[1:]
    if len(source) > max_bytes:
        return CgaParse(None, source, filename, [Diagnostic(
            "error", f"CGA text is too large ({len(source):,} characters; the limit is "
            f"{max_bytes:,})", Span(file=filename, line=1, column=1), code="too-large")])
    deep = _too_deep(source)
    if deep is not None:
        line, col = deep
        return CgaParse(None, source, filename, [Diagnostic(
            "error", f"brackets nested too deeply (the limit is {MAX_NESTING} levels)",
            Span(file=filename, line=line, column=col, end_line=line, end_column=col + 1),
            code="too-deep")])
    try:
        tree = get_parser().parse(source)
    except LarkError as exc:
        return CgaParse(None, source, filename, [_diagnostic(exc, source, filename)])
    except RecursionError:
        return CgaParse(None, source, filename, [Diagnostic(
            "error", "CGA text nested too deeply to parse", Span(file=filename, line=1, column=1),
            code="too-deep")])
    return CgaParse(tree, source, filename)


def _too_deep(source: str) -> tuple[int, int] | None:
    """Position of the first bracket beyond MAX_NESTING (strings and comments skipped)."""
    depth, line, line_start, i, n = 0, 1, 0, 0, len(source)
    while i < n:
        c = source[i]
        if c == '"':
            j = i + 1
            while j < n and source[j] not in '"\n':
                j += 2 if source[j] == "\\" else 1
            i = j + 1
            continue
        if c == "#" or source.startswith("//", i):
            j = source.find("\n", i)
            i = n if j < 0 else j
            continue
        if source.startswith("/*", i):
            j = source.find("*/", i + 2)
            end = n if j < 0 else j + 2
            line += source.count("\n", i, end)
            k = source.rfind("\n", i, end)
            if k >= 0:
                line_start = k + 1
            i = end
            continue
        if c in "([{":
            depth += 1
            if depth > MAX_NESTING:
                return line, i - line_start + 1
        elif c in ")]}":
            depth = max(0, depth - 1)
        elif c == "\n":
            line += 1
            line_start = i + 1
        i += 1
    return None


_WORDS = {
    "NAME": "a name", "NUMBER": "a number", "STRING": 'a string (like "text")',
    "RULE_HEAD": "a rule (like Lot -->)", "FUNC_HEAD": "a definition (like name = value)",
    "ANNOTATION": "an annotation (like @Range)", "PERCENT_COLON": "'%:'", "$END": "end of file",
    "ATTR": "'attr'", "STYLE": "'style'", "EXTENDS": "'extends'", "CONST": "'const'", "CASE": "'case'", "ELSE": "'else'", "NIL": "'NIL'",
    "TRUE": "'true'", "FALSE": "'false'", "STAR": "'*'", "EQ_OP": "'=='", "CMP_OP": "'<'",
    "PLUS": "'+'", "MINUS": "'-'", "SLASH": "'/'", "MODULO": "'%'",
}


def _word(name: str) -> str:
    if name in _WORDS:
        return _WORDS[name]
    try:
        pattern = get_parser().get_terminal(name).pattern
    except (KeyError, AttributeError):
        return name.lower()
    if getattr(pattern, "type", "") == "str":
        return f"'{pattern.value}'"
    return name.lower()


def _expected(names) -> str | None:
    words = sorted({_word(n) for n in names})
    if not words:
        return None
    if len(words) > 12:
        words = words[:12] + ["..."]
    return "expected one of: " + ", ".join(words)


def _describe(tok: Token) -> str:
    if tok.type == "$END":
        return "end of file"
    text = tok.value if len(tok.value) <= 30 else tok.value[:27] + "..."
    text = text.replace("\n", " ")
    if tok.type == "NAME":
        return f"name '{text}'"
    if tok.type == "NUMBER":
        return f"number {text}"
    if tok.type == "STRING":
        return f"string {text}"
    if tok.type == "RULE_HEAD":
        return f"rule head '{text}'"
    return f"'{text}'"


def _end(source: str) -> tuple[int, int]:
    lines = source.split("\n")
    return len(lines), len(lines[-1]) + 1


def _diagnostic(exc: Exception, source: str, filename: str | None) -> Diagnostic:
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        if tok.type == "$END" or not tok.line:
            line, col = _end(source)
            width = 1
        else:
            line, col = tok.line, tok.column
            first_line = tok.value.split("\n", 1)[0]
            width = max(1, len(first_line))
        return Diagnostic("error", f"CGA syntax error: unexpected {_describe(tok)}",
                          Span(file=filename, line=line, column=col, end_line=line,
                               end_column=col + width),
                          hint=_expected(exc.expected), code="cga-syntax")
    if isinstance(exc, UnexpectedCharacters):
        pos = exc.pos_in_stream
        ch = source[pos] if 0 <= pos < len(source) else "?"
        what = ("unterminated string (CGA strings end on the same line)" if ch == '"'
                else f"unexpected character {ch!r}")
        return Diagnostic("error", f"CGA syntax error: {what}",
                          Span(file=filename, line=exc.line, column=exc.column, end_line=exc.line,
                               end_column=exc.column + 1),
                          hint=_expected(getattr(exc, "allowed", None) or ()), code="cga-syntax")
    if isinstance(exc, UnexpectedEOF):
        line, col = _end(source)
        return Diagnostic("error", "CGA syntax error: unexpected end of file",
                          Span(file=filename, line=line, column=col), hint=_expected(exc.expected),
                          code="cga-syntax")
    line = getattr(exc, "line", 1) or 1
    col = getattr(exc, "column", 1) or 1
    return Diagnostic("error", f"CGA syntax error: {type(exc).__name__}",
                      Span(file=filename, line=line, column=col), code="cga-syntax")
