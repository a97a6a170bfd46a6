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

from ..errors import GrammarError
from ..ir.grammar import Grammar
from .compile import CompiledGrammar, compile_grammar
from .engine import Derivation, Limits
from .model import Model, Part, TreeNode, compose
from .shape import FACE, Shape

__all__ = ["Limits", "Model", "Part", "Shape", "TreeNode", "compile", "derive", "load_grammar", "variations"]

_lock = threading.RLock()
_cache: dict[tuple, tuple[Grammar, CompiledGrammar]] = {}
_CACHE_SIZE = 32
_files: dict[tuple[str, int], Grammar] = {}

DEFAULT_LOT = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))


def load_grammar(source: Any) -> Grammar:
    """A Grammar from an IR object, a path, or grammar text (imports resolved by grammarkit.dsl)."""
    if isinstance(source, Grammar):
        return source
    try:
        from ..dsl import load
    except ImportError as exc:  # pragma: no cover - the DSL is part of the package
        raise GrammarError(f"the grammar parser is not available: {exc}") from None
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


def compile(grammar: Any, choices: Mapping[str, str] | None = None, start: str | None = None) -> CompiledGrammar:  # noqa: A001
    """Compile (and cache) a grammar for a snippet binding; see grammarkit.split.compile."""
    g = load_grammar(grammar)
    key = (id(g), tuple(sorted((choices or {}).items())), start)
    with _lock:
        hit = _cache.get(key)
        if hit is not None and hit[0] is g:
            return hit[1]
        compiled = compile_grammar(g, choices, start)
        if len(_cache) >= _CACHE_SIZE:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (g, compiled)
        return compiled


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
    compiled = compile(grammar, choices, start)
    limits = limits or Limits()
    poly = DEFAULT_LOT if lot is None else tuple(lot)
    from ..geometry.footprints import normalize, validate_polygon
    norm, (x0, y0, x1, y1) = normalize(validate_polygon(poly))
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
