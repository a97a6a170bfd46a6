"""Everything the sampler needs from grammarkit's tiling layer, in one place.

Contacts, shape graphs, docking, example loading and rule checks are grammarkit.tiling's
(public API only); this module adapts them to the sampler's index-based shapes and adds the
incremental contact update: after a replacement only pairs involving an inserted part are
measured, with the same narrow phase (`grammarkit.tiling.contacts.contacts`) the full
`shape_graph` uses, so the result equals a full recompute at the same tolerance.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Iterable, Sequence

import networkx as nx
import numpy as np
import trimesh

from grammarkit.errors import GrammarError
from grammarkit.tiling import Assembly, Part
from grammarkit.tiling import PartGeometry as _PartGeometry
from grammarkit.tiling import contacts as _contacts_of
from grammarkit.tiling import default_tolerance as _default_tolerance
from grammarkit.tiling import dock as _dock
from grammarkit.tiling import prepare as _prepare


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


def moved_mesh(mesh: trimesh.Trimesh, matrix: np.ndarray) -> trimesh.Trimesh:
    if np.array_equal(matrix, np.eye(4)):
        return mesh
    verts = np.asarray(mesh.vertices, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    return trimesh.Trimesh(vertices=verts, faces=np.asarray(mesh.faces), process=False)


def surface_centroid(mesh: trimesh.Trimesh) -> np.ndarray:
    from grammarkit.tiling import surface_centroid as _sc

    return _sc(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces))


def example_edges(assembly: Assembly, tolerance: float) -> list[tuple[str, str]]:
    from grammarkit.tiling import shape_graph

    return list(shape_graph(assembly, tolerance=tolerance).edges())


def _parts(meshes: Sequence[trimesh.Trimesh], types: Sequence[str], idx: Iterable[int]) -> list[Part]:
    return [Part(str(k), types[k], meshes[k]) for k in idx]


def bounds_of(meshes: Sequence[trimesh.Trimesh]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) minima and maxima of the meshes' vertices (no trimesh cache lookups: hot path)."""
    lo = np.array([np.asarray(m.vertices).min(axis=0) for m in meshes])
    hi = np.array([np.asarray(m.vertices).max(axis=0) for m in meshes])
    return lo, hi


class PartCache:
    """Per-part contact data (bounds, centroid, box flag, manifold3d solid) keyed by the part's
    geometry: (proto index, placement matrix bytes). Every part of every shape is a proto moved
    rigidly, and a variant copies its parents' matrices, so the same placed part recurs across
    attempts; `grammarkit.tiling.contacts` would rebuild its data (and its solid, the costly
    part) on every call. Values are those `contacts.prepare` and its lazy solid builder give for
    that mesh alone (per-part results do not depend on the other parts), so contacts are
    unchanged. Bounded: cleared when it holds `limit` parts.
    """

    def __init__(self, limit: int = 4000):
        self.limit = limit
        self.rows: dict = {}  # key -> (lo, hi, centroid, boxy)
        self.solids: dict = {}  # key -> manifold3d.Manifold or None (not a closed manifold)

    def geometry(self, parts: Sequence[Part], keys: Sequence) -> "_PartGeometry":
        missing = [k for k, key in enumerate(keys) if key not in self.rows]
        if missing:
            if len(self.rows) + len(missing) > self.limit:
                self.rows.clear()
                self.solids.clear()
                missing = [k for k, key in enumerate(keys) if key not in self.rows]
            g = _prepare([parts[k] for k in missing])
            for j, k in enumerate(missing):
                self.rows[keys[k]] = (g.lo[j], g.hi[j], g.centroid[j], bool(g.boxy[j]))
        rows = [self.rows[key] for key in keys]
        geom = _PartGeometry(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                             np.array([r[2] for r in rows]), np.array([r[3] for r in rows], dtype=bool))
        # contacts() builds solids lazily into this dict by local index: pre-fill the known ones
        geom._manifolds.update({k: self.solids[key] for k, key in enumerate(keys) if key in self.solids})
        return geom

    def harvest(self, geom: "_PartGeometry", keys: Sequence) -> None:
        for k, solid in geom._manifolds.items():
            self.solids.setdefault(keys[k], solid)


def part_key(proto: int, matrix: np.ndarray) -> tuple:
    return (int(proto), np.ascontiguousarray(matrix, dtype=np.float64).tobytes())


class ForbiddenContact(Exception):
    """An inserted part touches a part whose type it may not touch: the variant is invalid."""


