"""Rigid parts (issue 28): every placed part is a rigid copy of its type's prototype.

A part's pose is the proper rigid motion from its prototype (the `part` geometry, modelling
frame) to it, from the Kalojanov frames (validate._poses): M = F_part · inv(F_prototype). The
part is **rigid** when the prototype moved by M matches the part's mesh: every vertex within
`RIGID_TOLERANCE` (0.1%) of the part's diagonal, compared vertex by vertex when the meshes are
copies (same vertex count), else point set to point set (nearest vertices both ways; also the
fallback when a turn symmetry permutes the vertices). A squashed gate, a stretched wall or a
mirror image of a chiral part is no rigid copy. `constraint deformable(T)` declares that T
parts may be deformed (a back end that adapts them must declare it): they are not checked.
Parts whose type has no prototype (`up(any)`, no `part` statement) are not checked either.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["RIGID_TOLERANCE", "deformable_types", "rigid_errors"]

RIGID_TOLERANCE = 1e-3
_CHUNK = 2_000_000  # vertices compared at once (bounds the memory of 100k-part models)


def deformable_types(rules: Any) -> set[str]:
    return {str(a.get("type", a.get("0"))) for n, a, _ in getattr(rules, "constraints", ()) if n == "deformable"}


def rigid_errors(rules: Any, shape: Any, poses: Any, idx: np.ndarray) -> list[tuple[int, float]]:
    """(part index, worst vertex error / diagonal) of the parts in `idx` that are not rigid
    copies of their prototypes."""
    from scipy.spatial import cKDTree

    skip = deformable_types(rules)
    out: list[tuple[int, float]] = []
    by_type: dict[str, list[int]] = {}
    for i in np.asarray(idx, dtype=np.int64).tolist():
        t = shape.types[i]
        spec = rules.parts.get(t)
        if spec is None or spec.vertices is None or t in skip or t in rules.free or poses.skip[i]:
            continue
        by_type.setdefault(t, []).append(i)
    for t, members in by_type.items():
        spec = rules.parts[t]
        V = spec.vertices
        inv = np.linalg.inv(spec.frame)
        F = shape.frames(np.array(members))
        step = max(1, _CHUNK // max(len(V), 1))
        for c in range(0, len(members), step):
            chunk = members[c:c + step]
            M = np.einsum("nij,jk->nik", F[chunk], inv)  # modelling frame -> world, per part
            for k, i in enumerate(chunk):
                W = np.asarray(shape.mesh(i).vertices, dtype=np.float64)
                P = V @ M[k, :3, :3].T + M[k, :3, 3]
                tol = RIGID_TOLERANCE * max(float(spec.size), 1e-12)
                if len(W) == len(P):
                    err = float(np.linalg.norm(W - P, axis=1).max())
                    if err <= tol:
                        continue
                err = max(float(cKDTree(W).query(P)[0].max()), float(cKDTree(P).query(W)[0].max()))
                if err > tol:
                    out.append((i, err / max(float(spec.size), 1e-12)))
    return out
