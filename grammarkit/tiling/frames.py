"""Kalojanov's local part frame (2019, section 6): a frame that moves rigidly with the part.

Construction, on the mesh's vertices:
1. origin: the area-weighted surface centroid (tessellation-robust and rotation-invariant);
2. p1 = the vertex farthest from the centroid, p2 = the vertex farthest from p1: x along p1->p2
   (the part's "diagonal");
3. p3 = the vertex farthest from the line p1p2: y along its component orthogonal to x; z = x cross y.

The paper found this more stable than PCA axes, whose order and signs flip for symmetric parts
(a cube has three equal variances). Symmetric parts still have ties (a box's 8 corners are all
farthest from its centre): ties within a relative 1e-6 go to the lowest vertex index, so rigid
copies of one mesh (same vertex order: what examples, written assemblies and the sampler
produce) always get corresponding frames. Degenerate parts (all vertices on a line or a point)
fall back to the world axes for the missing directions.
"""
from __future__ import annotations

import numpy as np

from .assembly import Part

__all__ = ["local_frame", "relative_placement", "surface_centroid"]

_TIE = 1e-6


def surface_centroid(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    tri = vertices[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if len(area) == 0 or area.sum() <= 0:
        return vertices.mean(axis=0)
    return (area[:, None] * tri.mean(axis=1)).sum(axis=0) / area.sum()


def _argmax_first(values: np.ndarray) -> int:
    top = values.max()
    return int(np.flatnonzero(values >= top - _TIE * max(abs(top), 1e-12))[0])


def local_frame(part_or_vertices, faces: np.ndarray | None = None) -> np.ndarray:  # noqa: ANN001
    """4x4 matrix whose columns are the frame's x, y, z axes and origin, in world coordinates."""
    if isinstance(part_or_vertices, Part):
        verts = np.asarray(part_or_vertices.mesh.vertices, dtype=np.float64)
        faces = np.asarray(part_or_vertices.mesh.faces)
    else:
        verts = np.asarray(part_or_vertices, dtype=np.float64)
    origin = surface_centroid(verts, faces) if faces is not None and len(faces) else verts.mean(axis=0)
    frame = np.eye(4)
    frame[:3, 3] = origin
    if len(verts) < 2:
        return frame
    p1 = verts[_argmax_first(np.linalg.norm(verts - origin, axis=1))]
    p2 = verts[_argmax_first(np.linalg.norm(verts - p1, axis=1))]
    x = p2 - p1
    if np.linalg.norm(x) <= 0:
        return frame
    x /= np.linalg.norm(x)
    rel = verts - p1
    off = rel - np.outer(rel @ x, x)  # components orthogonal to the diagonal
    dist = np.linalg.norm(off, axis=1)
    if dist.max() > _TIE * np.linalg.norm(p2 - p1):
        y = off[_argmax_first(dist)]
    else:  # all vertices on a line: any orthogonal direction, chosen deterministically
        helper = np.eye(3)[int(np.argmin(np.abs(x)))]
        y = helper - (helper @ x) * x
    y /= np.linalg.norm(y)
    z = np.cross(x, y)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = x, y, z
    return frame


def relative_placement(frame_a: np.ndarray, frame_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(translation, rotation) of frame b expressed in frame a: `inv(a) @ b`."""
    rel = np.linalg.inv(frame_a) @ frame_b
    return rel[:3, 3].copy(), rel[:3, :3].copy()


def _ties(values: np.ndarray) -> np.ndarray:
    top = values.max()
    return np.flatnonzero(values >= top - _TIE * max(abs(top), 1e-12))


def _frame_from(origin: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> np.ndarray | None:
    x = p2 - p1
    if np.linalg.norm(x) <= 0:
        return None
    x = x / np.linalg.norm(x)
    y = (p3 - p1) - ((p3 - p1) @ x) * x
    if np.linalg.norm(y) <= _TIE * np.linalg.norm(p2 - p1):
        return None
    y /= np.linalg.norm(y)
    F = np.eye(4)
    F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = x, y, np.cross(x, y), origin
    return F


# Bounds of the symmetry search (issue 19: round parts have thousands of tied vertices, and
# walking every tie made a 10k-triangle icosphere take 30 s). At most MAX_TIE_PAIRS (p1, p2)
# tie combinations and MAX_THIRD_TIES third points per pair are tried; each candidate frame is
# verified on at most SYMMETRY_SAMPLE evenly strided vertices, each of which must land within
# SYMMETRY_TOLERANCE x the part's bounding-box diagonal of some vertex (a k-d tree of all of
# them). So a highly symmetric part (a sphere) gets some of its symmetries, not all: enough for
# rigid copies, whose frames correspond anyway (same vertex order).
MAX_TIE_PAIRS = 32
MAX_THIRD_TIES = 32
SYMMETRY_SAMPLE = 512
SYMMETRY_TOLERANCE = 1e-5


def symmetry_offsets(vertices: np.ndarray, faces: np.ndarray | None = None, *,
                     limit: int = 64) -> list[np.ndarray]:
    """Rotations S (4x4, in the part's local frame F) such that F @ S is another frame the
    construction could have picked for the same geometry - i.e. the part's rotational
    symmetries that the tie-breaking hides. Always contains the identity first.

    Candidates come from the ties in the three farthest-point choices (bounded: MAX_TIE_PAIRS,
    MAX_THIRD_TIES); a candidate is kept only if the part's vertex set looks the same in it (a
    true symmetry, checked on a bounded sample: SYMMETRY_SAMPLE, SYMMETRY_TOLERANCE). Cost:
    O(V log V + MAX_TIE_PAIRS x V + candidates x SYMMETRY_SAMPLE log V) on any mesh."""
    from scipy.spatial import cKDTree

    verts = np.asarray(vertices, dtype=np.float64)
    F0 = local_frame(verts, faces)
    if len(verts) < 3:
        return [np.eye(4)]
    origin = F0[:3, 3]
    inv0 = np.linalg.inv(F0)
    size = float(np.linalg.norm(verts.max(axis=0) - verts.min(axis=0))) or 1.0
    tol = SYMMETRY_TOLERANCE * size
    sample = verts[:: max(1, len(verts) // SYMMETRY_SAMPLE)][:SYMMETRY_SAMPLE]
    local = (sample - origin) @ F0[:3, :3]  # the sample in F0's coordinates
    probe = local[:: max(1, len(local) // 16)]
    tree = None

    def same_shape(F: np.ndarray) -> bool:
        # the point with F0-coordinates l maps to the point with F-coordinates l
        nonlocal tree
        if tree is None:
            tree = cKDTree(verts)
        for pts in (probe, local):
            d, _ = tree.query(pts @ F[:3, :3].T + F[:3, 3], distance_upper_bound=tol)
            if not np.isfinite(d).all():
                return False
        return True

    out = [np.eye(4)]
    seen = {(np.round(np.eye(4), 6) + 0.0).tobytes()}
    pairs = 0
    for i1 in _ties(np.linalg.norm(verts - origin, axis=1)):
        p1 = verts[i1]
        for i2 in _ties(np.linalg.norm(verts - p1, axis=1)):
            pairs += 1
            if pairs > MAX_TIE_PAIRS:
                return out
            p2 = verts[i2]
            x = p2 - p1
            if np.linalg.norm(x) <= 0:
                continue
            x = x / np.linalg.norm(x)
            rel = verts - p1
            dist = np.linalg.norm(rel - np.outer(rel @ x, x), axis=1)
            for i3 in _ties(dist)[:MAX_THIRD_TIES]:
                F = _frame_from(origin, p1, p2, verts[i3])
                if F is None:
                    continue
                S = inv0 @ F
                key = (np.round(S, 6) + 0.0).tobytes()  # + 0.0 turns -0.0 into 0.0
                if key in seen:
                    continue
                seen.add(key)
                if same_shape(F):
                    out.append(S)
                    if len(out) >= limit:
                        return out
    return out


def _first_max(values: np.ndarray) -> np.ndarray:
    """Per row, the first index whose value is within the tie tolerance of the row maximum."""
    top = values.max(axis=1, keepdims=True)
    return np.argmax(values >= top - _TIE * np.maximum(np.abs(top), 1e-12), axis=1)


FRAME_CHUNK = 4096


def local_frames(meshes) -> np.ndarray:  # noqa: ANN001
    """`local_frame` of many meshes at once, batched over meshes with equal vertex/face counts
    (rigid copies: the common case); returns (n, 4, 4). Same result as `local_frame`."""
    meshes = list(meshes)
    out = np.tile(np.eye(4), (len(meshes), 1, 1))
    groups: dict[tuple[int, int], list[int]] = {}
    for i, m in enumerate(meshes):
        groups.setdefault((len(m.vertices), len(m.faces)), []).append(i)
    # batches of at most FRAME_CHUNK meshes: the (g, nf, 3, 3) temporaries stay small on 100k parts
    batches = [((nv, nf), idx[k:k + FRAME_CHUNK]) for (nv, nf), idx in groups.items()
               for k in range(0, len(idx), FRAME_CHUNK)]
    for (nv, nf), idx in batches:
        if nv < 3 or nf == 0:
            for i in idx:
                out[i] = local_frame(np.asarray(meshes[i].vertices, dtype=np.float64),
                                     np.asarray(meshes[i].faces))
            continue
        V = np.stack([np.asarray(meshes[i].vertices, dtype=np.float64) for i in idx])  # (g, nv, 3)
        F = np.stack([np.asarray(meshes[i].faces) for i in idx])  # (g, nf, 3)
        g = np.arange(len(idx))[:, None, None]
        tri = V[g, F]  # (g, nf, 3, 3)
        area = np.linalg.norm(np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0]), axis=2)
        wsum = area.sum(axis=1)
        origin = np.where(wsum[:, None] > 0,
                          (area[:, :, None] * tri.mean(axis=2)).sum(axis=1) / np.maximum(wsum, 1e-300)[:, None],
                          V.mean(axis=1))
        rows = np.arange(len(idx))
        p1 = V[rows, _first_max(np.linalg.norm(V - origin[:, None], axis=2))]
        p2 = V[rows, _first_max(np.linalg.norm(V - p1[:, None], axis=2))]
        diag = np.linalg.norm(p2 - p1, axis=1)
        x = (p2 - p1) / np.maximum(diag, 1e-300)[:, None]
        rel = V - p1[:, None]
        off = rel - np.einsum("gv,gk->gvk", np.einsum("gvk,gk->gv", rel, x), x)
        dist = np.linalg.norm(off, axis=2)
        y = off[rows, _first_max(dist)]
        ylen = np.linalg.norm(y, axis=1)
        good = (diag > 0) & (dist.max(axis=1) > _TIE * diag)
        y = y / np.maximum(ylen, 1e-300)[:, None]
        z = np.cross(x, y)
        for r, i in enumerate(idx):
            if not good[r]:  # degenerate: the scalar routine handles the fallbacks
                out[i] = local_frame(np.asarray(meshes[i].vertices, dtype=np.float64), np.asarray(meshes[i].faces))
                continue
            out[i, :3, 0], out[i, :3, 1], out[i, :3, 2], out[i, :3, 3] = x[r], y[r], z[r], origin[r]
    return out


# Symmetries by local-geometry key, kept across calls: a sampler validating thousands of
# variants made of the same few part meshes pays for each symmetry search once per process.
_SYMMETRY_CACHE: dict[bytes, np.ndarray] = {}
_SYMMETRY_CACHE_SIZE = 4096


def symmetry_classes(meshes, frames: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:  # noqa: ANN001
    """For each mesh (with its `local_frames` entry), the index of its symmetry class, and per
    class the (k, 3, 3) rotations `symmetry_offsets` finds. Rigid copies of one mesh share their
    local geometry and so their class: the (costlier) symmetry search runs once per class, and
    the class keys are computed in batches of meshes with equal vertex/face counts."""
    meshes = list(meshes)
    classes: list[np.ndarray] = []
    index: dict[bytes, int] = {}
    out = np.zeros(len(meshes), dtype=np.int64)
    groups: dict[tuple[int, int], list[int]] = {}
    for i, m in enumerate(meshes):
        groups.setdefault((len(m.vertices), len(m.faces)), []).append(i)
    for idx in groups.values():
        V = np.stack([np.asarray(meshes[i].vertices, dtype=np.float64) for i in idx])  # (g, nv, 3)
        F = frames[idx]
        local = np.einsum("gvk,gkj->gvj", V - F[:, None, :3, 3], F[:, :3, :3])
        size = np.linalg.norm(V.max(axis=1) - V.min(axis=1), axis=1)
        size[size <= 0] = 1.0
        keys = np.round(local / (1e-5 * size)[:, None, None]).astype(np.int64)
        for r, i in enumerate(idx):
            faces = np.asarray(meshes[i].faces)
            key = keys[r].tobytes() + faces.tobytes()
            if key not in index:
                index[key] = len(classes)
                syms = _SYMMETRY_CACHE.get(key)
                if syms is None:
                    syms = np.array([S[:3, :3] for S in symmetry_offsets(V[r], faces)])
                    if len(_SYMMETRY_CACHE) >= _SYMMETRY_CACHE_SIZE:  # bounded: drop the oldest
                        _SYMMETRY_CACHE.pop(next(iter(_SYMMETRY_CACHE)))
                    _SYMMETRY_CACHE[key] = syms
                classes.append(syms)
            out[i] = index[key]
    return out, classes
