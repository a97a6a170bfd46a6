"""Incremental contacts and rule checks for back ends that edit shapes part by part.

A back end that replaces a piece of a shape (the graph sampler, the substructure search) knows
which parts moved: the others keep their contacts. The helpers here measure only what changed,
with the same narrow phase (`grammarkit.tiling.contacts.contacts`) that `shape_graph` uses, so
the result equals a full recompute at the same tolerance.

Shapes are index-based: a list of world-space meshes, a parallel list of part types, and
edges as (i, j) index pairs with i < j.

- `moved_mesh(mesh, matrix)`, `bounds_of(meshes)`: cheap geometry helpers (no trimesh caches).
- `PartCache` and `part_key`: per-part contact data (bounds, centroid, box flag, manifold3d
  solid) shared across calls, keyed by the part's geometry (a source part and a placement).
- `contacts_involving(...)`: the contacts with at least one endpoint among given parts, with an
  optional early `ForbiddenContact` when a touching type pair is one no dock allows.
- `edit_violations(...)`: the rules a partial edit breaks: the whole graph's type pairs,
  neighbourhoods and global constraints, and docking placements of the edited contacts only.
- `full_check(...)`: the non-incremental reference (whole shape graph, full validation).
- `graph_of(...)`: a networkx graph with the attributes `shape_graph` gives, from index data.
"""
from __future__ import annotations

from typing import Any, Iterable, Sequence

import networkx as nx
import numpy as np
import trimesh

from .assembly import Assembly, Part
from .contacts import PartGeometry, PoseKeys, contacts, prepare

__all__ = [
    "ForbiddenContact", "PartCache", "bounds_of", "contacts_involving", "full_check", "graph_of",
    "edit_violations", "moved_mesh", "part_key",
]


