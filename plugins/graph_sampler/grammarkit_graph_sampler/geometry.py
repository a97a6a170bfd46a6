"""Everything the sampler needs from grammarkit's tiling layer, in one place.

Contacts, shape graphs, docking, example loading and rule checks are grammarkit.tiling's
(public API only). The incremental contact update and the part cache are the shared
shape-graph machinery of `grammarkit.tiling` (module `incremental`), re-exported here under
the names the sampler uses; this module adds what is the sampler's own: loading and checking
its examples, and turning its index-based shapes back into assemblies.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from grammarkit.errors import GrammarError
from grammarkit.tiling import (  # noqa: F401 - re-exported for the sampler
    Assembly, ForbiddenContact, Part, PartCache, bounds_of, contacts_involving, full_check,
    moved_mesh, part_key,
)
from grammarkit.tiling import default_tolerance as _default_tolerance
from grammarkit.tiling import dock as _dock
from grammarkit.tiling import edit_violations as violations  # noqa: F401


def as_grammar(grammar):
    """A Grammar from a Grammar, a path or grammar text (imports resolved, checked)."""
    from grammarkit.ir import Grammar

    if isinstance(grammar, Grammar):
        return grammar
    from grammarkit.dsl import load

    if isinstance(grammar, str) and "\n" not in grammar and grammar.endswith(".grammar"):
        grammar = Path(grammar)
    return load(grammar)


def no_examples_error(grammar) -> GrammarError:
    name = grammar.name if grammar is not None else "?"
    return GrammarError(f"grammar {name!r} has no examples: the graph sampler recombines "
                        "example assemblies (add `example NAME = assembly(\"file.glb\")`)",
                        getattr(grammar, "span", None))


def check_example(rule_set, assembly: Assembly, tolerance: float, grammar=None) -> None:
    """Examples must satisfy their own grammar, else every variant would inherit the problem."""
    from grammarkit.errors import DerivationError
    from grammarkit.tiling import validate

    report = validate(rule_set, assembly, tolerance=tolerance, max_violations=5)
    if not report.ok:
        lines = "; ".join(v.format() for v in report.violations)
        raise DerivationError(f"example {assembly.name!r} violates the grammar, so it cannot seed the "
                              f"graph sampler: {lines}", getattr(grammar, "span", None))


def final_problem(rule_set, assembly: Assembly, keys=None, cache: PartCache | None = None) -> str:
    """What `grammarkit validate` (these rules, its default tolerance) rejects in the variant
    first, or "" when it accepts it. `keys` (a `part_key` per part) and `cache`: support
    verdicts of contacts congruent to ones judged before are reused (a pure function of the
    two parts' relative placement and of up)."""
    from grammarkit.tiling import validate

    context = {"support_cache": cache.support, "keys": list(keys)} if cache is not None and keys else None
    report = validate(rule_set, assembly, max_violations=1, constraint_context=context)
    return "" if report.ok else report.violations[0].format()


def load_examples(grammar) -> list[Assembly]:
    from grammarkit.tiling import load_examples as loader

    return list(loader(grammar))


def rules(grammar):
    from grammarkit import tiling

    return tiling.rules_from_grammar(grammar)


def default_contact_tolerance(assembly: Assembly) -> float:
    return float(_default_tolerance(assembly))


def dock(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Kabsch transform taking `src` onto `dst`, or None when the points do not fix a rotation
    (fewer than 3, or collinear: grammarkit.tiling.dock refuses those)."""
    from grammarkit.errors import ShapeError

    try:
        return _dock(src, dst, allow_translation=False)
    except ShapeError:
        return None


def surface_centroid(mesh: trimesh.Trimesh) -> np.ndarray:
    from grammarkit.tiling import surface_centroid as _sc

    return _sc(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces))


def example_edges(assembly: Assembly, tolerance: float) -> list[tuple[str, str]]:
    from grammarkit.tiling import shape_graph

    return list(shape_graph(assembly, tolerance=tolerance).edges())


def shape_to_assembly(shape, protos, name: str | None = None) -> Assembly:
    """The variant as an Assembly: part ids `Type.k`, provenance in `meta`."""
    parts = []
    for node, (p, matrix) in enumerate(zip(shape.protos, shape.transforms)):
        proto = protos[p]
        mesh = moved_mesh(proto.mesh, matrix)  # a new mesh, except for the identity
        parts.append(Part(shape.ids[node], proto.type, mesh.copy() if mesh is proto.mesh else mesh,
                          np.asarray(matrix) @ proto.transform, {"source": proto.source, "node": node}))
    meta = {"graph_sampler": {"key": shape.key, "iteration": shape.iteration,
                              "parents": list(shape.parents), "operation": shape.operation}}
    return Assembly(parts, name=name or shape.key, meta=meta)
