"""The split-grammar engine (CGA-style): derive watertight buildings from `.grammar` files.

    from grammarkit.split import derive
    model = derive("grammars/paris.grammar", seed=3, attrs={"floors": 12})
    model.mesh            # trimesh, one watertight manifold with per-face colours
    model.parts           # terminals with rule, object type, colour, material, scope
    model.tree_dict()     # the derivation tree (rule, scope, seed, source line per shape)

`variations(grammar, n, seed)` yields models with attrs resampled in their ranges, stochastic
choices re-rolled and snippets swapped per the grammar's `variants` tables.
"""
from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, Iterator, Mapping

from ..errors import DerivationError, GrammarError, ShapeError
from ..ir.grammar import Grammar
from .compile import CompiledGrammar, compile_grammar
from .engine import Derivation, Limits
from .model import Model, Part, TreeNode, compose
from .shape import FACE, Shape

__all__ = ["Limits", "Model", "Part", "Shape", "TreeNode", "check_attrs", "compile", "derive", "load_grammar",
           "variations"]

_lock = threading.RLock()
_cache: dict[tuple, tuple[Grammar, CompiledGrammar]] = {}
_CACHE_SIZE = 32
_files: dict[tuple[str, int], Grammar] = {}
_resolved: dict[int, tuple[Grammar, Grammar]] = {}  # id -> (parsed, imports inlined); keeps both alive

DEFAULT_LOT = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))


def load_grammar(source: Any) -> Grammar:
    """A Grammar from an IR object, a path, or grammar text (imports resolved by grammarkit.dsl)."""
    try:
        from ..dsl import load
    except ImportError as exc:  # pragma: no cover - the DSL is part of the package
        raise GrammarError(f"the grammar parser is not available: {exc}") from None
    if isinstance(source, Grammar):
        if not source.imports:
            return source
        # From `grammarkit.parse` (imports kept as written): inline them once per object.
        with _lock:
            hit = _resolved.get(id(source))
        if hit is not None and hit[0] is source:
            return hit[1]
        resolved = load(source)
        with _lock:
            if len(_resolved) >= _CACHE_SIZE:
                _resolved.pop(next(iter(_resolved)))
            _resolved[id(source)] = (source, resolved)
        return resolved
    if isinstance(source, str) and "\n" not in source and source.endswith(".grammar"):
        source = Path(source)
    if isinstance(source, Path):
        # the same unchanged file gives the same Grammar object, so its compilation is reused
        try:
            key = (str(source.resolve()), source.stat().st_mtime_ns)
        except OSError:
            return load(source)  # the loader reports the missing file with its name
        with _lock:
            hit = _files.get(key)
        if hit is None:
            hit = load(source)
            with _lock:
                if len(_files) >= _CACHE_SIZE:
                    _files.pop(next(iter(_files)))
                _files[key] = hit
        return hit
    return load(source)