def moved_mesh(mesh: trimesh.Trimesh, matrix: np.ndarray) -> trimesh.Trimesh:
    """`mesh` moved by the 4x4 `matrix` (the same object for the identity; faces shared)."""
    if np.array_equal(matrix, np.eye(4)):
        return mesh
    verts = np.asarray(mesh.vertices, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    return trimesh.Trimesh(vertices=verts, faces=np.asarray(mesh.faces), process=False)


def bounds_of(meshes: Sequence[trimesh.Trimesh]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) minima and maxima of the meshes' vertices (no trimesh cache lookups: hot path)."""
    lo = np.array([np.asarray(m.vertices).min(axis=0) for m in meshes]).reshape(-1, 3)
    hi = np.array([np.asarray(m.vertices).max(axis=0) for m in meshes]).reshape(-1, 3)
    return lo, hi


def _parts(meshes: Sequence[trimesh.Trimesh], types: Sequence[str], idx: Iterable[int]) -> list[Part]:
    return [Part(str(k), types[k], meshes[k]) for k in idx]


class PartCache:
    """Per-part contact data (bounds, centroid, box flag, manifold3d solid) keyed by the part's
    geometry, e.g. `part_key(source index, placement matrix)`.

    When every part of every shape is a source part moved rigidly, the same placed part recurs
    across edits, and `contacts` would rebuild its data (and its solid, the costly part) on
    every call. Values are those `prepare` and the lazy solid builder give for that mesh alone
    (per-part results do not depend on the other parts), so contacts are unchanged. Bounded:
    cleared when it would hold more than `limit` parts.

    With `part_key` keys, what depends on two parts' relative placement only is also kept by
    that placement (`PoseMemo`): the surface gap of a pair (`gaps`), the support verdict of a
    contact (`support`, which also depends on how the first part stands relative to up) and
    each source part's Kalojanov frame (`frames`: a rigid move moves the frame with it). So a
    pair of sources docked the same way in another variant, at another place, is not measured
    again.
    """

    def __init__(self, limit: int = 4000, memo_limit: int = 200_000):
        self.limit = limit
        self.rows: dict = {}  # key -> (lo, hi, centroid, boxy)
        self.solids: dict = {}  # key -> manifold3d.Manifold or None (not a closed manifold)
        self.frames = FrameMemo()  # key -> the part's Kalojanov frame (4x4, world)
        self.memo_limit = memo_limit
        self._gaps: dict[float, dict] = {}  # tolerance -> relative pose -> surface gap
        self._support: PoseMemo | None = None  # support verdicts by relative pose

    @property
    def support(self) -> "PoseMemo":
        """Support verdicts by relative pose (support.carry_directions' `cache`). A verdict does
        not depend on the contact tolerance (support.py), so one memo serves every tolerance;
        its rounding step is set by the first `support_for` call (default: 1e-6 x 10)."""
        if self._support is None:
            self._support = PoseMemo(1e-5, with_up=True)
        if len(self._support) > self.memo_limit:
            self._support.clear()
        return self._support

    def support_for(self, tolerance: float) -> "PoseMemo":
        if self._support is None:
            self._support = PoseMemo(tolerance, with_up=True)
        return self.support

    def gaps_for(self, tolerance: float) -> dict:
        memo = self._gaps.get(float(tolerance))
        if memo is None or len(memo) > self.memo_limit:
            memo = self._gaps[float(tolerance)] = {}
        return memo

    def geometry(self, parts: Sequence[Part], keys: Sequence) -> PartGeometry:
        """A PartGeometry of `parts` (keys[k] identifies parts[k]), with known solids seeded."""
        missing = [k for k, key in enumerate(keys) if key not in self.rows]
        if missing:
            if len(self.rows) + len(missing) > self.limit:
                self.rows.clear()
                self.solids.clear()
                missing = [k for k, key in enumerate(keys) if key not in self.rows]
            g = prepare([parts[k] for k in missing])
            for j, k in enumerate(missing):
                self.rows[keys[k]] = (g.lo[j], g.hi[j], g.centroid[j], bool(g.boxy[j]))
        rows = [self.rows[key] for key in keys]
        geom = PartGeometry(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                            np.array([r[2] for r in rows]), np.array([r[3] for r in rows], dtype=bool))
        geom.seed_solids({k: self.solids[key] for k, key in enumerate(keys) if key in self.solids})
        return geom

    def harvest(self, geom: PartGeometry, keys: Sequence) -> None:
        """Keep the solids `contacts` built into `geom` (local index k is `keys[k]`)."""
        for k, solid in geom.known_solids().items():
            self.solids.setdefault(keys[k], solid)


def _placement(key: tuple) -> tuple[int, np.ndarray]:
    """(source, 4x4 placement) of a `part_key`."""
    return key[0], np.frombuffer(key[1], dtype=np.float64).reshape(4, 4)


class PoseMemo:
    """A dict-like memo over pairs of `part_key`s that keys by the pair's *relative* placement:
    (source a, source b, b's pose in a's frame), plus a's rotation with `with_up` (for verdicts
    that depend on gravity). Rotations are rounded to 1e-6, translations to a tenth of the
    tolerance (as `contacts.PoseKeys`): congruent pairs share one entry."""

    def __init__(self, tolerance: float, *, with_up: bool = False):
        self.q = max(float(tolerance) / 10.0, 1e-12)
        self.with_up = with_up
        self._data: dict = {}

    def canonical(self, pair: tuple) -> tuple:
        (sa, Ma), (sb, Mb) = _placement(pair[0]), _placement(pair[1])
        Ra = Ma[:3, :3]
        rel_R = Ra.T @ Mb[:3, :3]  # placements are rigid: inv(Ma) = [Ra^T, -Ra^T t]
        rel_t = Ra.T @ (Mb[:3, 3] - Ma[:3, 3])
        key = (sa, sb, (np.round(rel_R, 6) + 0.0).tobytes(), np.round(rel_t / self.q).astype(np.int64).tobytes())
        if self.with_up:
            key += ((np.round(Ra, 6) + 0.0).tobytes(),)
        return key

    def __contains__(self, pair: tuple) -> bool:
        return self.canonical(pair) in self._data

    def __getitem__(self, pair: tuple):  # noqa: ANN204
        return self._data[self.canonical(pair)]

    def __setitem__(self, pair: tuple, value) -> None:  # noqa: ANN001
        self._data[self.canonical(pair)] = value

    def __len__(self) -> int:
        return len(self._data)

    def clear(self) -> None:
        self._data.clear()


class FrameMemo:
    """Kalojanov frames of placed parts by `part_key`, kept per source part: the frame of a
    rigidly moved mesh is the moved frame (`frames.local_frames` is equivariant: it picks
    vertices by distances), so one frame per source serves every placement of it."""

    def __init__(self) -> None:
        self._base: dict[int, np.ndarray] = {}  # source -> frame of the unmoved source mesh

    def get(self, key, default=None):  # noqa: ANN001, ANN201
        base = self._base.get(key[0]) if isinstance(key, tuple) else None
        if base is None:
            return default
        return _placement(key)[1] @ base

    def __setitem__(self, key, frame: np.ndarray) -> None:  # noqa: ANN001
        source, M = _placement(key)
        if source not in self._base:
            R, t = M[:3, :3], M[:3, 3]
            inv = np.eye(4)
            inv[:3, :3], inv[:3, 3] = R.T, -R.T @ t
            self._base[source] = inv @ frame

    def __len__(self) -> int:
        return len(self._base)

    def clear(self) -> None:
        self._base.clear()


def part_key(source: int, matrix: np.ndarray) -> tuple:
    """A `PartCache` key: a source part index and its exact placement matrix (rigid: a rotation
    and a translation applied to the source part's mesh)."""
    return (int(source), np.ascontiguousarray(matrix, dtype=np.float64).tobytes())


class ForbiddenContact(Exception):
    """An edited part touches a part whose type it may not touch: the shape is invalid."""


def contacts_involving(meshes: Sequence[trimesh.Trimesh], types: Sequence[str], new: Iterable[int],
                       tolerance: float, lo: np.ndarray, hi: np.ndarray,
                       rule_set=None, keys: Sequence | None = None,
                       cache: PartCache | None = None) -> set[tuple[int, int]]:
    """Contacts (i, j), i < j, with at least one endpoint in `new`; `lo`/`hi`: bounds_of(meshes).

    With `cache` and `keys` (a `part_key` per mesh), per-part data comes from the cache.

    With `rule_set` (a `Rules`), candidate pairs of types no dock allows are measured first, and
    the first such contact raises `ForbiddenContact` (validation would report exactly that
    pair, so the verdict is the same; the remaining pairs are not measured).
    """
    new = np.asarray(sorted(new), dtype=np.int64)
    if len(new) == 0:
        return set()
    # broad phase: boxes of the edited parts against all boxes, grown by the tolerance
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
            found = contacts(parts, tolerance, geom=geom, pairs=lp,
                             poses=PoseKeys.of_placements(sub_keys, tolerance),
                             measured=cache.gaps_for(tolerance))
            cache.harvest(geom, sub_keys)
        else:
            found = contacts(parts, tolerance, pairs=lp)
        if found and len(groups) == 2 and g == 0:
            c = found[0]
            x, y = int(subset[c.a]), int(subset[c.b])
            raise ForbiddenContact(f"part {x} ({types[x]}) touches {y} ({types[y]}), but no dock "
                                   f"allows {types[x]} -- {types[y]}")
        out |= {(int(subset[c.a]), int(subset[c.b])) for c in found}
    return out


def full_check(rule_set, meshes: Sequence[trimesh.Trimesh], types: Sequence[str],
               tolerance: float) -> tuple[set[tuple[int, int]], list[str]]:
    """The non-incremental path (a reference and benchmark baseline): `shape_graph` of the whole
    shape, then the full `validate` on it (every contact's docking placement checked).
    Returns (edges, problems as text)."""
    from .graph import shape_graph
    from .validate import validate

    assembly = Assembly(_parts(meshes, types, range(len(meshes))), name="variant")
    g = shape_graph(assembly, tolerance=tolerance)
    edges = {(min(int(u), int(v)), max(int(u), int(v))) for u, v in g.edges()}
    report = validate(rule_set, assembly, graph=g, max_violations=1)
    return edges, [v.format() for v in report.violations]


def graph_of(types: Sequence[str], edges, centroids, tolerance: float, lo: np.ndarray,
             hi: np.ndarray, boxy: Sequence[bool] | None = None) -> nx.Graph:
    """A graph with the node/graph attributes `shape_graph` gives (ids = node indices as text).
    `boxy` (per part: its mesh is exactly its axis-aligned box) sets the `box` attribute."""
    g = nx.Graph(tolerance=float(tolerance))
    for i, t in enumerate(types):
        g.add_node(str(i), type=t, index=i, centroid=centroids[i], lo=lo[i], hi=hi[i],
                   box=bool(boxy[i]) if boxy is not None else False)
    g.add_edges_from((str(u), str(v)) for u, v in edges)
    return g


def edit_violations(rule_set, types: Sequence[str], edges, meshes, centroids, tolerance: float,
                    new: Iterable[int], lo: np.ndarray | None = None,
                    hi: np.ndarray | None = None, max_violations: int = 1, *,
                    keys: Sequence | None = None, cache: PartCache | None = None,
                    registries: Any = None, sites_of: Iterable[int] | None = None) -> list[str]:
    """Rules an edited shape breaks, by `grammarkit.tiling.validate`'s checks on its graph `edges`.

    With `new` (the edited nodes), the checks that depend on one part or one contact only run
    where something changed: orientation on the edited parts, docking placements on the
    contacts that involve an edited part (a placement depends on the two parts alone, and the
    other contacts are unchanged). Type pairs, neighbourhoods, required sites and global
    constraints (support, counts, paths, ...) are checked on the whole graph. With `keys` (a
    `part_key` per mesh) and `cache`, part frames and support verdicts of parts that recur are
    reused. `registries` gives the global constraints (default: as `validate`). `sites_of`:
    the parts whose required sites can have changed (default: all; an edit changes those of
    the edited parts and of the kept parts that lost a neighbour). Returns the problems as
    text (empty: valid)."""
    from dataclasses import replace

    from .validate import (
        _dock_violations, _Full, _Shape, _type_violations, orientation_violations,
        required_site_violations, rigid_violations, validate,
    )

    parts = _parts(meshes, types, range(len(meshes)))
    assembly = Assembly(parts, name="variant")
    if lo is None or hi is None:
        lo, hi = bounds_of(meshes)
    if cache is not None and keys is not None:
        geom = cache.geometry(parts, keys)
        boxy = geom.boxy
    else:
        boxy = prepare(parts).boxy
    g = graph_of(types, edges, centroids, tolerance, lo, hi, boxy)
    shape = _Shape(assembly, g)
    if cache is not None and keys is not None:
        shape.frame_keys, shape.frame_cache = list(keys), cache.frames
    out: list[str] = []

    def add(v) -> None:  # noqa: ANN001
        out.append(v.format())
        if len(out) >= max_violations:
            raise _Full

    new_idx = np.array(sorted({int(i) for i in new}), dtype=np.int64)
    try:
        _type_violations(rule_set, shape, add)
        for v in orientation_violations(rule_set, shape, new_idx):
            add(v)
        for v in rigid_violations(rule_set, shape, new_idx):
            add(v)
        site_idx = None if sites_of is None else np.array(sorted({int(i) for i in sites_of}), dtype=np.int64)
        for v in required_site_violations(rule_set, shape, idx=site_idx):
            add(v)
        # docking placements before the global constraints: they are local to the edited
        # contacts and reject most broken edits for less (support and holes read the whole shape)
        if (getattr(rule_set, "configs", None) or getattr(rule_set, "docks", None)) and len(shape.edges):
            touched = np.flatnonzero(np.isin(shape.edges, new_idx).any(axis=1))
            if len(touched):
                for v in _dock_violations(rule_set, shape, touched):
                    add(v)
        if getattr(rule_set, "constraints", ()):
            extra = {}
            if cache is not None and keys is not None:
                extra = {"support_cache": cache.support_for(tolerance), "keys": list(keys)}
            # the global constraints through `validate` (which owns the registries' default),
            # with every other rule switched off: they were checked above (the sites stay, not
            # required: `filled` needs them)
            sites = {t: tuple(replace(x, required=False) for x in sts) for t, sts in rule_set.sites.items()}
            only = replace(rule_set, types=frozenset(), neighbor_multisets={}, neighbor_counts={},
                           pairs=None, sites=sites, configs={}, docks={})
            report = validate(only, assembly, graph=g, docks=False, orientation=False, rigid=False,
                              max_violations=max_violations, registries=registries,
                              constraint_context=extra)
            for v in report.violations:
                add(v)
    except _Full:
        pass
    return out
