"""Shapes, operations on them, and the geometric embedding (Liu et al. 2015, sections 5.2-5.3).

A `Shape` is an assembly in index form: types, world-space meshes, bounds, centroids, the
shape graph's edges and the cyclic edge order of every node (`ordering.cyclic_orders`).

Embedding an operation (copy S' of the donor into the hole where S was in the host):
- every cut-edge pair gets two *boundary frames*, one on the donor's edge (a, w) and one on
  the host's edge (b, w2): origin at the centre of the intersection of the two parts'
  bounding boxes (at its foot along the up axis by default, see `_frame`), x towards the
  neighbour (horizontal), z up. Each pair gives the rigid
  transform T = F_host F_donor^-1;
- each copied part is moved by the inverse-distance-weighted interpolation of those transforms
  (weights 1 / distance from the part's centre, or from the vertex, to the donor frame's
  origin): per part as one rigid motion (angles about z averaged on the circle, the centre
  moved by the weighted images), or per vertex (blend skinning, non-rigid). Meshes keep their
  faces, so watertight parts stay watertight.
Afterwards the shape graph is updated incrementally (`grammarkit.tiling.contacts_involving`)
and checked against the grammar (`grammarkit.tiling.edit_violations`: pairs, neighbourhoods,
docking placements, and the global constraints support/path/connected), plus the orientation
check of section 5.3. With `repair`, a failing embedding gets a greedy rescaling along z of the
copied parts that stood on the ground in the donor (figure 11 of the paper) and is checked again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import trimesh

from grammarkit.tiling import (
    Assembly, ForbiddenContact, Part, adjacency_from_edges, bounds_of, contacts_involving,
    edit_violations, induced_edges, prepare, shape_graph,
)

from .ordering import UP, cyclic_orders
from .search import Operation, OrderedGraph


@dataclass
class Shape:
    ids: list[str]
    types: list[str]
    meshes: list[trimesh.Trimesh]
    transforms: list[np.ndarray]
    sources: list[str]
    edges: list[tuple[int, int]]
    tolerance: float
    name: str = ""
    lo: np.ndarray = field(default=None)  # type: ignore[assignment]
    hi: np.ndarray = field(default=None)  # type: ignore[assignment]
    centroids: np.ndarray = field(default=None)  # type: ignore[assignment]
    graph: OrderedGraph = field(default=None)  # type: ignore[assignment]
    _counts: dict | None = field(default=None, repr=False)
    # per part, the example part it is a rigid copy of: (example name, part id); the part's
    # mesh is that part's mesh in its own frame moved by `transforms[i]` (PartCache keys)
    origins: list | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.types)

    def type_counts(self) -> dict[str, int]:
        """{type: number of parts} (cached: a shape's parts never change)."""
        if self._counts is None:
            counts: dict[str, int] = {}
            for t in self.types:
                counts[t] = counts.get(t, 0) + 1
            self._counts = counts
        return self._counts

    def finish(self, centroids: np.ndarray | None = None) -> "Shape":
        self.lo, self.hi = bounds_of(self.meshes)
        if centroids is None:
            parts = [Part(str(i), t, m) for i, (t, m) in enumerate(zip(self.types, self.meshes))]
            centroids = prepare(parts).centroid
        self.centroids = np.asarray(centroids, dtype=np.float64).reshape(-1, 3)
        adj = adjacency_from_edges(len(self.types), self.edges)
        self.graph = OrderedGraph(list(self.types), cyclic_orders(self.centroids, adj))
        return self

    @classmethod
    def from_assembly(cls, assembly: Assembly, tolerance: float | None = None) -> "Shape":
        g = shape_graph(assembly, tolerance=tolerance)
        index = {p.id: i for i, p in enumerate(assembly.parts)}
        edges = sorted((min(index[u], index[v]), max(index[u], index[v])) for u, v in g.edges())
        name = assembly.name or "shape"
        shape = cls([p.id for p in assembly.parts], [p.type for p in assembly.parts],
                    [p.mesh for p in assembly.parts],
                    [np.asarray(p.transform, dtype=np.float64) for p in assembly.parts],
                    [str(p.meta.get("source", f"{name}/{p.id}")) for p in assembly.parts],
                    edges, float(g.graph["tolerance"]), name,
                    origins=[(name, p.id) for p in assembly.parts])
        cents = np.array([g.nodes[p.id]["centroid"] for p in assembly.parts]).reshape(-1, 3)
        return shape.finish(cents)

    def to_assembly(self, name: str | None = None, meta: dict | None = None) -> Assembly:
        parts = [Part(self.ids[i], self.types[i], self.meshes[i], self.transforms[i],
                      {"source": self.sources[i]}) for i in range(len(self))]
        return Assembly(parts, name=name or self.name, meta=dict(meta or {}))


ORIGINS = ("foot", "centre")


def _frame(shape: Shape, v: int, x: int, origin_at: str = "foot") -> np.ndarray:
    """Boundary frame of the edge (v, x): origin at the centre of the intersection of the two
    bounding boxes (`origin_at="centre"`, the paper's), or at that centre seen from above but at
    the intersection's foot along the up axis (`"foot"`, the default); x axis towards x's
    centre (horizontal), z up.

    Why the foot: at the centre, a copy whose contact is taller or shorter than the one it
    replaces is lifted or sunk by half the difference (a 5 m gate put where a 4 m wall met a
    tower sinks by 0.5 m), which breaks support unless parts are rescaled (the paper's greedy
    repair); at the foot, parts that stood on one floor in the donor stand on the same floor in
    the host, and stay rigid. Between parts of one type both give the same transform."""
    lo = np.maximum(shape.lo[v], shape.lo[x])
    hi = np.minimum(shape.hi[v], shape.hi[x])
    origin = (lo + hi) / 2
    if origin_at == "foot":
        origin = origin + (min(float(lo @ UP), float(hi @ UP)) - float(origin @ UP)) * UP
    d = shape.centroids[x] - shape.centroids[v]
    d = d - (d @ UP) * UP
    n = float(np.linalg.norm(d))
    ex = d / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
    ey = np.cross(UP, ex)
    F = np.eye(4)
    F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = ex, ey, UP, origin
    return F


def boundary_transforms(donor: Shape, host: Shape, op: Operation,
                        origin_at: str = "foot") -> tuple[list[np.ndarray], np.ndarray]:
    """Per cut-edge pair, the rigid transform F_host F_donor^-1; and the donor frames' origins."""
    mats, origins = [], []
    for a, w, b, w2 in op.pairs:
        Fd, Fh = _frame(donor, a, w, origin_at), _frame(host, b, w2, origin_at)
        mats.append(Fh @ np.linalg.inv(Fd))
        origins.append(Fd[:3, 3])
    return mats, np.array(origins)


def _weights(points: np.ndarray, origins: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(points[:, None, :] - origins[None, :, :], axis=2)
    w = 1.0 / np.maximum(d, 1e-9)
    exact = d < 1e-9
    w = np.where(exact.any(axis=1, keepdims=True), exact.astype(float), w)
    return w / w.sum(axis=1, keepdims=True)


def _blend_rigid(mats: list[np.ndarray], weights: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """One rigid motion: rotation angles about z averaged on the circle, the centre moved to the
    weighted mean of its images (exact when all transforms agree)."""
    angles = np.array([math.atan2(M[1, 0], M[0, 0]) for M in mats])
    theta = math.atan2(float(weights @ np.sin(angles)), float(weights @ np.cos(angles)))
    images = np.array([M[:3, :3] @ centre + M[:3, 3] for M in mats])
    target = weights @ images
    R = np.eye(4)
    c, s = math.cos(theta), math.sin(theta)
    R[:2, :2] = [[c, -s], [s, c]]
    T = np.eye(4)
    T[:3, 3] = target - R[:3, :3] @ centre
    return T @ R


def _orientation_problem(donor: Shape, host: Shape, op: Operation, degrees: float) -> str | None:
    """Section 5.3: the angle between consecutive cut edges must not turn parallel edges into
    perpendicular ones or the reverse."""
    if len(op.pairs) < 2:
        return None
    lim_par = math.cos(math.radians(degrees))
    lim_perp = math.sin(math.radians(degrees))

    def unit(s: Shape, u: int, v: int) -> np.ndarray:
        d = s.centroids[v] - s.centroids[u]
        n = float(np.linalg.norm(d))
        return d / n if n > 0 else d

    pairs = list(op.pairs)
    for (a1, w1, b1, x1), (a2, w2, b2, x2) in zip(pairs, pairs[1:] + pairs[:1]):
        cd = abs(float(unit(donor, a1, w1) @ unit(donor, a2, w2)))
        ch = abs(float(unit(host, b1, x1) @ unit(host, b2, x2)))
        if (cd >= lim_par and ch <= lim_perp) or (cd <= lim_perp and ch >= lim_par):
            return (f"orientation: cut edges {host.ids[b1]}-{host.ids[x1]} and {host.ids[b2]}-"
                    f"{host.ids[x2]} are {'perpendicular' if ch <= lim_perp else 'parallel'}, their "
                    f"donor counterparts {'parallel' if cd >= lim_par else 'perpendicular'}")
    return None


@dataclass
class Embedded:
    shape: Shape | None
    problems: list[str]
    repaired: bool = False


def _renumber(types: Sequence[str]) -> list[str]:
    counts: dict[str, int] = {}
    ids = []
    for t in types:
        ids.append(f"{t}.{counts.get(t, 0)}")
        counts[t] = counts.get(t, 0) + 1
    return ids


def embed(donor: Shape, host: Shape, op: Operation, rules=None, *, embedding: str = "rigid",
          repair: bool = True, orientation_degrees: float = 20.0,
          max_parts: int | None = None, origin_at: str = "foot", cache: dict | None = None) -> Embedded:
    """Apply `op` with geometry: the host without S, plus S' of the donor mapped into the hole.

    `cache` (a dict kept across calls, e.g. per run) holds a `grammarkit.tiling.PartCache`:
    with the rigid embedding every part is a source part at a placement (`part_key(source,
    transform)`), so its contact data, frames and support verdicts are computed once per
    placement instead of once per embedding; only the required sites of copied parts and of
    kept parts that lost a neighbour are checked again."""
    removed = set(op.removed)
    kept = [v for v in range(len(host)) if v not in removed]
    copied = list(op.copied)
    n_new = len(kept) + len(copied)
    if max_parts is not None and n_new > max_parts:
        return Embedded(None, [f"too large: {n_new} parts (max_parts {max_parts})"])
    problem = _orientation_problem(donor, host, op, orientation_degrees)
    if problem:
        return Embedded(None, [problem])
    mats, origins = boundary_transforms(donor, host, op, origin_at)
    cw = _weights(donor.centroids[copied], origins)
    meshes = [host.meshes[v] for v in kept]
    transforms = [host.transforms[v] for v in kept]
    moved_cents = []
    for k, x in enumerate(copied):
        mesh = donor.meshes[x]
        T = _blend_rigid(mats, cw[k], donor.centroids[x])
        if embedding == "rigid" or len(mats) == 1:
            verts = np.asarray(mesh.vertices) @ T[:3, :3].T + T[:3, 3]
        else:  # per-vertex blend skinning of the boundary transforms
            v = np.asarray(mesh.vertices, dtype=np.float64)
            vw = _weights(v, origins)
            stack = np.stack([v @ M[:3, :3].T + M[:3, 3] for M in mats], axis=1)  # (nv, p, 3)
            verts = (vw[:, :, None] * stack).sum(axis=1)
        meshes.append(trimesh.Trimesh(verts, np.asarray(mesh.faces), process=False))
        transforms.append(T @ donor.transforms[x])
        moved_cents.append(T[:3, :3] @ donor.centroids[x] + T[:3, 3])
    types = [host.types[v] for v in kept] + [donor.types[x] for x in copied]
    sources = [host.sources[v] for v in kept] + [donor.sources[x] for x in copied]
    base_edges = induced_edges(host.edges, kept)
    new_idx = list(range(len(kept), n_new))
    keys = pcache = sites_of = origins = None
    if host.origins is not None and donor.origins is not None:
        origins = [host.origins[v] for v in kept] + [donor.origins[x] for x in copied]
    if cache is not None and embedding == "rigid" and origins is not None:
        from grammarkit.tiling import PartCache, part_key

        pcache = cache.setdefault("parts", PartCache())
        ids = cache.setdefault("origins", {})
        keys = [part_key(ids.setdefault(o, len(ids)), M) for o, M in zip(origins, transforms)]
        position = {v: k for k, v in enumerate(kept)}
        lost = {position[u if v in removed else v] for u, v in host.edges
                if (u in removed) != (v in removed)}
        sites_of = sorted(lost | set(new_idx))
    result = _check(rules, types, meshes, base_edges, new_idx, host.tolerance, keys, pcache, sites_of)
    repaired = False
    if result[1] and repair:
        fixed = _repair_ground(donor, host, copied, meshes, len(kept))
        if fixed is not None:
            r2 = _check(rules, types, fixed, base_edges, new_idx, host.tolerance)
            if not r2[1]:
                meshes, result, repaired = fixed, r2, True
    edges, problems = result
    if problems:
        return Embedded(None, problems)
    shape = Shape(_renumber(types), types, meshes, transforms, sources, sorted(edges),
                  host.tolerance, host.name, origins=origins if not repaired else None)
    return Embedded(shape.finish(), [], repaired)


def _check(rules, types, meshes, base_edges, new_idx, tolerance, keys=None, pcache=None,  # noqa: ANN001
           sites_of=None) -> tuple[set, list[str]]:
    lo, hi = bounds_of(meshes)
    try:
        edges = set(base_edges) | contacts_involving(meshes, types, new_idx, tolerance, lo, hi, rules,
                                                     keys=keys, cache=pcache)
    except ForbiddenContact as exc:
        return set(), [str(exc)]
    if rules is None:
        return edges, []
    parts = [Part(str(i), t, m) for i, (t, m) in enumerate(zip(types, meshes))]
    cents = pcache.geometry(parts, keys).centroid if pcache is not None else prepare(parts).centroid
    return edges, edit_violations(rules, types, sorted(edges), meshes, cents, tolerance, new_idx, lo, hi,
                                  keys=keys, cache=pcache, sites_of=sites_of)


def _repair_ground(donor: Shape, host: Shape, copied: list[int], meshes: list, k: int):
    """Greedy rescaling (figure 11): every copied part that stood on the donor's ground is
    stretched or squashed along z, about its top, until it stands on the host's ground again.
    None when nothing would change or a factor leaves [0.5, 2]."""
    g_d = float(donor.lo[:, 2].min())
    g_h = float(host.lo[:, 2].min())
    tol = host.tolerance
    out = list(meshes)
    changed = False
    for j, x in enumerate(copied):
        if donor.lo[x, 2] > g_d + tol:
            continue
        m = out[k + j]
        v = np.asarray(m.vertices, dtype=np.float64)
        bottom, top = float(v[:, 2].min()), float(v[:, 2].max())
        if abs(bottom - g_h) <= tol or top <= g_h:
            continue
        s = (top - g_h) / (top - bottom)
        if not 0.5 <= s <= 2.0:
            return None
        v = v.copy()
        v[:, 2] = top - (top - v[:, 2]) * s
        out[k + j] = trimesh.Trimesh(v, np.asarray(m.faces), process=False)
        changed = True
    return out if changed else None
