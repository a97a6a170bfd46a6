"""Orientation of parts: the grammar's up axis, turns about it, and mirrored copies.

Gravity is not a symmetry. A box looks the same upside down, but a door on the top floor or a
cornice at the bottom of a facade is not what the examples show. So:

- a grammar has an **up axis** (`up +z`, the default: grammarkit's Z-up frame, which is how
  every example file is read); `up none` switches orientation checks off;
- a part type's **symmetry** is a group of turns about that axis (`symmetry(z4)`: turning the
  part by 90 degrees about the vertical line through its surface centroid leaves it looking
  the same). Placements and sites are compared only up to these turns, never up to a flip.
  Without a declaration the group is found from the part's geometry (`turn_order`, on a
  bounded vertex sample);
- a part's **pose** is the rigid motion from its type's prototype (the `part` statement's
  geometry, in its modelling frame) to the part: `M = F_part @ inv(F_proto)` with Kalojanov's
  frames (`frames.local_frame`), exact for rigid copies of the prototype's mesh. The part stands
  as allowed when `M^-1` maps the world's up onto one of the type's allowed up directions
  (`up(+z, +x)`; default: the grammar's up axis, i.e. as modelled);
- a **mirrored** copy (a node transform with a negative determinant) of a part whose geometry
  is mirror-symmetric is the same solid as a properly turned copy, and is re-expressed as one
  (`normalize_mirrored`); a mirrored copy of a chiral part is a different part unless the type
  declares `symmetry(..., mirror)`.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = [
    "AXES", "MAX_TURN_ORDER", "SAMPLE_VERTICES", "TURN_TOLERANCE", "normalize_mirrored",
    "improper_symmetry", "turn", "turn_group", "turn_order", "up_vector",
]

AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0),
        "-y": (0.0, -1.0, 0.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0)}

# Symmetry search bounds (documented in docs/tiling.md): turn orders up to 64 are tried; each
# candidate is verified on at most SAMPLE_VERTICES evenly strided vertices, every one of which
# must land within TURN_TOLERANCE x the part's bounding-box diagonal of some vertex.
MAX_TURN_ORDER = 64
SAMPLE_VERTICES = 1024
TURN_TOLERANCE = 1e-4


def up_vector(axis: str | None) -> np.ndarray | None:
    """The unit vector of an `up` axis name (+x ... -z); None for `none`/None."""
    if axis is None or axis == "none":
        return None
    return np.array(AXES[axis], dtype=np.float64)


def turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """3x3 rotation by `angle` (radians) about the unit vector `axis` (Rodrigues)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def turn_group(axis: np.ndarray, n: int) -> np.ndarray:
    """(n, 3, 3): the turns by k * 360/n degrees about `axis`, identity first."""
    n = max(1, int(n))
    return np.array([turn(axis, 2 * math.pi * k / n) if k else np.eye(3) for k in range(n)])


def _sample(vertices: np.ndarray, k: int = SAMPLE_VERTICES) -> np.ndarray:
    stride = max(1, len(vertices) // k)
    return vertices[::stride][:k]


def turn_order(vertices, centre, axis, *, max_order: int = MAX_TURN_ORDER,  # noqa: ANN001
               tolerance: float = TURN_TOLERANCE) -> int:
    """The largest n <= max_order such that turning the vertex set by 360/n degrees about
    `axis` through `centre` maps it onto itself (1: no turn symmetry).

    Checked on a sample of at most SAMPLE_VERTICES vertices against a k-d tree of all of them
    (bounded cost on any mesh: O(V log V) to build, max_order x sample queries)."""
    from scipy.spatial import cKDTree

    V = np.asarray(vertices, dtype=np.float64)
    if len(V) < 2:
        return 1
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    tol = tolerance * size
    c = np.asarray(centre, dtype=np.float64)
    tree = cKDTree(V)
    sample = _sample(V) - c
    probe = sample[:: max(1, len(sample) // 16)]  # a few points reject most candidates at once
    for n in range(max(1, int(max_order)), 1, -1):
        R = turn(axis, 2 * math.pi / n)
        for pts in (probe, sample):
            d, _ = tree.query(pts @ R.T + c, distance_upper_bound=tol)
            if not np.isfinite(d).all():
                break
        else:
            return n
    return 1


def improper_symmetry(vertices) -> tuple[np.ndarray, np.ndarray] | None:  # noqa: ANN001
    """A reflection J (4x4, through a plane containing the vertex centroid) with J V = V as a
    set, and the vertex correspondence `perm` (J @ V[i] == V[perm[i]]); None if the vertex set
    has no mirror plane among the candidates (the coordinate planes, the principal planes and
    the diagonal planes between coordinate axes: what modelled parts have)."""
    from scipy.spatial import cKDTree

    V = np.asarray(vertices, dtype=np.float64)
    if len(V) < 2:
        return None
    c = V.mean(axis=0)
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    tol = TURN_TOLERANCE * size
    X = V - c
    normals = [np.eye(3)[k] for k in range(3)]
    try:
        _, vecs = np.linalg.eigh(np.cov(X.T) if len(X) > 1 else np.eye(3))
        normals += [vecs[:, k] for k in range(3)]
    except np.linalg.LinAlgError:
        pass
    s = 1 / math.sqrt(2)
    normals += [np.array(v) * s for v in ((1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1))]
    tree = cKDTree(V)
    for n in normals:
        n = n / np.linalg.norm(n)
        R = np.eye(3) - 2 * np.outer(n, n)
        d, idx = tree.query(X @ R.T + c, distance_upper_bound=tol)
        if np.isfinite(d).all() and len(np.unique(idx)) == len(V):
            J = np.eye(4)
            J[:3, :3] = R
            J[:3, 3] = c - R @ c
            return J, idx
    return None


def normalize_mirrored(part):  # noqa: ANN001, ANN201
    """`part` itself if its transform is proper; otherwise, if its local geometry (the mesh
    before the transform) has a mirror plane J, the same solid as a proper copy: local mesh
    moved by `transform @ J` (vertex order of the local mesh, so its frame corresponds to
    every other copy's); else the part with `meta["mirrored"] = True` (a chiral mirror image)."""
    import trimesh

    from .assembly import Part

    T = np.asarray(part.transform, dtype=np.float64)
    if T.shape != (4, 4) or np.linalg.det(T[:3, :3]) >= 0:
        return part
    try:
        inv = np.linalg.inv(T)
    except np.linalg.LinAlgError:
        return part
    world = np.asarray(part.mesh.vertices, dtype=np.float64)
    local = world @ inv[:3, :3].T + inv[:3, 3]
    found = improper_symmetry(local)
    meta = dict(part.meta)
    if found is None:
        meta["mirrored"] = True
        return Part(part.id, part.type, part.mesh, T, meta)
    J, _ = found
    proper = T @ J
    verts = local @ proper[:3, :3].T + proper[:3, 3]
    # trimesh re-winds triangles when it applies a reflection (so the mirrored world mesh still
    # faces outwards); the proper copy of the local mesh needs the winding back.
    faces = np.asarray(part.mesh.faces)[:, ::-1]
    meta["mirrored"] = "normalized"
    return Part(part.id, part.type, trimesh.Trimesh(verts, faces, process=False), proper, meta)
