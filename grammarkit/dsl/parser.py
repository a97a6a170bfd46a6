"""Text -> Lark parse tree: the cached LALR parser, the newline postlexer, comments and limits.

Everything that can go wrong with raw text (size, encoding, nesting, syntax) becomes a located
`Diagnostic`; no Lark exception leaves this module.
"""
from __future__ import annotations

import contextvars
import functools
import os
import re
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Iterator

from lark import Lark, Token, Tree
from lark.exceptions import LarkError, UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from ..errors import Diagnostic
from ..gcpause import paused_gc  # noqa: F401  (grammarkit.dsl re-exports it)
from ..fileio import DEFAULT_MAX_BYTES, decode_source, read_limited, read_source  # noqa: F401 - re-exported
from ..ir.base import Span

MAX_NESTING = 48  # brackets; keeps every later recursive pass far from Python's recursion limit
MAX_SYNTAX_ERRORS = 50

# Keywords of the language. They are reserved everywhere (the transformer rejects them as names)
# so that the printer never has to guess whether a name would read back as a keyword.
KEYWORDS = frozenset({
    "grammar", "import", "asset_dir", "attr", "const", "func", "snippet", "use", "as", "default", "for", "variants",
    "case", "else", "NIL", "true", "false", "part", "site", "at", "facing", "mirror", "dock",
    "rot", "neighbors", "in", "constraint", "example",
})
NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

# Statement keywords whose `{ }` holds statements (newline separated) rather than an expression.
_STATEMENT_BLOCK_HEADS = frozenset({"SNIPPET", "EXAMPLE"})
_OPEN = {"(": ")", "[": "]", "{": "}"}
_CLOSE = frozenset(_OPEN.values())


@dataclass(frozen=True)
class Comment:
    line: int
    column: int
    text: str  # without the leading '#'


_LINE_BREAKS = re.compile("[\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]")


class _NestingTooDeep(Exception):
    def __init__(self, token: Token):
        self.token = token


# Comments found by the lexer during the current parse (the parser object is shared and cached).
_comment_sink: contextvars.ContextVar[list | None] = contextvars.ContextVar("_comment_sink", default=None)


def _collect_comment(token: Token) -> Token:
    sink = _comment_sink.get()
    if sink is not None:
        # characters that other tools treat as line breaks would split the comment when printed
        text = _LINE_BREAKS.sub(" ", token.value[1:]).rstrip()
        sink.append(Comment(token.line, token.column, text))
    return token


class StatementPostLexer:
    """Makes newlines end statements, except inside open brackets of an expression.

    Inside `snippet ... { }` and `example NAME { }` newlines (and ';') separate the inner
    statements, as at top level. Also enforces the nesting limit, so that deeply nested input
    gives a clear error instead of a recursion failure later on.
    """

    always_accept = ("_NL", "SEMICOLON", "RBRACE")

    def __init__(self, max_nesting: int = MAX_NESTING):
        self.max_nesting = max_nesting

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        # Tokens are yielded at once: the contextual lexer lexes the next token in the parser
        # state reached after the tokens yielded so far, so nothing may be held back.
        stack: list[tuple[str, bool]] = []  # open brackets: (closing char, is_statement_block)
        at_statement_start = True  # the next token starts a statement (at a statement level)
        head: list[str | None] = [None]  # first token type of the current statement, per level
        last: Token | None = None
        for tok in stream:
            in_statements = not stack or stack[-1][1]
            if tok.type in ("_NL", "SEMICOLON"):
                if in_statements:
                    if not at_statement_start:
                        at_statement_start = True
                        yield Token.new_borrow_pos("_NL", "\n", tok)
                    continue
                if tok.type == "_NL":
                    continue  # newline inside an expression bracket: not a separator
                yield tok  # ';' inside an expression: a syntax error reported by the parser
                continue
            value = tok.value
            is_punct = tok.type not in ("STRING", "NAME", "DOTTED_NAME", "TERMINAL_NAME")
            if is_punct and value == "}" and stack and stack[-1][1]:
                # closing a statement block: its last inner statement ends here
                if not at_statement_start:
                    yield Token.new_borrow_pos("_NL", "\n", tok)
                stack.pop()
                head.pop()
                at_statement_start = False
                last = tok
                yield tok
                continue
            if at_statement_start:
                head[-1] = tok.type
                at_statement_start = False
            if is_punct and value in _OPEN:
                if len(stack) >= self.max_nesting:
                    raise _NestingTooDeep(tok)
                statement_block = (value == "{" and (not stack or stack[-1][1])
                                   and head[-1] in _STATEMENT_BLOCK_HEADS)
                stack.append((_OPEN[value], statement_block))
                if statement_block:
                    head.append(None)
                    at_statement_start = True
            elif is_punct and value in _CLOSE and stack:
                stack.pop()
            last = tok
            yield tok
        if last is not None and (not at_statement_start or stack):
            yield Token("_NL", "", start_pos=last.end_pos, line=last.end_line,
                        column=last.end_column, end_line=last.end_line,
                        end_column=last.end_column, end_pos=last.end_pos)


