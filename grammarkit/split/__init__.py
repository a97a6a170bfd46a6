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
import weakref
from pathlib import Path
from typing import Any, Iterator, Mapping

from importlib import import_module
from typing import TYPE_CHECKING

from ..errors import DerivationError, GrammarError, ShapeError
from ..ir.grammar import Grammar
from .compile import CompiledGrammar, compile_grammar
from .shape import FACE, Shape

if TYPE_CHECKING:  # pragma: no cover
    from .engine import Limits
    from .model import Model, Part, TreeNode

# The engine and the model need manifold3d and numpy: imported on first use, so that loading
# the `split-operations` plugin (every `grammarkit check` does) stays light.
_LAZY = {"Limits": "engine", "Derivation": "engine", "Model": "model", "Part": "model", "TreeNode": "model"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'grammarkit.split' has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value

__all__ = ["Limits", "Model", "Part", "Shape", "TreeNode", "as_mapping", "check_attrs", "compile", "derive",
           "load_grammar", "variations"]

_CACHE_SIZE = 32

DEFAULT_LOT = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))


class IdentityCache:
    """A small LRU cache keyed by the *identity* of objects (plus a hashable extra key).

    Grammars compare by value ignoring spans, so a value-keyed cache could hand one grammar's
    compilation (and its error locations) to another; a bare `id()` key could be reused by a
    new object once the old one is gone. Here every entry holds weak references to its key
    objects and is dropped when any of them dies, so a hit is always the very same objects."""

    def __init__(self, size: int = _CACHE_SIZE):
        self.size = size
        self._entries: dict[tuple, tuple[tuple, Any]] = {}
        self._lock = threading.Lock()

    def get(self, objects: tuple, extra: Any = ()) -> Any:
        key = (tuple(id(o) for o in objects), extra)
        entry = self._entries.get(key)
        if entry is None or any(r() is not o for r, o in zip(entry[0], objects)):
            return None
        return entry[1]

    def put(self, objects: tuple, value: Any, extra: Any = ()) -> None:
        key = (tuple(id(o) for o in objects), extra)
        entries = self._entries

        def forget(_ref: Any, _key: tuple = key) -> None:  # runs when a key object dies
            entries.pop(_key, None)
        refs = tuple(weakref.ref(o, forget) for o in objects)
        with self._lock:
            while len(entries) >= self.size:
                try:
                    entries.pop(next(iter(entries)), None)
                except (StopIteration, RuntimeError):  # emptied (or changed) by a callback
                    break
            entries[key] = (refs, value)


_resolved = IdentityCache()  # parsed grammar with imports (and registries) -> imports inlined
_files = IdentityCache()  # registries + (path, mtime) -> the file's loaded grammar
_compiled = IdentityCache()  # (grammar, registries) + (choices, start) -> CompiledGrammar


def _registries(registries: Any) -> Any:
    """The registries in effect: the caller's, or the plugin manager's at this API edge."""
    if registries is not None:
        return registries
    from ..plugins import default_registries

    return default_registries()


def load_grammar(source: Any, registries: Any = None) -> Grammar:
    """A Grammar from an IR object, a path, or grammar text (imports resolved by grammarkit.dsl,
    checked against `registries`)."""
    try:
        from ..dsl import load
    except ImportError as exc:  # pragma: no cover - the DSL is part of the package
        raise GrammarError(f"the grammar parser is not available: {exc}") from None
    registries = _registries(registries)
    if isinstance(source, Grammar):
        if not source.imports:
            return source
        # From `grammarkit.parse` (imports kept as written): inline them once per object.
        hit = _resolved.get((source, registries))
        if hit is None:
            hit = load(source, registries=registries)
            _resolved.put((source, registries), hit)
        return hit
    if isinstance(source, str) and "\n" not in source and source.endswith(".grammar"):
        source = Path(source)
    if isinstance(source, Path):
        # the same unchanged file gives the same Grammar object, so its compilation is reused
        try:
            key = (str(source.resolve()), source.stat().st_mtime_ns)
        except (OSError, ValueError):  # ValueError: a NUL in the path
            return load(source, registries=registries)  # the loader reports the file, located
        hit = _files.get((registries,), key)
        if hit is None:
            hit = load(source, registries=registries)
            _files.put((registries,), hit, key)
        return hit
    return load(source, registries=registries)


def as_mapping(value: Any, what: str) -> dict:
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


def compile(grammar: Any, choices: Mapping[str, str] | None = None, start: str | None = None,  # noqa: A001
            *, registries: Any = None) -> CompiledGrammar:
    """Compile (and cache) a grammar for a snippet binding; see grammarkit.split.compile.

    The cache is keyed by the identity of the grammar and of the registries (never by a bare
    `id()`), so the same objects always get the same, immutable, compiled grammar."""
    registries = _registries(registries)
    g = load_grammar(grammar, registries)
    choices = as_mapping(choices, "choices")
    if start is not None and not isinstance(start, str):
        raise GrammarError(f"start= must be a rule name, got {start!r}", None, code="bad-argument")
    extra = (tuple(sorted(choices.items(), key=lambda kv: (kv[0], str(kv[1])))), start)
    hit = _compiled.get((g, registries), extra)
    if hit is not None:
        return hit
    compiled = compile_grammar(g, registries, {k: v for k, v in choices.items() if isinstance(v, str)},
                               start)
    if choices:
        _check_choices(g, compiled, choices)
    _compiled.put((g, registries), compiled, extra)
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


