"""Where a contact is, independent of how the shape is turned (issue 28: tilings the project
has never seen, e.g. a whole tiling turned by 30 degrees about the up axis).

A contact's position (Liu 2015's boundary-frame origin: the centre of the two parts' bounding-box
intersection) and its normal (the thinnest axis of that intersection) are read along the
first part's *modelling* axes (its pose: the Kalojanov frame times the prototype's inverse)
whenever those are not world axes; with world boxes, the intersection of two differently sized
parts (a bridge against a block) moves when the shape turns, and its sites would no longer be
found. Parts along the world axes (every turn a multiple of 90 degrees) cost nothing extra.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .rules import Rules
    from .validate import _Shape

__all__ = ["contact_geometry"]


def contact_geometry(rules: Rules, shape: _Shape, e: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per contact of `e`: the centre of the two parts' bounding-box intersection, its normal
    (the thinnest axis of that intersection, pointing from the first part's box centre to the
    second's; on a tie the first such axis) and whether it is a *corner* contact (thin along
    two axes or more: parts that meet along an edge or at a point, diagonal neighbours of
    square tiles). The boxes are taken along the first part's modelling axes (its pose) when
    that part stands turned off the world axes (a tiling turned by 30 degrees): where the
    contact is does not depend on how the shape is turned. Parts along the world axes (every
    turn a multiple of 90 degrees) use the world boxes directly."""
    e = np.asarray(e, dtype=np.int64)
    a, b = shape.edges[e, 0], shape.edges[e, 1]
    lo, hi = np.maximum(shape.lo[a], shape.lo[b]), np.minimum(shape.hi[a], shape.hi[b])
    d = (shape.lo[b] + shape.hi[b]) - (shape.lo[a] + shape.hi[a])
    rot = _modelling_rotations(rules, shape, np.unique(np.concatenate([a, b]))) if len(e) else {}
    axes = np.tile(np.eye(3), (len(e), 1, 1))  # columns: the axes the boxes are taken along
    for j, (u, v) in enumerate(zip(a.tolist(), b.tolist())):
        R = rot.get(u, rot.get(v))
        if R is None:
            continue
        Vu = np.asarray(shape.part(u).mesh.vertices, dtype=np.float64) @ R
        Vv = np.asarray(shape.part(v).mesh.vertices, dtype=np.float64) @ R
        lo[j], hi[j] = np.maximum(Vu.min(axis=0), Vv.min(axis=0)), np.minimum(Vu.max(axis=0), Vv.max(axis=0))
        d[j] = (Vv.min(axis=0) + Vv.max(axis=0)) - (Vu.min(axis=0) + Vu.max(axis=0))
        axes[j] = R
    points = np.einsum("nij,nj->ni", axes, (lo + hi) / 2)
    ext = np.maximum(hi - lo, 0.0)
    thin = 1e-3 * np.minimum(shape.diag[a], shape.diag[b])
    k = np.argmax(ext <= ext.min(axis=1, keepdims=True) + 1e-6 * thin[:, None], axis=1) if len(e) \
        else np.zeros(0, dtype=np.int64)
    rows = np.arange(len(e))
    sign = np.sign(d[rows, k])
    sign[sign == 0] = 1.0
    normals = axes[rows, :, k] * sign[:, None]
    corner = (ext <= thin[:, None]).sum(axis=1) >= 2
    return points, normals, corner


def _modelling_rotations(rules: Rules, shape: _Shape, idx: np.ndarray) -> dict[int, np.ndarray]:
    """{part index: world-from-modelling rotation} for the parts of `idx` whose modelling
    axes are not world axes (the rotation is no signed permutation); parts without a
    prototype are taken as along the axes."""
    out: dict[int, np.ndarray] = {}
    by_type: dict[str, list[int]] = {}
    for i in idx.tolist():
        by_type.setdefault(shape.types[i], []).append(i)
    for t, members in by_type.items():
        spec = rules.parts.get(t)
        if spec is None:
            continue
        m = np.array(members, dtype=np.int64)
        R = np.einsum("nij,kj->nik", shape.frames(m)[m, :3, :3], spec.frame[:3, :3])  # R_F R_P^T
        off = np.abs(np.abs(R) - np.round(np.abs(R))).max(axis=(1, 2)) > 1e-6
        for i, Ri in zip(m[off].tolist(), R[off]):
            out[i] = Ri
    return out
