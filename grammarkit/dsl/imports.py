"""`import "other.grammar"`: inline the statements of imported files (spans keep their file).

Paths are relative to the importing file (or the working directory for text without a file).
A file imported twice (directly or through another import) is inlined once; a cycle is an
error naming the chain; a missing or broken file is an error at the import line.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from .. import confine
from ..errors import Diagnostic, GrammarError
from ..ir import AssetDir, Case, Choice, Grammar, Import, OpCall, Push, Repeat, Rule, Seq, Snippet, Successor
from ..ir.split import Branch
from .frontend import parse_source
from .parser import DEFAULT_MAX_BYTES, read_source

MAX_IMPORT_DEPTH = 32


def resolve_imports(grammar: Grammar, *, max_bytes: int = DEFAULT_MAX_BYTES
                    ) -> tuple[Grammar, list[Diagnostic]]:
    diagnostics: list[Diagnostic] = []
    if not grammar.imports:
        return grammar, diagnostics
    main_path = _key(grammar.source_path) if grammar.source_path else None
    done: set[str] = {main_path} if main_path else set()
    chain = [main_path or "<string>"]
    statements = _expand(grammar, chain, done, diagnostics, max_bytes)
    merged = grammar.model_copy(update={"statements": tuple(statements)})
    return resolve_calls(merged), diagnostics


MAX_PATH_CHARS = 4096  # PATH_MAX of Linux; a longer path cannot name a file


def _path_problem(path: str) -> str | None:
    """Why `path` cannot name a file (None: it can)."""
    if "\0" in path:
        return "it contains a NUL character"
    if len(path) > MAX_PATH_CHARS:
        return f"it is {len(path):,} characters long (the limit is {MAX_PATH_CHARS:,})"
    return None


def _key(path: str) -> str:
    try:
        return str(Path(path).resolve())
    except OSError:
        return str(Path(path).absolute())


def _expand(grammar: Grammar, chain: list[str], done: set[str], diagnostics: list[Diagnostic],
            max_bytes: int) -> list[Any]:
    base = Path(grammar.source_path).parent if grammar.source_path else Path.cwd()
    out: list[Any] = []
    for s in grammar.statements:
        if not isinstance(s, Import):
            out.append(s)
            continue
        problem = _path_problem(s.path)
        if problem is not None:
            diagnostics.append(Diagnostic("error", f"bad import path: {problem}", s.span,
                                          code="import-path"))
            continue
        target = base / s.path
        refused = confine.refusal(s.path, base=base, what="import", span=s.span)
        if refused is not None:  # before anything looks at the file: its existence is not told
            diagnostics.append(refused)
            continue
        try:
            key = _key(str(target))
            found = target.is_file()
        except (OSError, ValueError) as exc:  # e.g. a name longer than the file system allows
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            diagnostics.append(Diagnostic("error", f"bad import path: {reason}", s.span,
                                          code="import-path"))
            continue
        if key in chain:
            names = [Path(c).name for c in chain[chain.index(key):]] + [Path(key).name]
            diagnostics.append(Diagnostic("error", "import cycle: " + " -> ".join(names), s.span,
                                          code="import-cycle"))
            continue
        if key in done:
            continue  # already inlined through another import
        if len(chain) > MAX_IMPORT_DEPTH:
            diagnostics.append(Diagnostic("error", f"imports nested deeper than {MAX_IMPORT_DEPTH}"
                                          " files", s.span, code="import-depth"))
            continue
        if not found:
            diagnostics.append(Diagnostic("error", f"imported file not found: {s.path}", s.span,
                                          hint=f"looked for {target}", code="import-missing"))
            continue
        done.add(key)
        try:
            text = read_source(target, max_bytes=max_bytes)
        except GrammarError as exc:
            diagnostics.extend(exc.diagnostics)
            continue
        parsed = parse_source(text, str(target), max_bytes=max_bytes)
        diagnostics.extend(parsed.diagnostics)
        if parsed.grammar is None:
            diagnostics.append(Diagnostic("error", f"imported file {s.path} has errors", s.span,
                                          code="import-error"))
            continue
        chain.append(key)
        out.extend(_absolute_asset_dirs(_expand(parsed.grammar, chain, done, diagnostics, max_bytes),
                                        target.parent))
        chain.pop()
    return out


def _absolute_asset_dirs(statements: list[Any], folder: Path) -> list[Any]:
    """An imported file's `asset_dir "x"` is relative to that file's folder: once inlined into
    another file it must not change meaning, so it becomes absolute (Path.absolute keeps
    symlinks as written, as the folder of the imported file was reached)."""
    out = []
    for s in statements:
        path = s.path if isinstance(s, AssetDir) else None
        if path and not Path(path).is_absolute():
            value = s.value.model_copy(update={"value": str((folder / path).absolute())})
            s = s.model_copy(update={"value": value})
        out.append(s)
    return out


# -- calls to imported rules ---------------------------------------------------------------

def resolve_calls(grammar: Grammar) -> Grammar:
    """Turn `Name(args)` operation calls into successors when Name is a rule of the grammar.

    Needed after imports: while a file is parsed alone it cannot know the rules of the files
    it imports.
    """
    names = {r.name for r in grammar.rules}
    for s in grammar.snippets:
        names.update(r.name for r in s.rules)
    changed = False
    out = []
    for s in grammar.statements:
        new = s
        if isinstance(s, Rule):
            new = _rule(s, names)
        elif isinstance(s, Snippet):
            rules = tuple(_rule(r, names) for r in s.rules)
            if any(a is not b for a, b in zip(rules, s.rules)):
                new = s.model_copy(update={"rules": rules})
        changed |= new is not s
        out.append(new)
    return grammar.model_copy(update={"statements": tuple(out)}) if changed else grammar


def _rule(r: Rule, names: set[str]) -> Rule:
    body = _seq(r.body, names)
    return r if body is r.body else r.model_copy(update={"body": body})


def _seq(seq: Seq, names: set[str]) -> Seq:
    items = tuple(_item(i, names) for i in seq.items)
    if all(a is b for a, b in zip(items, seq.items)):
        return seq
    return seq.model_copy(update={"items": items})


def _item(item: Any, names: set[str]) -> Any:
    if isinstance(item, OpCall):
        if item.name in names and item.block is None and all(a.name is None for a in item.args):
            return Successor(name=item.name, args=tuple(a.value for a in item.args), span=item.span)
        if item.block is not None:
            block = tuple(_block_item(b, names) for b in item.block)
            if any(a is not b for a, b in zip(block, item.block)):
                return item.model_copy(update={"block": block})
        return item
    if isinstance(item, Push):
        body = _seq(item.body, names)
        return item if body is item.body else item.model_copy(update={"body": body})
    if isinstance(item, (Case, Choice)):
        arms = tuple(a if _seq(a.body, names) is a.body else
                     a.model_copy(update={"body": _seq(a.body, names)}) for a in item.arms)
        other = _seq(item.otherwise, names) if item.otherwise is not None else None
        if all(a is b for a, b in zip(arms, item.arms)) and other is item.otherwise:
            return item
        return item.model_copy(update={"arms": arms, "otherwise": other})
    return item


def _block_item(b: Any, names: set[str]) -> Any:
    if isinstance(b, Branch):
        body = _seq(b.body, names)
        return b if body is b.body else b.model_copy(update={"body": body})
    if isinstance(b, Repeat):
        items = tuple(_block_item(x, names) for x in b.items)
        return b if all(x is y for x, y in zip(items, b.items)) else b.model_copy(update={"items": items})
    return b
