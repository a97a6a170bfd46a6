"""Closing open triangle meshes into solids (the default, watertight output of CGA-style models).

CGA inserts open meshes as they are (a window pane, a shop-window frame, a column shaft without
caps) and leaves faces as zero-thickness surfaces. grammarkit's default output is one closed
manifold per connected mass (docs/operations.md, "Watertight output"), so an open piece is
made closed here, in this order, per connected component (by shared edges, vertices welded by
position):

1. already closed: kept as it is;
2. *holes filled*: each boundary loop is triangulated in its best-fitting plane (a shaft's open
   ends get their caps); kept when manifold3d accepts the result and it encloses volume;
3. *a convex patch*: a piece every face of which lies on its convex hull's boundary (a bar
   modelled as its three visible sides, a bent strip) becomes that hull: the visible faces stay
   where they were and only back faces are added (a 4-triangle L-profile closes with 8
   triangles instead of thickening's 20, and no slivers to unite);
4. *thickened*: the component is given a back side `THICKNESS` behind its front (vertices moved
   against their normals) and side walls along its boundary: a pane becomes a 1 cm slab, its
   visible front where it was;
5. what none makes closed (a non-orientable or self-touching piece) becomes its convex hull.

The result depends only on the triangles (it is cached by their bytes, so a window inserted a
hundred times at one size is closed once: `close_mesh`).
"""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from typing import Any

import manifold3d
import numpy as np

from .surfaces import unit_normals

__all__ = ["CONVEX_PATCHES", "THICKNESS", "close_mesh", "thicken", "fill_holes"]

Manifold = manifold3d.Manifold

# The documented thickness (model units, metres) of a surface made solid: an open inserted
# mesh that no hole filling closes, a face terminal off every solid, a flat volume.
THICKNESS = 0.01

# Step 3 (convex patches) on or off: off is the closing before issue 27's second step, kept
# so that benchmarks/bench_prt.py --baseline can measure it in the same run.
CONVEX_PATCHES = True

_CACHE: OrderedDict[bytes, Any] = OrderedDict()
_CACHE_SIZE = 512


def close_mesh(V: np.ndarray, F: np.ndarray, thickness: float = THICKNESS) -> Any:
    """A closed manifold3d solid made of the open mesh (V, F) (see the module docstring), or
    None when it has no area. Cached by the mesh's bytes (the same insert at the same size)."""
    V = np.ascontiguousarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    flags = repr((thickness, CONVEX_PATCHES)).encode()
    key = hashlib.blake2b(V.tobytes() + b"|" + F.tobytes() + flags, digest_size=16).digest()
    hit = _CACHE.get(key)
    if hit is not None or key in _CACHE:
        _CACHE.move_to_end(key)
        return hit
    solid = _close(V, F, thickness)
    _CACHE[key] = solid
    if len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return solid


