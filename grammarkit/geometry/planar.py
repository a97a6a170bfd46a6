"""The planar faces of a triangle mesh: what `comp(f)` makes of a roof, a taper or an insert.

A face is a connected set of coplanar triangles (edge-adjacent, normals within ~0.1 degree,
plane offsets within 1e-6 of the model's size). Its outline is made of the directed
boundary edges of those triangles (an edge whose reverse is not in the set), chained into
loops: counter-clockwise about the normal for the outer contour, clockwise for holes, as
grammarkit's face polygons are. Written by hand because trimesh's facet grouping needs its
graph helpers (networkx/scipy) and returns no ordered outlines; this is ~60 lines of numpy.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PlanarFace", "planar_faces", "MAX_FACES"]

# A mesh with more faces than this is refused by comp(f) (an inserted high-poly asset): each
# face becomes a shape, and shapes cost Python time.
MAX_FACES = 20_000


@dataclass
class PlanarFace:
    normal: np.ndarray  # unit normal (3,)
    loops: list[np.ndarray]  # outline loops, each (k, 3) in order (outer CCW, holes CW)
    triangles: np.ndarray  # indices of the mesh triangles in the face


def _weld(V: np.ndarray, F: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices closer than `tol` (by rounding): soup meshes share no vertex indices."""
    key = np.round(V / tol).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return V[first], inv.reshape(-1)[F]


def planar_faces(V: np.ndarray, F: np.ndarray) -> list[PlanarFace]:
    """The planar faces of the mesh (V: (n, 3) float, F: (m, 3) int), ordered by their first
    triangle (deterministic)."""
    V = np.asarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.asarray(F, dtype=np.int64).reshape(-1, 3)
    if len(F) == 0:
        return []
    extent = float(np.ptp(V, axis=0).max()) if len(V) else 1.0
    tol = max(extent, 1.0) * 1e-7
    V, F = _weld(V, F, tol)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    ln = np.linalg.norm(n, axis=1)
    good = ln > tol * tol
    n[good] /= ln[good, None]
    off = np.einsum("ij,ij->i", n, a)
    m = len(F)
    # union-find over triangles sharing an edge with the same plane
    parent = np.arange(m)

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    e0 = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    e1 = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    tri = np.tile(np.arange(m), 3)
    lo, hi = np.minimum(e0, e1), np.maximum(e0, e1)
    order = np.lexsort((hi, lo))
    lo_s, hi_s, tri_s = lo[order], hi[order], tri[order]
    same = (lo_s[1:] == lo_s[:-1]) & (hi_s[1:] == hi_s[:-1])
    for k in np.nonzero(same)[0].tolist():
        t, u = int(tri_s[k]), int(tri_s[k + 1])
        if not (good[t] and good[u]):
            continue
        if float(n[t] @ n[u]) > 1 - 1e-6 and abs(off[t] - off[u]) < max(extent, 1.0) * 1e-6:
            rt, ru = find(t), find(u)
            if rt != ru:
                parent[max(rt, ru)] = min(rt, ru)
    roots = np.array([find(i) for i in range(m)])
    faces: list[PlanarFace] = []
    for root in np.unique(roots).tolist():  # roots are the smallest member: first-triangle order
        members = np.nonzero(roots == root)[0]
        if not good[members].any():
            continue
        sub = F[members]
        d0 = np.concatenate([sub[:, 0], sub[:, 1], sub[:, 2]])
        d1 = np.concatenate([sub[:, 1], sub[:, 2], sub[:, 0]])
        fwd = set(zip(d0.tolist(), d1.tolist()))
        boundary = [(u, v) for u, v in zip(d0.tolist(), d1.tolist()) if (v, u) not in fwd]
        nxt: dict[int, list[int]] = {}
        for u, v in boundary:
            nxt.setdefault(u, []).append(v)
        loops = []
        used: set[tuple[int, int]] = set()
        for u, v in boundary:
            if (u, v) in used:
                continue
            loop = [u]
            cur, to = u, v
            while (cur, to) not in used:
                used.add((cur, to))
                loop.append(to)
                cands = [w for w in nxt.get(to, []) if (to, w) not in used]
                if not cands:
                    break
                cur, to = to, cands[0]
            if loop[-1] == loop[0]:
                loop.pop()
            if len(loop) >= 3:
                loops.append(V[np.asarray(loop)])
        if loops:
            nrm = n[members[good[members]]].mean(axis=0)
            nrm /= np.linalg.norm(nrm)
            faces.append(PlanarFace(nrm, loops, members))
        if len(faces) > MAX_FACES:
            raise ValueError(f"the mesh has more than {MAX_FACES} planar faces")
    return faces