CACHE_ENV = "GRAMMARKIT_CACHE_DIR"
_PARSER_OPTIONS = dict(
    parser="lalr",
    lexer="contextual",
    # Positions are computed by the transformer's own walk (transform.py), which is ~40%
    # cheaper than Lark's propagate_positions; it needs every token, keywords included.
    propagate_positions=False,
    keep_all_tokens=True,
    maybe_placeholders=False,
)


def cache_dir() -> Path:
    """Where grammarkit keeps caches: $GRAMMARKIT_CACHE_DIR, else $XDG_CACHE_HOME/grammarkit,
    else ~/.cache/grammarkit."""
    explicit = os.environ.get(CACHE_ENV)
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "grammarkit"


def parser_cache_path(text: str) -> Path:
    """The parser-table cache file for this grammar text, Lark version and Python version:
    any change of the three gives another file (and Lark checks the same hash inside it)."""
    import hashlib
    import sys

    import lark

    key = "\0".join([text, lark.__version__, ".".join(map(str, sys.version_info[:2])),
                      repr(sorted(_PARSER_OPTIONS.items()))])
    digest = hashlib.sha256(key.encode("utf-8")).hexdigest()[:24]
    return cache_dir() / f"grammar-lalr-{digest}.lark"


@functools.lru_cache(maxsize=None)
def get_parser() -> Lark:
    """The LALR parser, built once per process. Building the tables costs ~100 ms, so they
    are cached on disk (Lark's own `cache=` file, in `cache_dir()`): a stale file (another
    grammar.lark, Lark or Python version) is never read, a broken one is rebuilt and
    rewritten, and a missing or read-only cache folder just means building every time."""
    text = resources.files("grammarkit.dsl").joinpath("grammar.lark").read_text(encoding="utf-8")
    path = parser_cache_path(text)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        cache: str | bool = str(path)
    except OSError:
        cache = False
    return Lark(text, postlex=StatementPostLexer(), lexer_callbacks={"COMMENT": _collect_comment},
                cache=cache, **_PARSER_OPTIONS)


# -- parsing -------------------------------------------------------------------------------

@dataclass
class ParseResult:
    tree: Tree | None
    comments: list[Comment]
    diagnostics: list[Diagnostic]
    source: str


def parse_tree(source: str, filename: str | None = None, *,
               max_bytes: int = DEFAULT_MAX_BYTES) -> ParseResult:
    """Parse text to a Lark tree. On syntax errors `tree` is None and every error is listed."""
    if source.startswith("\ufeff"):
        source = source[1:]
    if len(source) > max_bytes:
        d = Diagnostic("error", f"grammar text is too large ({len(source):,} characters; the limit "
                       f"is {max_bytes:,})", Span(file=filename, line=1, column=1, end_line=1,
                                                   end_column=1), code="too-large")
        return ParseResult(None, [], [d], source)
    comments: list[Comment] = []
    token = _comment_sink.set(comments)
    try:
        try:
            tree = get_parser().parse(source)
            return ParseResult(tree, comments, [], source)
        except (LarkError, _NestingTooDeep) as exc:
            first = _diagnostic_for(exc, source, filename)
    finally:
        _comment_sink.reset(token)
    # Find every other error: parse statement by statement (only on the error path).
    diagnostics = _all_syntax_errors(source, filename, first)
    return ParseResult(None, comments, diagnostics, source)


