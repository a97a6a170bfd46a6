"""A local cyclic order of each node's edges (Liu et al. 2015, section 4.3.2, non-manifold data).

For each part, the centroids of its neighbours (and its own) get a least-squares plane by
local PCA; the edges (vectors between centroids) are projected into that plane and sorted by
angle. The plane's normal is oriented upwards (+z, the up axis of tiling grammars), or, for a
vertical plane, towards a fixed horizontal reference, so that translated and z-rotated copies
of one configuration get the same cyclic order: the orientation is what makes a match
orientation-preserving (no mirrored copies, which a rigid embedding could not realise).
Parts with fewer than three neighbours have a single cyclic order, whatever the plane.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

UP = np.array([0.0, 0.0, 1.0])
_REF = np.array([0.6, 0.8, 0.0])  # fixed horizontal reference for vertical planes


def cyclic_orders(centroids: np.ndarray, adjacency: Sequence[Sequence[int]]) -> list[list[int]]:
    """Neighbours of every node sorted by angle in its local PCA plane."""
    c = np.asarray(centroids, dtype=np.float64)
    out: list[list[int]] = []
    for u, row in enumerate(adjacency):
        row = sorted(int(w) for w in row)
        if len(row) < 3:
            out.append(row)
            continue
        pts = np.vstack([c[u], c[row]])
        centred = pts - pts.mean(axis=0)
        _, _, vt = np.linalg.svd(centred, full_matrices=True)
        normal = vt[2]
        up = float(normal @ UP)
        if abs(up) > 0.1:
            normal = normal if up > 0 else -normal
        elif float(normal @ _REF) < 0:
            normal = -normal
        # a basis of the plane: e1 from the horizontal reference (or x) projected into it
        ref = _REF if abs(float(normal @ _REF)) < 0.9 else np.array([0.0, 0.0, 1.0])
        e1 = ref - (ref @ normal) * normal
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(normal, e1)
        d = c[row] - c[u]
        ang = np.arctan2(d @ e2, d @ e1)
        # angles rounded so that float noise between identical copies cannot reorder ties
        order = sorted(range(len(row)), key=lambda k: (round(float(ang[k]), 6), row[k]))
        out.append([row[k] for k in order])
    return out
