"""Coincident vertices in the final mesh: finding them fast, and pulling them apart.

Where solids of a building touch exactly along an edge or at a point (a tower's bottom window
cut meeting the podium top, two recesses sharing a corner), manifold3d's symbolic perturbation
keeps the union a valid manifold by giving each of the touching surface sheets its own copy of
the shared vertices. In memory the mesh is fine; but the copies sit at the same float32
position, and every reader that welds vertices by position (trimesh's default load, Blender,
`grammarkit.geometry.meshio.load_mesh`) merges them into one vertex with four or more faces
around an edge: not watertight any more.

`coincident_groups` finds such copies (a hash of the quantised positions, two grids offset by
half a cell so that neighbours across a cell border are found too; ~0.1 ms for 2,000 vertices,
so the common case costs next to nothing). `separate` then realises geometrically what the
topology already says: each copy is moved by a fraction of a millimetre into its own fan of
triangles (towards the centroid of its incident triangles), so the sheets no longer share a
position. Connectivity is untouched, so the result is still the same single manifold; the
move is deterministic (a function of the mesh only) and far below anything visible.
"""
from __future__ import annotations

from typing import Any

import manifold3d
import numpy as np

__all__ = ["SEPARATION", "coincident_groups", "coincident_count", "components", "separate", "separate_mesh"]

# How far (model units: metres) a copy of a pinched vertex is moved into its own fan: 0.1 mm,
# far below anything visible yet ~100 float32 ulps at 100 m, so readers never weld it back.
SEPARATION = 1e-4

_K1 = np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15 as a signed int64 (golden ratio)
_K2 = np.int64(0x632BE59BD9B4E019)
_KEY = np.array([_K1, _K2, 1], dtype=np.int64)


def _cell(v: np.ndarray) -> float:
    """Quantum of the position grid: 1 um, or 2e-9 of the model's extent if larger. Readers
    weld at least exact float32 duplicates; trimesh rounds positions to 1e-8 and
    `meshio.load_mesh` quantises at 1e-9 of the bounding-box diagonal, so this is a superset
    of what they merge, yet finer than a float32 ulp at building scale (7.6e-6 at 100 m): two
    vertices that are apart in the file are not flagged."""
    if not len(v):
        return 1e-6
    extent = 3.0 * float(v.max() - v.min())  # >= the sum of the axis extents (and fast)
    return max(1e-6, 2e-9 * extent)


def coincident_groups(vertices: Any) -> list[np.ndarray]:
    """Groups (arrays of vertex indices, each of size >= 2) of vertices in one grid cell
    (see `_cell`), in either of two grids offset by half a cell. Exact duplicates (what
    manifold3d's copies of a pinched vertex are) are always found, near ones within a
    fraction of a cell nearly always. Empty list when every position is distinct."""
    v = np.asarray(vertices)[:, :3].astype(np.float64)
    n = len(v)
    if n < 2:
        return []
    cell = _cell(v)
    found = []  # (vertex indices, their integer cells) of vertices sharing a hash key
    for shift in (0.0, 0.5):
        q = np.floor(v / cell + shift).astype(np.int64)
        # one int64 key per cell (wrapping multiply-add); collisions are sorted out below
        key = q @ _KEY
        ks = np.sort(key)
        if not (ks[1:] == ks[:-1]).any():  # the common case: every vertex in its own cell
            continue
        order = np.argsort(key, kind="stable")
        ks = key[order]
        same = ks[1:] == ks[:-1]
        if same.any():
            idx = order[np.concatenate(([False], same)) | np.concatenate((same, [False]))]
            found.append((idx, q[idx]))
    if not found:
        return []
    # union of the vertices sharing a cell, over both grids: connected components of the graph
    # joining each vertex to the first vertex of its cell (candler: ~30,000 vertices)
    rows, cols = [], []
    for idx, cells in found:
        _, first, inv = np.unique(cells, axis=0, return_index=True, return_inverse=True)
        rows.append(idx)
        cols.append(idx[first[inv.reshape(-1)]])
    r, c = np.concatenate(rows), np.concatenate(cols)
    nodes = np.unique(np.concatenate([r, c]))  # ascending
    root = components(len(nodes), np.searchsorted(nodes, r), np.searchsorted(nodes, c))
    # groups in the order of their smallest vertex (each component's root), each ascending
    order = np.argsort(root, kind="stable")
    _labels, start, sizes = np.unique(root[order], return_index=True, return_counts=True)
    return [nodes[order[a:a + k]] for a, k in zip(start.tolist(), sizes.tolist()) if k > 1]