def _all_syntax_errors(source: str, filename: str | None, first: Diagnostic) -> list[Diagnostic]:
    found: dict[tuple[int, int], Diagnostic] = {}
    token = _comment_sink.set(None)
    try:
        chunks = list(split_statements(source))
        # Parse runs of statements together; only a run that fails is parsed statement by
        # statement, so a long file with few errors costs about one more parse.
        for g in range(0, len(chunks), _GROUP):
            if len(found) >= MAX_SYNTAX_ERRORS:
                break
            group = chunks[g:g + _GROUP]
            if len(group) > 1 and _parses(group):
                continue
            for k, (start_line, chunk) in enumerate(group):
                if len(found) >= MAX_SYNTAX_ERRORS:
                    break
                try:
                    get_parser().parse(chunk)
                except (LarkError, _NestingTooDeep) as exc:
                    ends_file = g + k == len(chunks) - 1
                    d = _diagnostic_for(exc, chunk, filename, line_offset=start_line - 1,
                                        end_word="end of file" if ends_file else "end of statement")
                    if d.span is not None and d.span.line:
                        shift = start_line - 1  # chunks start at the beginning of a line
                        d = replace(d, span=d.span.model_copy(update={
                            "line": d.span.line + shift, "end_line": d.span.end_line + shift}))
                        found.setdefault((d.span.line, d.message), d)
    finally:
        _comment_sink.reset(token)
    if not found:  # resynchronising found nothing more precise: keep the whole-file error
        found[(first.span.line if first.span else 0, first.message)] = first
    out = sorted(found.values(), key=lambda d: (d.span.line, d.span.column) if d.span else (0, 0))
    if len(out) >= MAX_SYNTAX_ERRORS:
        out.append(Diagnostic("note", f"stopped after {MAX_SYNTAX_ERRORS} syntax errors",
                              Span(file=filename)))
    return out


_GROUP = 64


def _parses(group: list[tuple[int, str]]) -> bool:
    try:
        get_parser().parse("\n".join(chunk for _, chunk in group))
        return True
    except (LarkError, _NestingTooDeep):
        return False


# A line that starts, at column 1, like a top-level statement ends an unclosed bracket (used
# only to resynchronise after a syntax error).
_STATEMENT_START = re.compile(
    r"(?:attr|const|func|import|asset_dir|grammar|snippet|use|default|variants|part|site|dock|neighbors|"
    r"constraint|example)\b|[A-Za-z_][A-Za-z0-9_]*[ \t]*(?:\([^()\n]*\))?[ \t]*-->")


def _code_chars(source: str) -> Iterator[tuple[int, str]]:
    """(index, character) of every character outside strings and comments (newlines included),
    for the scanners below that work without the lexer (after a syntax error)."""
    i, n = 0, len(source)
    while i < n:
        c = source[i]
        if c == '"':  # strings end at their quote or at the end of the line
            j = i + 1
            while j < n and source[j] not in '"\n':
                j += 2 if source[j] == "\\" else 1
            i = j + 1 if j < n and source[j] == '"' else j
            continue
        if c == "#":
            j = source.find("\n", i)
            i = n if j < 0 else j
            continue
        yield i, c
        i += 1


def split_statements(source: str) -> Iterator[tuple[int, str]]:
    """Cut text into top-level statements (newline at bracket depth 0), tracking strings/comments.

    Only used to continue after a syntax error, so it may be approximate: each chunk is parsed
    on its own and its errors reported.
    """
    depth = 0
    start = 0
    start_line = 1
    line = 1
    for i, c in _code_chars(source):
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth = max(0, depth - 1)
        elif c == "\n":
            line += 1
            if depth > 0 and _STATEMENT_START.match(source, i + 1):
                depth = 0
            if depth == 0:
                if source[start:i].strip():
                    yield start_line, source[start:i]
                start = i + 1
                start_line = line
    if source[start:].strip():
        yield start_line, source[start:]


# -- syntax errors in plain words ------------------------------------------------------------

_WORDS = {
    "NAME": "a name",
    "DOTTED_NAME": "a dotted name (like scope.sx or Wall.end)",
    "TERMINAL_NAME": "a terminal (like Wall.)",
    "NUMBER": "a number",
    "INT": "a whole number",
    "PERCENT": "a percentage (like 30%)",
    "STRING": 'a string (like "text")',
    "FACING": "a direction (like +x)",
    "_NL": "end of line",
    "$END": "end of file",
    "SEMICOLON": "';'",
    "CALL_NAME": "a call (like extrude(3))",
}


def describe_terminal(name: str) -> str:
    if name in _WORDS:
        return _WORDS[name]
    try:
        term = get_parser().get_terminal(name)
    except (KeyError, AttributeError):
        return name.lower()
    pattern = term.pattern
    if getattr(pattern, "type", "") == "str":
        return f'"{pattern.value}"' if "'" in pattern.value else f"'{pattern.value}'"
    return name.lower()


def _expected_words(names) -> str:
    words = sorted({describe_terminal(n) for n in names if n not in ("SEMICOLON",)},
                   key=lambda w: (w.startswith("'"), w))
    if not words:
        return ""
    if len(words) > 14:
        words = words[:14] + ["..."]
    return "expected one of: " + ", ".join(words)


