"""The snippet library as the recognizer sees it: object types, snippets, their ranged
parameters, default snippets, where each object type is anchored, and the library's hash.

A snippet's *parameters* are its numeric attrs with an `@range(lo, hi)`: those are what the
regression networks estimate, normalised to [0, 1] by the range (Nishida et al. 2016, s. 5.2).
Enum and string attrs (colours, materials) do not show in a line drawing and keep their
default values.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

from grammarkit.errors import GrammarError
from grammarkit.ir import Grammar, OpCall, Snippet, Successor
from grammarkit.ir import Num, Str, Unary

#: How an object type is anchored in a building, found from the library's own rules:
#: "ground" (on the lot: the first stage), "top" (on a top face: roofs) or "face" (on a face
#: of a facade: facades, floors, windows, ledges).
ANCHOR_KINDS = ("ground", "top", "face")


@dataclass(frozen=True)
class ParamSpec:
    """A ranged numeric attr of a snippet."""

    name: str
    lo: float
    hi: float
    default: float

    def normalise(self, value: float) -> float:
        return (float(value) - self.lo) / (self.hi - self.lo)

    def value(self, u: float) -> float:
        """The attr value for a normalised value `u` (clamped into the range)."""
        u = min(1.0, max(0.0, float(u)))
        return self.lo + u * (self.hi - self.lo)


@dataclass(frozen=True)
class SnippetInfo:
    name: str
    object_type: str
    params: tuple[ParamSpec, ...]
    snippet: Snippet

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    def defaults(self) -> dict[str, float]:
        return {p.name: p.default for p in self.params}


class SnippetLibrary:
    """A parsed snippet library (`grammars/library.grammar` or a third party's)."""

    def __init__(self, grammar: Grammar, path: str | None = None):
        self.grammar = grammar
        self.path = path
        self.snippets: dict[str, SnippetInfo] = {}
        for s in grammar.snippets:
            self.snippets[s.name] = SnippetInfo(s.name, s.object_type, tuple(_params(s)), s)
        if not self.snippets:
            raise GrammarError(f"{path or 'the library'}: has no snippets to recognise", None,
                               code="sketch-no-snippets")
        self.types: list[str] = []
        for s in self.snippets.values():
            if s.object_type not in self.types:
                self.types.append(s.object_type)
        self.defaults = {d.object_type: d.snippet for d in grammar.defaults}
        self.anchor_kinds = _anchor_kinds(grammar, self.types)
        self.hash = library_hash(grammar)
        # part meshes the snippets insert that are not there (the hash then differs from a
        # models file's, and the message must say which file is missing, not "changed")
        self.missing_assets = [p for p in _asset_paths(grammar) if not p.is_file()]

    @property
    def name(self) -> str:
        return self.grammar.name

    def snippets_of(self, object_type: str) -> list[SnippetInfo]:
        return [s for s in self.snippets.values() if s.object_type == object_type]

    def default_for(self, object_type: str) -> str:
        """The library's `default` snippet for a type, else its first snippet."""
        name = self.defaults.get(object_type)
        if name in self.snippets:
            return name
        return self.snippets_of(object_type)[0].name

    def check_type(self, object_type: str) -> str:
        """The type's canonical spelling (case-insensitive match), or a GrammarError listing them."""
        for t in self.types:
            if t.lower() == str(object_type).lower():
                return t
        raise GrammarError(f"unknown object type {object_type!r}; the library {self.name!r} has "
                           f"{', '.join(self.types)}", None, code="sketch-unknown-type")


def load_library(source: Any) -> SnippetLibrary:
    """A SnippetLibrary from a path, grammar text or a Grammar (imports resolved)."""
    from grammarkit.split import load_grammar

    if isinstance(source, SnippetLibrary):
        return source
    path = None
    if isinstance(source, (str, Path)) and (isinstance(source, Path) or "\n" not in source):
        p = Path(source)
        if not p.is_file():
            raise GrammarError(f"{p}: library file not found", None, code="sketch-no-library")
        path = str(p)
        source = p
    grammar = load_grammar(source)
    return SnippetLibrary(grammar, path or grammar.source_path)


# ------------------------------------------------------------------------------------------
def _number(expr: Any) -> float | None:
    if isinstance(expr, Num):
        return float(expr.value)
    if isinstance(expr, Unary) and expr.op in "+-" and isinstance(expr.operand, Num):
        return -float(expr.operand.value) if expr.op == "-" else float(expr.operand.value)
    return None


def _params(s: Snippet) -> Iterable[ParamSpec]:
    for a in s.attrs:
        if a.range is None:
            continue
        default = _number(a.value)
        lo, hi = _number(a.range[0]), _number(a.range[1])
        if default is None or lo is None or hi is None:
            # the recognizer samples ranges before any derivation: they must be plain numbers
            raise GrammarError(f"snippet {s.name!r}: attr {a.name!r} needs a number value and a "
                               "@range of two numbers to be sketch-recognised", a.span,
                               code="sketch-range")
        if not hi > lo:
            raise GrammarError(f"snippet {s.name!r}: attr {a.name!r} has an empty range "
                               f"[{lo:g}, {hi:g}]", a.span, code="sketch-range")
        yield ParamSpec(a.name, lo, hi, default)


def _walk_block_successors(items: Any, key: Any, out: list[tuple[str | None, str]]) -> None:
    """(selector or None, successor name) pairs reachable in a block or sequence."""
    from grammarkit.ir import Branch, Case, Choice, Push, Repeat, Seq

    if isinstance(items, Seq):
        items = items.items
    for it in items or ():
        if isinstance(it, Successor):
            out.append((key, it.name))
        elif isinstance(it, OpCall) and it.block is not None:
            for b in it.block:
                _walk_block_successors((b,), None, out)
        elif isinstance(it, Branch):
            sel = it.key.name if getattr(it.key, "kind", None) == "ref" else None
            _walk_block_successors(it.body, sel, out)
        elif isinstance(it, Repeat):
            _walk_block_successors(it.items, key, out)
        elif isinstance(it, Push):
            _walk_block_successors(it.body, key, out)
        elif isinstance(it, (Case, Choice)):
            for arm in it.arms:
                _walk_block_successors(arm.body, key, out)
            if it.otherwise is not None:
                _walk_block_successors(it.otherwise, key, out)
        elif getattr(it, "kind", None) == "pattern":
            out.extend((key, n) for n in (*it.group, *((it.tail,) if it.tail else ())))


def _anchor_kinds(grammar: Grammar, types: list[str]) -> dict[str, str]:
    """Where each object type is anchored: a type reached through `comp(f) { top: T }` is a
    roof-like type ("top"), one reached any other way from another snippet sits on a face
    ("face"); a type no snippet refers to stands on the lot ("ground")."""
    found: dict[str, set[str]] = {t: set() for t in types}
    for s in grammar.snippets:
        for r in s.rules:
            pairs: list[tuple[str | None, str]] = []
            _walk_block_successors(r.body, None, pairs)
            for sel, name in pairs:
                if name in found and name != s.object_type:
                    found[name].add("top" if sel == "top" else "face")
    return {t: ("ground" if not k else "top" if k == {"top"} else "face") for t, k in found.items()}


def _strip(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items()
                if k not in ("span", "comments", "trailing_comments", "source_path")}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _asset_paths(grammar: Grammar) -> list[Path]:
    """Files inserted with a literal path (`i("parts/chimney.glb")`): their bytes change renders."""
    found: set[Path] = set()

    def visit(node: Any) -> None:
        if isinstance(node, OpCall) and node.name == "i" and node.args:
            v = node.args[0].value
            if isinstance(v, Str) and node.span is not None and node.span.file:
                found.add((Path(node.span.file).parent / v.value).resolve())
        if hasattr(node, "__dict__"):
            for child in node.__dict__.values():
                if isinstance(child, tuple):
                    for c in child:
                        visit(c)
                elif hasattr(child, "__dict__") and not isinstance(child, (str, bytes)):
                    visit(child)

    for s in grammar.snippets:
        visit(s)
    return sorted(found)


def library_hash(grammar: Grammar) -> str:
    """SHA-256 of what the renders depend on: the snippets and defaults (no comments, spans or
    layout) plus the bytes of inserted asset files. Editing a comment does not invalidate
    trained models; changing a rule, a range or a part mesh does."""
    content = [_strip(s.model_dump(mode="json")) for s in (*grammar.snippets, *grammar.defaults)]
    h = hashlib.sha256(json.dumps(content, sort_keys=True).encode())
    for p in _asset_paths(grammar):
        h.update(p.name.encode())
        try:
            h.update(p.read_bytes())
        except OSError:
            h.update(b"<missing>")
    return h.hexdigest()