def check_attrs(grammar: Any, attrs: Mapping[str, Any] | None, *, registries: Any = None) -> dict[str, Any]:
    """Check attr overrides against the grammar (names, types, ranges, enums) without deriving;
    returns every attr's value. Raises GrammarError pointing at the attr's declaration."""
    compiled = compile(grammar, registries=registries)
    return compiled.attr_values(compiled.evaluate_values(as_mapping(attrs, "attrs"), 0))


def derive(grammar: Any, *, seed: int = 0, attrs: Mapping[str, Any] | None = None,
           limits: Limits | None = None, start: str | None = None,
           lot: Any = None, choices: Mapping[str, str] | None = None, registries: Any = None,
           surfaces: str = "solid") -> Model:
    """Derive one model.

    grammar: a Grammar, a path to a .grammar file, or grammar text.
    seed:    run seed; every shape's generator is seeded from it and the shape's derivation path.
    attrs:   attr overrides (`{"height": 30, "Roof.roof_deg": 45}`; an unqualified name sets every
             attr of that name), checked against ranges/enums.
    limits:  `Limits(max_depth, max_shapes, max_repeat, max_triangles)`.
    start:   the axiom rule (default: the grammar's first rule).
    lot:     the axiom shape's footprint polygon (default: a 10 x 10 square face).
    choices: `{anchor: snippet}` bindings overriding the grammar's `use` statements.
    registries: the operations/functions/fits to use (a grammarkit.registry.Registries);
             default: the installed plugins'.
    surfaces: "solid" (default): one watertight solid per connected mass; the faces comp(f)
             hands out are views of the volume they bound, open meshes and faces off every
             solid are closed with a 1 cm thickness. "cga": CityEngine's open faces (a
             surface layer beside the solid). docs/operations.md, "Watertight output".

    Re-entrant: any number of derivations (of one grammar or several) may run at once in
    threads; each keeps its values, seed and limits to itself.
    """
    from ..gcpause import paused_gc
    from .engine import Derivation, Limits
    from .model import Model, compose

    seed = _seed(seed)
    attrs = as_mapping(attrs, "attrs")
    if limits is None:
        limits = Limits()
    elif not isinstance(limits, Limits):
        raise DerivationError(f"limits= must be a grammarkit.split.Limits, got {type(limits).__name__}",
                              None, code="bad-argument")
    registries = _registries(registries)
    compiled = compile(grammar, choices, start, registries=registries)
    norm, (x0, y0, x1, y1) = _lot(lot)
    values = compiled.evaluate_values(attrs, seed)
    ctx = Derivation(compiled, seed, limits, values, registries, compiled.base_dir, surfaces)
    shape = Shape((x0, y0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
                  (x1 - x0, y1 - y0, 0.0), FACE, None if lot is None else (norm,))
    ctx.start(compiled.axiom, shape)
    # a derivation allocates many small objects (shapes, scopes, mesh pieces) and no cycles
    # worth collecting meanwhile (candler.cga: 194 -> 167 ms, grammarkit/gcpause.py)
    with paused_gc():
        ctx.run()
        manifold, mesh = compose(ctx, compiled.axiom.span)
    warnings = [f"{span}: {msg}" if span is not None and span.line else msg for msg, span in compiled.warnings]
    warnings += ctx.warnings
    return Model(compiled.name, seed, compiled.attr_values(values), ctx, manifold, mesh, warnings,
                 dict(compiled.bindings))


def variations(grammar: Any, n: int, *, seed: int = 0, attrs: Mapping[str, Any] | None = None,
               limits: Limits | None = None, start: int = 0, registries: Any = None,
               surfaces: str = "solid") -> Iterator[tuple[Any, Model]]:
    """Yield `n` (Variation, Model) pairs: variations start, start+1, ... (each depends only on
    `seed` and its index, so workers can derive disjoint index ranges). What varies and how it
    is drawn: grammarkit.split.variation. `surfaces` as for `derive`."""
    return _variations(grammar, n, seed, attrs, limits, start, _registries(registries), surfaces)


def _variations(grammar: Any, n: int, seed: int, attrs: Mapping[str, Any] | None, limits: Limits | None,
                start: int, registries: Any, surfaces: str = "solid") -> Iterator[tuple[Any, Model]]:
    import random

    from .variation import Variation, sample_attrs, snippet_weights

    for what, v, lo in (("n", n, 0), ("start", start, 0), ("seed", seed, None)):
        if isinstance(v, bool) or not isinstance(v, int) or (lo is not None and v < lo):
            raise DerivationError(f"variations(): {what}= must be an integer"
                                  + (f" >= {lo}" if lo is not None else "") + f", got {v!r}",
                                  None, code="bad-argument")
    g = load_grammar(grammar, registries)
    base = compile(g, registries=registries)
    tables = snippet_weights(g, registries.functions, base.default_values())
    snippets = {s.name: s for s in g.snippets}
    fixed = as_mapping(attrs, "attrs")
    for i in range(start, start + n):
        rng = random.Random(hash((seed, i)) & ((1 << 64) - 1))
        choices: dict[str, str] = {}
        for anchor, snip in sorted(base.bindings.items()):
            otype = snippets[snip].object_type if snip in snippets else None
            table = tables.get(otype or "")
            if table:
                names = [s for s, _ in table]
                choices[anchor] = rng.choices(names, weights=[w for _, w in table])[0]
        compiled = compile(g, choices or None, registries=registries)
        sampled = sample_attrs(compiled, rng, fixed)
        run_seed = rng.getrandbits(32)
        model = derive(g, seed=run_seed, attrs=sampled, limits=limits, choices=choices or None,
                       registries=registries, surfaces=surfaces)
        yield Variation(i, run_seed, model.attrs, dict(compiled.bindings)), model