def _weld(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices welded by position (to 1e-6 of the extent), degenerate triangles dropped."""
    ext = float(np.ptp(V, axis=0).max()) if len(V) else 0.0
    q = np.round(V / max(ext * 1e-6, 1e-9)).astype(np.int64)
    _, first, inv = np.unique(q, axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    F = inv[F]
    ok = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    return V[first], F[ok]


def _components(F: np.ndarray, nv: int) -> list[np.ndarray]:
    """Triangle indices of each edge-connected component (union-find over shared edges)."""
    parent = np.arange(len(F))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    tri = np.tile(np.arange(len(F)), 3)
    key = edges[:, 0] * nv + edges[:, 1]
    order = np.argsort(key, kind="stable")
    k, t = key[order], tri[order]
    same = np.nonzero(k[1:] == k[:-1])[0]
    for i in same.tolist():
        a, b = find(int(t[i])), find(int(t[i + 1]))
        if a != b:
            parent[max(a, b)] = min(a, b)
    roots = np.array([find(i) for i in range(len(F))])
    return [np.nonzero(roots == r)[0] for r in np.unique(roots)]


def _manifold(V: np.ndarray, F: np.ndarray) -> Any:
    mesh = manifold3d.Mesh(vert_properties=np.ascontiguousarray(V, dtype=np.float32),
                           tri_verts=np.ascontiguousarray(F, dtype=np.uint32))
    solid = Manifold(mesh)
    if solid.status() != manifold3d.Error.NoError or solid.is_empty():
        return None
    return solid


def _boundary(F: np.ndarray) -> np.ndarray:
    """Directed boundary edges (a, b): used once, never in the other direction."""
    d = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    fwd = {(int(a), int(b)) for a, b in d}
    return np.array([(a, b) for a, b in fwd if (b, a) not in fwd], dtype=np.int64).reshape(-1, 2)


def _loops(edges: np.ndarray) -> list[list[int]] | None:
    """The boundary edges chained into loops, or None where a vertex has two outgoing edges."""
    nxt: dict[int, int] = {}
    for a, b in edges.tolist():
        if a in nxt:
            return None
        nxt[a] = b
    loops, seen = [], set()
    for start in sorted(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen:
            seen.add(v)
            loop.append(v)
            v = nxt.get(v)
            if v is None:
                return None
        if v != start:
            return None
        loops.append(loop)
    return loops


def fill_holes(V: np.ndarray, F: np.ndarray) -> np.ndarray | None:
    """F plus triangles closing every boundary loop (each triangulated in its best-fitting
    plane, wound against the loop so the cap faces out), or None when the boundary is not a
    set of simple loops."""
    loops = _loops(_boundary(F))
    if loops is None:
        return None
    caps = [F]
    for loop in loops:
        if len(loop) < 3:
            return None
        ring = loop[::-1]  # the cap runs against the boundary's direction
        P = V[ring]
        c = P.mean(axis=0)
        n = np.cross(P - c, np.roll(P, -1, axis=0) - c).sum(axis=0)  # Newell normal
        ln = np.linalg.norm(n)
        if ln < 1e-15:
            return None
        n /= ln
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        pts = np.column_stack([(P - c) @ u, (P - c) @ w])
        tris = np.asarray(manifold3d.triangulate([pts]), dtype=np.int64).reshape(-1, 3)
        if len(tris) != len(ring) - 2:
            return None  # the loop self-intersects in its plane
        caps.append(np.asarray(ring, dtype=np.int64)[tris])
    return np.concatenate(caps)


def thicken(V: np.ndarray, F: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """The open mesh (V, F) with a back side `thickness` behind it (vertices moved against their
    area-weighted normals) and walls along its boundary: a closed mesh if (V, F) is an
    orientable manifold with boundary."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    fn = np.cross(b - a, c - a)  # area-weighted face normals
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], fn)
    ln = np.linalg.norm(vn, axis=1)
    ok = ln > 1e-15
    vn[ok] /= ln[ok, None]
    n = len(V)
    back = V - thickness * vn
    walls = []
    for p, q in _boundary(F).tolist():
        walls += [[q, p, p + n], [q, p + n, q + n]]
    W = np.asarray(walls, dtype=np.int64).reshape(-1, 3)
    return np.vstack([V, back]), np.concatenate([F, F[:, ::-1] + n, W])


def _close_component(V: np.ndarray, F: np.ndarray, thickness: float) -> Any:
    used, inv = np.unique(F, return_inverse=True)
    V, F = V[used], inv.reshape(-1, 3)
    solid = _manifold(V, F)
    if solid is not None and solid.volume() > 0:
        return solid
    filled = fill_holes(V, F)
    if filled is not None:
        solid = _manifold(V, filled)
        area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
        # a pane "filled" by its own back face encloses nothing: thicken it instead
        if solid is not None and solid.volume() > 0.1 * thickness * area:
            return solid
    hull = _convex_patch_hull(V, F, thickness) if CONVEX_PATCHES else None
    if hull is not None:
        return hull
    Vt, Ft = thicken(V, F, thickness)
    solid = _manifold(Vt, Ft)
    if solid is not None and solid.volume() > 0:
        return solid
    hull = Manifold.hull_points(np.ascontiguousarray(V, dtype=np.float32))
    return None if hull.is_empty() or hull.volume() <= 0 else hull


def _convex_patch_hull(V: np.ndarray, F: np.ndarray, thickness: float) -> Any:
    """The convex hull of the piece when every triangle of it lies in a supporting plane of
    the hull (all the piece's vertices on one side, within a hundredth of `thickness`) and the
    hull is at least `thickness` thick; else None (a flat pane is thickened instead)."""
    ok, n, ln = unit_normals(V, F, 1e-15)
    if not ok.any():
        return None
    a = V[F[ok, 0]]
    side = np.einsum("tvk,tk->tv", V[None, :, :] - a[:, None, :], n)
    tol = 0.01 * thickness
    if not np.all((side.max(axis=1) <= tol) | (side.min(axis=1) >= -tol)):
        return None  # some face has vertices of the piece on both sides: not convex
    hull = Manifold.hull_points(np.ascontiguousarray(V, dtype=np.float32))
    if hull.is_empty():
        return None
    area = 0.5 * float(ln.sum())
    return hull if hull.volume() >= 0.1 * thickness * area else None


def _close(V: np.ndarray, F: np.ndarray, thickness: float) -> Any:
    if len(F) == 0:
        return None
    V, F = _weld(V, F)
    if len(F) == 0:
        return None
    solid = _manifold(V, F)
    if solid is not None and solid.volume() > 0:
        return solid  # closed once welded
    parts = [p for p in (_close_component(V, F[idx], thickness) for idx in _components(F, len(V)))
             if p is not None]
    if not parts:
        return None
    return parts[0] if len(parts) == 1 else Manifold.batch_boolean(parts, manifold3d.OpType.Add)