def contacts_involving(meshes: Sequence[trimesh.Trimesh], types: Sequence[str], new: Iterable[int],
                       tolerance: float, lo: np.ndarray, hi: np.ndarray,
                       rule_set=None, keys: Sequence | None = None,
                       cache: PartCache | None = None) -> set[tuple[int, int]]:
    """Contacts (i, j), i < j, with at least one endpoint in `new`; `lo`/`hi`: bounds_of(meshes).

    With `cache` and `keys` (`part_key` of each mesh), per-part data comes from the cache.

    With `rule_set`, candidate pairs of types no dock allows are measured first, and the first
    such contact raises `ForbiddenContact` (validation would report exactly that pair, so the
    verdict is the same; the remaining pairs are not measured).
    """
    new = np.asarray(sorted(new), dtype=np.int64)
    if len(new) == 0:
        return set()
    # broad phase: boxes of the inserted parts against all boxes, grown by the tolerance
    sep = np.maximum(lo[new][:, None, :] - hi[None, :, :], lo[None, :, :] - hi[new][:, None, :])
    near = sep.max(axis=2) <= tolerance
    ii, jj = np.nonzero(near)
    a, b = new[ii], jj
    keep = a != b
    a, b = a[keep], b[keep]
    pairs = np.unique(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1), axis=0)
    if len(pairs) == 0:
        return set()
    groups = [pairs]
    if rule_set is not None and getattr(rule_set, "pairs", None) is not None:
        bad = np.array([not rule_set.allows_pair(types[x], types[y]) for x, y in pairs.tolist()])
        groups = [pairs[bad], pairs[~bad]]
    out: set[tuple[int, int]] = set()
    for g, group in enumerate(groups):
        if len(group) == 0:
            continue
        subset = np.unique(group)
        local = {int(x): k for k, x in enumerate(subset)}
        lp = np.array([[local[x], local[y]] for x, y in group.tolist()], dtype=np.int64)
        parts = _parts(meshes, types, subset)
        if cache is not None and keys is not None:
            sub_keys = [keys[int(x)] for x in subset]
            geom = cache.geometry(parts, sub_keys)
            found = _contacts_of(parts, tolerance, geom=geom, pairs=lp)
            cache.harvest(geom, sub_keys)
        else:
            found = _contacts_of(parts, tolerance, pairs=lp)
        if found and len(groups) == 2 and g == 0:
            c = found[0]
            x, y = int(subset[c.a]), int(subset[c.b])
            raise ForbiddenContact(f"part {x} ({types[x]}) touches {y} ({types[y]}), but no dock "
                                   f"allows {types[x]} -- {types[y]}")
        out |= {(int(subset[c.a]), int(subset[c.b])) for c in found}
    return out


def full_check(rule_set, meshes: Sequence[trimesh.Trimesh], types: Sequence[str],
               tolerance: float) -> tuple[set[tuple[int, int]], list[str]]:
    """The non-incremental path (benchmark baseline): `shape_graph` of the whole variant, then
    the full `validate` on it (every contact's docking placement checked). -> (edges, problems)"""
    from grammarkit.tiling import shape_graph, validate

    assembly = Assembly(_parts(meshes, types, range(len(meshes))), name="variant")
    g = shape_graph(assembly, tolerance=tolerance)
    edges = {(min(int(u), int(v)), max(int(u), int(v))) for u, v in g.edges()}
    report = validate(rule_set, assembly, graph=g, max_violations=1)
    return edges, [v.format() for v in report.violations]


def shape_graph_of(types: Sequence[str], edges, centroids, tolerance: float, lo: np.ndarray,
                   hi: np.ndarray) -> nx.Graph:
    """A graph with the node/graph attributes `shape_graph` gives (ids = node indices as text)."""
    g = nx.Graph(tolerance=float(tolerance))
    for i, t in enumerate(types):
        g.add_node(str(i), type=t, index=i, centroid=centroids[i], lo=lo[i], hi=hi[i])
    g.add_edges_from((str(u), str(v)) for u, v in edges)
    return g


def violations(rule_set, types: Sequence[str], edges, meshes, centroids, tolerance: float,
               new: Iterable[int], lo: np.ndarray | None = None,
               hi: np.ndarray | None = None) -> list[str]:
    """Rules the variant breaks, by `grammarkit.tiling.validate` on its recomputed graph.

    With `new` (the inserted nodes), the docking-placement check runs on the contacts that
    involve an inserted part only: a placement depends on the two parts alone, and the other
    contacts are the recipient's, unchanged. Type pairs, neighbourhoods and global constraints
    are checked on the whole graph.
    """
    from grammarkit.tiling import validate

    assembly = Assembly(_parts(meshes, types, range(len(meshes))), name="variant")
    if lo is None or hi is None:
        lo, hi = bounds_of(meshes)
    g = shape_graph_of(types, edges, centroids, tolerance, lo, hi)
    report = validate(rule_set, assembly, graph=g, docks=False, max_violations=1)
    if not report.ok:
        return [v.format() for v in report.violations]
    if getattr(rule_set, "docks", None):
        new_ids = {str(i) for i in new}
        touched = [(u, v) for u, v in g.edges() if u in new_ids or v in new_ids]
        if touched:
            only_docks = replace(rule_set, neighbor_multisets={}, neighbor_counts={}, constraints=())
            report = validate(only_docks, assembly, graph=g.edge_subgraph(touched), docks=True,
                              max_violations=1)
            return [v.format() for v in report.violations]
    return []


def shape_to_assembly(shape, protos, name: str | None = None) -> Assembly:
    """The variant as an Assembly: part ids `Type.k`, provenance in `meta`."""
    parts = []
    for node, (p, matrix) in enumerate(zip(shape.protos, shape.transforms)):
        proto = protos[p]
        parts.append(Part(shape.ids[node], proto.type, moved_mesh(proto.mesh, matrix).copy(),
                          np.asarray(matrix) @ proto.transform, {"source": proto.source, "node": node}))
    meta = {"graph_sampler": {"key": shape.key, "iteration": shape.iteration,
                              "parents": list(shape.parents), "operation": shape.operation}}
    return Assembly(parts, name=name or shape.key, meta=meta)