def components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of the graph on nodes 0..n-1 with edges (u[i], v[i]): for every
    node, the smallest node of its component. Numpy only (scipy's csgraph is ~0.2 s of imports
    a warm derive does without): roots hooked onto the smaller root, then paths halved until
    every node points at its root, repeated until no edge joins two roots."""
    parent = np.arange(n)
    u, v = np.asarray(u, dtype=np.int64), np.asarray(v, dtype=np.int64)
    while True:
        pu, pv = parent[u], parent[v]
        apart = pu != pv
        if not apart.any():
            return parent
        lo, hi = np.minimum(pu[apart], pv[apart]), np.maximum(pu[apart], pv[apart])
        np.minimum.at(parent, hi, lo)
        while True:
            up = parent[parent]
            if np.array_equal(up, parent):
                break
            parent = up


def coincident_count(vertices: Any) -> int:
    """How many vertices a welding reader would merge away (0 for a clean mesh)."""
    return sum(len(g) - 1 for g in coincident_groups(vertices))


def separate_mesh(vertices: np.ndarray, tris: np.ndarray, groups: list[np.ndarray],
                  distance: float = SEPARATION, spread: bool = False) -> np.ndarray:
    """New vertex positions: every vertex of `groups` moved by `distance` (at least 16 float32
    ulps of its coordinates, or the file would round the move away) towards the centroid of
    its incident triangles; with `spread`, the k-th vertex of each group k+1 times as far.
    Other vertices are returned unchanged.

    No cap by the fan's shortest edge: the copies are often joined by zero-area or sub-micron
    triangles, and a cap would shrink the move below float32 resolution. A triangle shorter
    than the move may flip, which changes nothing a reader checks (connectivity) or sees."""
    v = np.asarray(vertices, dtype=np.float64)[:, :3]
    t = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    moved = np.concatenate(groups)
    is_moved = np.zeros(len(v), dtype=bool)
    is_moved[moved] = True
    tt = t[is_moved[t].any(axis=1)]
    cen = v[tt].mean(axis=1)
    pull = np.zeros_like(v)
    for k in range(3):
        vk = tt[:, k]
        hit = is_moved[vk]
        np.add.at(pull, vk[hit], cen[hit] - v[vk[hit]])
    d = pull[moved]
    ln = np.linalg.norm(d, axis=1)
    ok = ln > 0
    step = max(distance, 16.0 * float(np.spacing(np.float32(np.abs(v[moved]).max()))))
    scale = np.concatenate([np.arange(1, len(g) + 1) for g in groups]) if spread else np.ones(len(moved))
    out = v.copy()
    out[moved[ok]] += d[ok] / ln[ok, None] * (step * scale[ok, None])
    return out


def separate(body: Any, mesh: Any, groups: list[np.ndarray], build: bool = True) -> tuple[Any, Any]:
    """(Manifold, Mesh) of `body` with the coincident `groups` of `mesh` pulled apart.

    The triangles, runs and original IDs (the semantic tags) are kept; only positions change.
    Returns the input unchanged if the moved mesh is not a valid manifold (never expected).
    With `build=False` the manifold is not built (None; the caller builds it when asked)."""
    verts = np.asarray(mesh.vert_properties, dtype=np.float32)
    tris = np.asarray(mesh.tri_verts, dtype=np.uint32)
    props = verts.copy()
    for attempt in range(3):
        # a second pass (copies whose fans pull the same way) moves the k-th copy k+1 times as far
        props[:, :3] = separate_mesh(props, tris, groups, spread=attempt > 0).astype(np.float32)
        groups = coincident_groups(props)
        if not groups:
            break
    kw = {"run_index": np.asarray(mesh.run_index, dtype=np.uint32),
          "run_original_id": np.asarray(mesh.run_original_id, dtype=np.uint32)}
    new_mesh = manifold3d.Mesh(vert_properties=np.ascontiguousarray(props),
                               tri_verts=np.ascontiguousarray(tris), **kw)
    if not build:
        return None, new_mesh
    new_body = manifold3d.Manifold(new_mesh)
    if new_body.status() != manifold3d.Error.NoError:
        return body, mesh
    return new_body, new_mesh
