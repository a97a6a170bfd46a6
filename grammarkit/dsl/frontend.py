"""Source text -> Grammar IR (syntax only): read, parse, transform, attach comments.

`parse_source` never raises for bad input: it returns the diagnostics instead; the public
`grammarkit.dsl.parse` turns them into one GrammarError.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

from ..errors import Diagnostic, DiagnosticBag, GrammarError
from ..gcpause import paused_gc
from ..ir import Grammar, Snippet
from ..ir.base import Span
from .parser import DEFAULT_MAX_BYTES, KEYWORDS, Comment, parse_tree, read_source
from .transform import Header, ToIR, call_names

DEFAULT_NAME = "main"


def default_name(filename: str) -> str:
    """The grammar name of a file without a header: its stem, made a valid identifier."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", Path(filename).stem) or DEFAULT_NAME
    if name[0].isdigit():
        name = "_" + name
    return name + "_" if name in KEYWORDS else name


@dataclass
class Parsed:
    grammar: Grammar | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    source: str = ""
    filename: str | None = None
    has_header: bool = False

    @property
    def ok(self) -> bool:
        return self.grammar is not None and not any(d.severity == "error" for d in self.diagnostics)


def load_text(source: str | Path, filename: str | None = None, *,
              max_bytes: int = DEFAULT_MAX_BYTES) -> tuple[str, str | None]:
    """(text, filename) from a path or a string; raises GrammarError for unreadable files.

    A string is grammar text, except a one-line string ending in `.grammar`, which is a path
    (`grammarkit.parse("grammars/paris.grammar")`); no grammar text can look like that, since a
    statement never ends in `.grammar` outside a string literal."""
    if isinstance(source, str) and "\n" not in source and source.strip().endswith(".grammar"):
        source = Path(source.strip())
    if isinstance(source, Path):
        return read_source(source, max_bytes=max_bytes), filename or str(source)
    if isinstance(source, bytes):
        from .parser import decode_source
        return decode_source(source, filename), filename
    if not isinstance(source, str):
        raise GrammarError(f"expected grammar text or a path, got {type(source).__name__}")
    return source, filename


def parse_source(text: str, filename: str | None = None, *, max_bytes: int = DEFAULT_MAX_BYTES,
                 extra_rule_names: Iterable[str] = ()) -> Parsed:
    with paused_gc():
        return _parse_source(text, filename, max_bytes, extra_rule_names)


def _parse_source(text: str, filename: str | None, max_bytes: int,
                  extra_rule_names: Iterable[str]) -> Parsed:
    result = parse_tree(text, filename, max_bytes=max_bytes)
    if result.tree is None:
        return Parsed(None, result.diagnostics, result.source, filename)
    bag = DiagnosticBag()
    names = call_names(result.tree) | set(extra_rule_names)
    items: list[Any] = ToIR(filename, bag, names).transform(result.tree)
    header: Header | None = None
    statements = []
    for item in items:
        if isinstance(item, Header):
            if header is not None:
                bag.error("the grammar already has a name (only one `grammar` line)", item.span,
                          code="duplicate-header")
            elif statements:
                bag.error("`grammar NAME` must be the first statement of the file", item.span,
                          code="late-header")
            else:
                header = item
        else:
            statements.append(item)
    if header is not None:
        name = header.name
    elif filename:
        name = default_name(filename)
    else:
        name = DEFAULT_NAME
    head_comments, statements, trailing = attach_comments(result.comments, header, statements,
                                                          result.source)
    grammar = Grammar(name=name, statements=tuple(statements), comments=tuple(head_comments),
                      trailing_comments=tuple(trailing), source_path=filename,
                      span=Span(file=filename, line=1, column=1))
    return Parsed(grammar, bag.items, result.source, filename, header is not None)


def attach_comments(comments: list[Comment], header: Header | None, statements: list[Any],
                    source: str) -> tuple[list[str], list[Any], list[str]]:
    """Give each comment to the statement it precedes (or sits in); keeps `fmt` lossless."""
    if not comments:
        return [], statements, []
    head: list[str] = []
    trailing: list[str] = []
    attached: dict[int, list[str]] = {}
    inner: dict[tuple[int, int], list[str]] = {}  # (statement index, inner index) -> comments
    ends = [s.span.end_line if s.span else 0 for s in statements]
    starts = [s.span.line if s.span else 0 for s in statements]
    k = 0
    for c in sorted(comments, key=lambda c: (c.line, c.column)):
        if header is not None and c.line <= header.span.end_line:
            head.append(c.text)
            continue
        while k < len(statements) and ends[k] < c.line:
            k += 1
        if k == len(statements):
            trailing.append(c.text)
            continue
        s = statements[k]
        if isinstance(s, Snippet) and starts[k] < c.line < ends[k]:
            members = sorted(list(s.attrs) + list(s.rules), key=lambda m: m.span.line if m.span else 0)
            for j, m in enumerate(members):
                if m.span is not None and m.span.end_line >= c.line:
                    inner.setdefault((k, j), []).append(c.text)
                    break
            else:
                attached.setdefault(k, []).append(c.text)
            continue
        attached.setdefault(k, []).append(c.text)
    out = []
    for i, s in enumerate(statements):
        if isinstance(s, Snippet) and any(key[0] == i for key in inner):
            members = sorted(list(s.attrs) + list(s.rules), key=lambda m: m.span.line if m.span else 0)
            new_members = {id(m): m.model_copy(update={"comments": tuple(inner[(i, j)])})
                           for j, m in enumerate(members) if (i, j) in inner}
            s = s.model_copy(update={
                "attrs": tuple(new_members.get(id(a), a) for a in s.attrs),
                "rules": tuple(new_members.get(id(r), r) for r in s.rules),
            })
        if i in attached:
            s = s.model_copy(update={"comments": tuple(attached[i])})
        out.append(s)
    return head, out, trailing