def _describe_token(tok: Token) -> str:
    if tok.type == "$END":
        return "end of file"
    if tok.type == "_NL":
        return "end of line"
    text = tok.value if len(tok.value) <= 30 else tok.value[:27] + "..."
    if tok.type in ("NAME", "DOTTED_NAME"):
        return f"name '{text}'"
    if tok.type in ("NUMBER", "INT"):
        return f"number {text}"
    if tok.type == "STRING":
        return f"string {text}"
    return f"'{text}'"


def _line_end_col(source: str, line: int) -> int:
    lines = source.split("\n")
    if 1 <= line <= len(lines):
        return len(lines[line - 1]) + 1
    return 1


def unclosed_brackets(source: str) -> list[tuple[str, int, int]]:
    """Brackets opened in `source` and never closed: (bracket, line, column), outermost first.

    Used to say which bracket an "unexpected end" error is waiting for."""
    stack: list[tuple[str, int, int]] = []
    line, line_start = 1, 0
    for i, c in _code_chars(source):
        if c in "([{":
            stack.append((c, line, i - line_start + 1))
        elif c in ")]}" and stack and _OPEN.get(stack[-1][0]) == c:
            stack.pop()
        elif c == "\n":
            line += 1
            line_start = i + 1
    return stack


def _unclosed_hint(source: str, line_offset: int) -> str | None:
    stack = unclosed_brackets(source)
    if not stack:
        return None
    bracket, line, col = stack[-1]
    return f"the '{bracket}' opened at line {line + line_offset}, column {col} is never closed"


def _diagnostic_for(exc: Exception, source: str, filename: str | None, *, line_offset: int = 0,
                    end_word: str = "end of file") -> Diagnostic:
    if isinstance(exc, _NestingTooDeep):
        t = exc.token
        return Diagnostic("error", f"brackets nested too deeply (the limit is {MAX_NESTING} levels)",
                          Span(file=filename, line=t.line, column=t.column, end_line=t.line,
                               end_column=t.column + 1), code="too-deep",
                          hint="flatten the expression or split it into consts")
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        if tok.type == "_NL" or tok.type == "$END":
            line = tok.line if tok.line is not None and tok.line > 0 else source.count("\n") + 1
            col = tok.column if tok.column and tok.type != "$END" else _line_end_col(source, line)
            what = ("unexpected end of line" if tok.type == "_NL" and tok.value
                    else f"unexpected {end_word}")
        else:
            line, col = tok.line, tok.column
            what = f"unexpected {_describe_token(tok)}"
        width = max(1, len(tok.value)) if tok.type not in ("_NL", "$END") else 1
        hint = _expected_words(exc.expected) or None
        if tok.type in ("_NL", "$END"):
            unclosed = _unclosed_hint(source, line_offset)
            hint = f"{hint}; {unclosed}" if hint and unclosed else (hint or unclosed)
        return Diagnostic("error", f"syntax error: {what}",
                          Span(file=filename, line=line, column=col, end_line=line,
                               end_column=col + width),
                          hint=hint, code="syntax")
    if isinstance(exc, UnexpectedCharacters):
        ch = source[exc.pos_in_stream] if 0 <= exc.pos_in_stream < len(source) else "?"
        if ch == '"':
            what = "unterminated string (strings end on the same line)"
        elif ch == "\t" or ch.isspace():
            what = f"unexpected whitespace character {ch!r}"
        else:
            what = f"unexpected character {ch!r}"
        allowed = getattr(exc, "allowed", None) or ()
        return Diagnostic("error", f"syntax error: {what}",
                          Span(file=filename, line=exc.line, column=exc.column, end_line=exc.line,
                               end_column=exc.column + 1),
                          hint=_expected_words(allowed) or None, code="syntax")
    if isinstance(exc, UnexpectedEOF):
        line = source.count("\n") + 1
        hint = _expected_words(exc.expected) or None
        unclosed = _unclosed_hint(source, line_offset)
        hint = f"{hint}; {unclosed}" if hint and unclosed else (hint or unclosed)
        return Diagnostic("error", f"syntax error: unexpected {end_word}",
                          Span(file=filename, line=line, column=_line_end_col(source, line)),
                          hint=hint, code="syntax")
    if isinstance(exc, UnexpectedInput):
        line = getattr(exc, "line", 1) or 1
        col = getattr(exc, "column", 1) or 1
        return Diagnostic("error", "syntax error", Span(file=filename, line=line, column=col),
                          code="syntax")
    return Diagnostic("error", f"syntax error: {exc}", Span(file=filename, line=1, column=1),
                      code="syntax")