def _mapping(value: Any, what: str) -> dict:
    """A user-given mapping argument (attrs=, choices=) as a dict with string keys, or a
    GrammarError saying what was expected (never an AttributeError deep inside)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise GrammarError(f"{what}= must be a mapping of names to values, got {type(value).__name__}",
                           None, code="bad-argument")
    for key in value:
        if not isinstance(key, str):
            raise GrammarError(f"{what}= keys must be names (strings), got {key!r}", None,
                               code="bad-argument")
    return dict(value)


def _check_choices(g: Grammar, compiled: CompiledGrammar, choices: Mapping[str, str]) -> None:
    """Every `choices` anchor must be an anchor of the grammar, and its snippet of the anchor's
    object type (Nishida's typing: a Roof anchor takes Roof snippets only)."""
    otype = {s.name: s.object_type for s in g.snippets}
    for anchor, snip in choices.items():
        if not isinstance(snip, str):
            raise GrammarError(f"choices[{anchor!r}] must be a snippet name, got {snip!r}", None,
                               code="bad-argument")
        if anchor not in compiled.bindings:
            known = ", ".join(sorted(compiled.bindings)) or "none"
            raise GrammarError(f"choices: {anchor!r} is not an anchor of this grammar (anchors: {known})",
                               None, code="unknown-anchor")
    base = {u.anchor: u.snippet for u in g.uses}
    types = set(otype.values())
    for anchor, snip in choices.items():
        want = otype.get(base[anchor]) if anchor in base else (anchor if anchor in types else None)
        if want is not None and otype.get(snip) != want:
            raise GrammarError(f"choices: snippet {snip!r} is of object type {otype.get(snip)!r}; "
                               f"anchor {anchor!r} takes {want!r} snippets", None, code="snippet-type")


def compile(grammar: Any, choices: Mapping[str, str] | None = None, start: str | None = None) -> CompiledGrammar:  # noqa: A001
    """Compile (and cache) a grammar for a snippet binding; see grammarkit.split.compile."""
    g = load_grammar(grammar)
    choices = _mapping(choices, "choices")
    if start is not None and not isinstance(start, str):
        raise GrammarError(f"start= must be a rule name, got {start!r}", None, code="bad-argument")
    key = (id(g), tuple(sorted(choices.items(), key=lambda kv: (kv[0], str(kv[1])))), start)
    with _lock:
        hit = _cache.get(key)
        if hit is not None and hit[0] is g:
            return hit[1]
        compiled = compile_grammar(g, {k: v for k, v in choices.items() if isinstance(v, str)}, start)
        if choices:
            _check_choices(g, compiled, choices)
        if len(_cache) >= _CACHE_SIZE:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (g, compiled)
        return compiled


def _seed(seed: Any) -> int:
    import numbers

    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
        raise DerivationError(f"seed= must be an integer, got {seed!r}", None, code="bad-argument")
    return int(seed)


def _lot(lot: Any) -> Any:
    """The axiom footprint from `lot=` (points), or a ShapeError saying what is wrong with it."""
    from ..geometry.footprints import normalize, validate_polygon

    poly = DEFAULT_LOT if lot is None else lot
    try:
        pts = [tuple(p) for p in poly]
        return normalize(validate_polygon(pts))
    except (TypeError, ValueError) as exc:
        msg = str(exc) if isinstance(exc, ValueError) else "expected a sequence of (x, y) points"
        raise ShapeError(f"lot=: {msg}", None, code="bad-lot") from None


def check_attrs(grammar: Any, attrs: Mapping[str, Any] | None) -> dict[str, Any]:
    """Check attr overrides against the grammar (names, types, ranges, enums) without deriving;
    returns every attr's value. Raises GrammarError pointing at the attr's declaration."""
    compiled = compile(grammar)
    with _lock:
        return compiled.set_values(_mapping(attrs, "attrs"), 0)


def derive(grammar: Any, *, seed: int = 0, attrs: Mapping[str, Any] | None = None,
           limits: Limits | None = None, start: str | None = None,
           lot: Any = None, choices: Mapping[str, str] | None = None) -> Model:
    """Derive one model.

    grammar: a Grammar, a path to a .grammar file, or grammar text.
    seed:    run seed; every shape's generator is seeded from it and the shape's derivation path.
    attrs:   attr overrides (`{"height": 30, "Roof.roof_deg": 45}`; an unqualified name sets every
             attr of that name), checked against ranges/enums.
    limits:  `Limits(max_depth, max_shapes, max_repeat, max_triangles)`.
    start:   the axiom rule (default: the grammar's first rule).
    lot:     the axiom shape's footprint polygon (default: a 10 x 10 square face).
    choices: `{anchor: snippet}` bindings overriding the grammar's `use` statements.
    """
    seed = _seed(seed)
    attrs = _mapping(attrs, "attrs")
    if limits is None:
        limits = Limits()
    elif not isinstance(limits, Limits):
        raise DerivationError(f"limits= must be a grammarkit.split.Limits, got {type(limits).__name__}",
                              None, code="bad-argument")
    compiled = compile(grammar, choices, start)
    norm, (x0, y0, x1, y1) = _lot(lot)
    with _lock:  # compiled closures read compiled.values: one derivation at a time per process
        values = compiled.set_values(attrs, seed)
        ctx = Derivation(compiled, seed, limits, compiled.base_dir)
        shape = Shape((x0, y0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
                      (x1 - x0, y1 - y0, 0.0), FACE, None if lot is None else (norm,))
        ctx.start(compiled.axiom, shape)
        ctx.run()
        manifold, mesh = compose(ctx, compiled.axiom.span)
    warnings = [f"{span}: {msg}" if span is not None and span.line else msg for msg, span in compiled.warnings]
    warnings += ctx.warnings
    return Model(compiled.name, seed, values, ctx, manifold, mesh, warnings, dict(compiled.bindings))


def variations(grammar: Any, n: int, *, seed: int = 0, attrs: Mapping[str, Any] | None = None,
               limits: Limits | None = None, start: int = 0) -> Iterator[tuple[Any, Model]]:
    """(Variation, Model) pairs; see grammarkit.split.variation.variations."""
    from .variation import variations as _variations
    return _variations(grammar, n, seed=seed, attrs=attrs, limits=limits, start=start)
