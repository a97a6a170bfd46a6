"""Which parts of an assembly touch: a broad phase over bounding boxes, then an exact-enough test.

Definition (Kalojanov 2019 section 3: "pieces are neighbours iff their surfaces intersect"):
two parts are in contact when the distance between their surfaces is at most `tolerance`,
or one lies inside the other. The default tolerance is `DEFAULT_RELATIVE_TOLERANCE` times the
assembly's bounding-box diagonal, so the same model at another scale gives the same graph.

Why three narrow phases:
- *box parts* (the mesh is exactly its axis-aligned bounding box: every vertex a box corner,
  every triangle on a box face, each face covered once with outward orientation) are decided by
  the box-box distance, which is then exact; this is vectorised over all candidate pairs and is
  what keeps 1,000-10,000 box models fast;
- closed (watertight, manifold) parts use manifold3d's `min_gap`, an exact surface distance
  that also returns 0 when one solid contains the other;
- open or non-manifold parts (real scans are like that) fall back to vertex-to-surface
  distances both ways plus edge-through-triangle crossings, measured on the triangles near
  the other part only. This can miss a pure edge-edge graze that touches no vertex.

The broad phase is an rtree (R*-tree, bulk loaded) queried with all boxes at once
(`intersection_v`), so candidate generation is O(n log n + k) instead of all n^2 pairs;
`candidate_pairs_bruteforce` is the quadratic reference the tests and benchmark compare with.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import trimesh

from .assembly import Assembly, Part

__all__ = [
    "DEFAULT_RELATIVE_TOLERANCE", "Contact", "PartGeometry", "PoseKeys", "candidate_pairs", "contact_arrays",
    "candidate_pairs_bruteforce", "contacts", "default_tolerance", "prepare",
]

# Fraction of the model's bounding-box diagonal below which two surfaces count as touching.
DEFAULT_RELATIVE_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Contact:
    a: int  # index into assembly.parts, a < b
    b: int
    gap: float  # surface distance (0 when touching, intersecting or nested), <= tolerance
    depth: float | None = None  # box parts only: how far the boxes interpenetrate (0 if they just touch)
    kind: str = "touch"  # "touch" (surfaces meet within tolerance) or "overlap" (interpenetrate deeper)


@dataclass
class PartGeometry:
    """Per-part data computed once, vectorised over the assembly."""

    lo: np.ndarray  # (n, 3) bounding-box minimum
    hi: np.ndarray  # (n, 3)
    centroid: np.ndarray  # (n, 3) area-weighted surface centroid (moves rigidly with the part)
    boxy: np.ndarray  # (n,) bool: the mesh is exactly its bounding box
    _manifolds: dict = field(default_factory=dict)
    _triangle_boxes: dict = field(default_factory=dict)  # part index -> (triangle lo, hi), for _apart

    # The solids `contacts()` builds lazily (local part index -> manifold3d.Manifold, or None
    # for a part whose mesh is not a closed manifold). Back ends that measure the same placed
    # part many times (grammarkit.tiling.incremental.PartCache) share them across calls.
    def known_solids(self) -> dict[int, object]:
        """The solids built so far, by local part index (a copy; None: not a closed manifold)."""
        return dict(self._manifolds)

    def seed_solids(self, solids: dict[int, object]) -> None:
        """Pre-fill solids by local part index, so `contacts()` does not rebuild them. Each must
        be the manifold3d solid of that part's mesh (or None if it is not a closed manifold)."""
        self._manifolds.update(solids)


def check_tolerance(tolerance: object, where: str = "tolerance") -> float | None:
    """A user's contact tolerance as a float (None: the default), or a ShapeError: NaN would
    silently make every part lonely (no distance is <= NaN), a negative one likewise."""
    import math
    import numbers

    from ..errors import ShapeError

    if tolerance is None:
        return None
    if isinstance(tolerance, bool) or not isinstance(tolerance, numbers.Real):
        raise ShapeError(f"{where}: the contact tolerance must be a number, got {tolerance!r}")
    t = float(tolerance)
    if not (math.isfinite(t) and t >= 0):
        raise ShapeError(f"{where}: the contact tolerance must be a finite number >= 0, got {tolerance!r}")
    return t


def default_tolerance(assembly: Assembly | PartGeometry) -> float:
    """`DEFAULT_RELATIVE_TOLERANCE` x the bounding-box diagonal of all parts."""
    if len(assembly.lo if isinstance(assembly, PartGeometry) else assembly.parts) == 0:
        return DEFAULT_RELATIVE_TOLERANCE
    if isinstance(assembly, PartGeometry):
        lo, hi = assembly.lo.min(axis=0), assembly.hi.max(axis=0)
    else:
        lo, hi = assembly.bounds
    scale = float(np.linalg.norm(hi - lo))
    return DEFAULT_RELATIVE_TOLERANCE * (scale if scale > 0 else 1.0)


PREPARE_CHUNK = 4096  # parts per vectorised pass of `prepare` (bounded temporaries on 100k parts)


def prepare(parts: Sequence[Part]) -> PartGeometry:
    """Bounds, centroids and box flags of all parts in a few numpy passes per chunk of
    PREPARE_CHUNK parts (the per-triangle temporaries of 100,000 parts at once peaked at 400 MB)."""
    n = len(parts)
    if n == 0:
        z = np.zeros((0, 3))
        return PartGeometry(z, z, z, np.zeros(0, bool))
    if n > PREPARE_CHUNK:
        chunks = [_prepare(parts[k:k + PREPARE_CHUNK]) for k in range(0, n, PREPARE_CHUNK)]
        return PartGeometry(np.concatenate([c.lo for c in chunks]), np.concatenate([c.hi for c in chunks]),
                            np.concatenate([c.centroid for c in chunks]),
                            np.concatenate([c.boxy for c in chunks]))
    return _prepare(parts)


def _prepare(parts: Sequence[Part]) -> PartGeometry:
    n = len(parts)
    verts = [np.asarray(p.mesh.vertices, dtype=np.float64) for p in parts]
    faces = [np.asarray(p.mesh.faces, dtype=np.int64) for p in parts]
    nv = np.array([len(v) for v in verts])
    nf = np.array([len(f) for f in faces])
    V = np.concatenate(verts) if n else np.zeros((0, 3))
    voff = np.concatenate([[0], np.cumsum(nv)[:-1]])
    F = np.concatenate([f + o for f, o in zip(faces, voff)])
    vpart = np.repeat(np.arange(n), nv)
    fpart = np.repeat(np.arange(n), nf)

    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    has = nv > 0  # parts are contiguous runs of V: reduceat (ufunc.at is ten times slower)
    if has.all():
        lo, hi = np.minimum.reduceat(V, voff, axis=0), np.maximum.reduceat(V, voff, axis=0)
    else:
        np.minimum.at(lo, vpart, V)
        np.maximum.at(hi, vpart, V)

    tri = V[F]  # (m, 3, 3)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)  # twice the triangle area
    centre = tri.mean(axis=1)
    wsum = np.bincount(fpart, weights=area2, minlength=n)
    centroid = np.stack([np.bincount(fpart, weights=area2 * centre[:, k], minlength=n)
                         for k in range(3)], axis=1)
    ok = wsum > 0
    centroid[ok] /= wsum[ok, None]
    centroid[~ok] = (lo[~ok] + hi[~ok]) / 2

    boxy = _box_flags(V, F, vpart, fpart, lo, hi, cross, n)
    return PartGeometry(lo, hi, centroid, boxy)


def _box_flags(V, F, vpart, fpart, lo, hi, cross, n) -> np.ndarray:  # noqa: ANN001
    """True where a part's mesh is exactly its bounding box (see the module docstring)."""
    ext = hi - lo
    eps = 1e-9 * np.maximum(np.linalg.norm(ext, axis=1), 1e-12)
    # every vertex at a corner: each coordinate equals lo or hi of its part
    dlo = np.abs(V - lo[vpart])
    dhi = np.abs(V - hi[vpart])
    corner = ((dlo <= eps[vpart, None]) | (dhi <= eps[vpart, None])).all(axis=1)
    flags = np.bincount(vpart, weights=~corner, minlength=n) == 0
    flags &= (ext > eps[:, None]).all(axis=1)  # a flat box is not a solid box
    # every triangle on one box face, and per face: signed area equals the face area
    tri_lo = dlo[F] <= eps[fpart, None, None]  # (m, 3 verts, 3 axes)
    tri_hi = dhi[F] <= eps[fpart, None, None]
    on_lo = tri_lo.all(axis=1)  # (m, 3): triangle lies in plane coord=lo on that axis
    on_hi = tri_hi.all(axis=1)
    on_any = (on_lo | on_hi).any(axis=1)
    flags &= np.bincount(fpart, weights=~on_any, minlength=n) == 0
    for axis in range(3):
        face_area = np.prod(np.delete(ext, axis, axis=1), axis=1)
        for sign, on in ((-1.0, on_lo[:, axis]), (1.0, on_hi[:, axis])):
            signed = np.bincount(fpart, weights=np.where(on, sign * cross[:, axis] / 2, 0.0), minlength=n)
            flags &= np.abs(signed - face_area) <= 1e-6 * np.maximum(face_area, 1e-12)
    return flags


def candidate_pairs(geom: PartGeometry, tolerance: float) -> np.ndarray:
    """(k, 2) index pairs i < j whose bounding boxes, grown by `tolerance`, overlap (rtree)."""
    n = len(geom.lo)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    from rtree import index

    props = index.Property()
    props.dimension = 3
    lo, hi = geom.lo, geom.hi
    # bulk loading from numpy arrays builds a packed tree without a Python loop (a stream of
    # n tuples took 0.5 s at 100k parts, the arrays take a few hundredths)
    arrays = (np.arange(n, dtype=np.int64), np.ascontiguousarray(lo, dtype=np.float64),
              np.ascontiguousarray(hi, dtype=np.float64))
    idx = index.Index(arrays, properties=props)
    ids, counts = idx.intersection_v(lo - tolerance, hi + tolerance)
    src = np.repeat(np.arange(n), np.asarray(counts, dtype=np.int64))
    ids = np.asarray(ids, dtype=np.int64)
    keep = src < ids
    return np.stack([src[keep], ids[keep]], axis=1)


def candidate_pairs_bruteforce(geom: PartGeometry, tolerance: float) -> np.ndarray:
    """The O(n^2) reference for `candidate_pairs` (tests, benchmark baseline)."""
    n = len(geom.lo)
    i, j = np.triu_indices(n, 1)
    sep = np.maximum(geom.lo[i] - geom.hi[j], geom.lo[j] - geom.hi[i]).max(axis=1)
    keep = sep <= tolerance
    return np.stack([i[keep], j[keep]], axis=1)


def contacts(assembly: Assembly | Sequence[Part], tolerance: float | None = None, *,
             geom: PartGeometry | None = None, pairs: np.ndarray | None = None,
             poses: "PoseKeys | None" = None, measured: dict | None = None) -> list[Contact]:
    """All touching part pairs, sorted by (a, b). `poses`/`measured`: see `contact_arrays`."""
    parts = assembly.parts if isinstance(assembly, Assembly) else list(assembly)
    geom = geom or prepare(parts)
    if tolerance is None:
        tolerance = default_tolerance(geom)
    a, b, gap, depth = contact_arrays(parts, tolerance, geom=geom, pairs=pairs, poses=poses,
                                      measured=measured)
    return [Contact(x, y, g, None if d < 0 else d, "touch" if d < 0 or d <= tolerance else "overlap")
            for x, y, g, d in zip(a.tolist(), b.tolist(), gap.tolist(), depth.tolist())]


def contact_arrays(parts: Sequence[Part], tolerance: float, *, geom: PartGeometry,
                   pairs: np.ndarray | None = None, poses: "PoseKeys | None" = None,
                   measured: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`contacts` as arrays sorted by (a, b): a, b (int), gap, depth (box pairs: how far the
    boxes interpenetrate; -1 for other pairs). No object per contact: 150,000 contacts of a
    100k-part model cost a few numpy operations. `poses` (default: from the meshes) keys the
    congruent pairs; `measured` (pose key -> gap, at this tolerance) keeps their gaps across
    calls (incremental.PartCache)."""
    if pairs is None:
        pairs = candidate_pairs(geom, tolerance)
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))
    if len(pairs) == 0:
        return empty
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    i, j = pairs[:, 0], pairs[:, 1]
    # box-box: gap = largest per-axis separation (negative = overlap depth along the
    # shallowest axis); for two solid boxes the distance is the norm of the positive separations
    sep = np.maximum(geom.lo[i] - geom.hi[j], geom.lo[j] - geom.hi[i])
    box_dist = np.linalg.norm(np.maximum(sep, 0.0), axis=1)
    both_boxy = geom.boxy[i] & geom.boxy[j]
    depth = np.maximum(0.0, -sep.max(axis=1))
    keep = both_boxy & (box_dist <= tolerance)
    gaps = np.where(both_boxy, box_dist, np.inf)
    depth = np.where(both_boxy, depth, -1.0)
    poses = poses if poses is not None else PoseKeys(parts, tolerance)
    # rigid copies in the same relative pose have the same gap: measure once
    measured = {} if measured is None else measured
    for k in np.flatnonzero(~both_boxy).tolist():
        a, b = int(i[k]), int(j[k])
        key = poses.pair(a, b)
        gap = measured.get(key) if key is not None else None
        if gap is None:
            gap = math.inf if _apart(parts, a, b, geom, tolerance) else \
                _surface_gap(parts[a], parts[b], a, b, geom, tolerance)
            if key is not None:
                measured[key] = gap
        if gap <= tolerance:
            keep[k] = True
            gaps[k] = float(gap)
    return i[keep], j[keep], gaps[keep], depth[keep]


class PoseKeys:
    """Keys under which two parts' relative configuration repeats: per part, its mesh in its
    node frame (`Part.transform`; rigid copies of one mesh share it) hashed after rounding to a
    tenth of the tolerance; per pair, both of those plus b's pose in a's frame (rounded alike).
    Equal keys mean congruent pairs (same gap, same contact), so the exact narrow phase runs
    once per key. `with_up=True` adds a's rotation (for tests that depend on gravity). None
    where a part's transform is not rigid (world-baked meshes with odd transforms)."""

    def __init__(self, parts: Sequence[Part], tolerance: float):
        self.parts = parts
        self.q = max(float(tolerance) / 10.0, 1e-12)
        self._geo: dict[int, tuple | None] = {}

    @classmethod
    def of_placements(cls, keys: Sequence[tuple], tolerance: float) -> "PoseKeys":
        """Keys for parts known as (source, rigid placement bytes) (`incremental.part_key`):
        a part's geometry is its source's, so no mesh is hashed."""
        out = cls((), tolerance)
        for i, (source, matrix) in enumerate(keys):
            out._geo[i] = (("source", source), 0, 0, np.frombuffer(matrix, dtype=np.float64).reshape(4, 4))
        return out

    def part(self, i: int) -> tuple | None:
        if i not in self._geo:
            p = self.parts[i]
            T = np.asarray(getattr(p, "transform", None) if getattr(p, "transform", None) is not None
                           else np.eye(4), dtype=np.float64)
            R = T[:3, :3] if T.shape == (4, 4) else None
            if R is None or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
                self._geo[i] = None
            else:
                V = (np.asarray(p.mesh.vertices, dtype=np.float64) - T[:3, 3]) @ R
                self._geo[i] = (hash(np.round(V / self.q).astype(np.int64).tobytes()),
                                hash(np.asarray(p.mesh.faces).tobytes()), len(V), T)
        return self._geo[i]

    def pair(self, a: int, b: int, *, with_up: bool = False) -> tuple | None:
        ga, gb = self.part(a), self.part(b)
        if ga is None or gb is None:
            return None
        Ta, Tb = ga[3], gb[3]
        rel = np.linalg.inv(Ta) @ Tb
        key = (ga[:3], gb[:3], (np.round(rel[:3, :3], 6) + 0.0).tobytes(),
               np.round(rel[:3, 3] / self.q).astype(np.int64).tobytes())
        if with_up:
            key += ((np.round(Ta[:3, :3], 6) + 0.0).tobytes(),)
        return key


def _triangle_boxes(part: Part, key: int, geom: PartGeometry) -> tuple[np.ndarray, np.ndarray]:
    cached = geom._triangle_boxes.get(key)
    if cached is None:
        tri = np.asarray(part.mesh.vertices, dtype=np.float64)[np.asarray(part.mesh.faces)]
        cached = (tri.min(axis=1), tri.max(axis=1))
        geom._triangle_boxes[key] = cached
    return cached


def _apart(parts: Sequence[Part], a: int, b: int, geom: PartGeometry, tolerance: float) -> bool:
    """True when the two surfaces are certainly further apart than `tolerance`, by a cheap
    test: two points within the tolerance lie in the boxes' intersection grown by it, so each
    surface must have a triangle whose box meets that region. Not used when one bounding box
    contains the other (nesting counts as contact, with no surfaces near each other). Finely
    tessellated parts whose boxes merely graze (diagonal neighbours) skip the exact test."""
    la, ha, lb, hb = geom.lo[a], geom.hi[a], geom.lo[b], geom.hi[b]
    if ((la <= lb) & (hb <= ha)).all() or ((lb <= la) & (ha <= hb)).all():
        return False
    rlo = np.maximum(la, lb) - tolerance
    rhi = np.minimum(ha, hb) + tolerance
    for k, part in ((a, parts[a]), (b, parts[b])):
        tlo, thi = _triangle_boxes(part, k, geom)
        if not ((tlo <= rhi) & (thi >= rlo)).all(axis=1).any():
            return True
    return False


def _manifold(part: Part, key: int, geom: PartGeometry):  # noqa: ANN202
    """The part as a manifold3d solid, or None if its mesh is not a closed manifold."""
    if key in geom._manifolds:
        return geom._manifolds[key]
    solid = solid_of(part.mesh)
    geom._manifolds[key] = solid
    return solid


def solid_of(mesh: trimesh.Trimesh):  # noqa: ANN201
    """The mesh as a manifold3d solid, or None if it is not a closed manifold."""
    import manifold3d

    if len(mesh.faces) and np.isfinite(mesh.vertices).all():
        m = manifold3d.Mesh(vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float32),
                            tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint32))
        m.merge()
        cand = manifold3d.Manifold(m)
        if cand.status() == manifold3d.Error.NoError and not cand.is_empty():
            return cand
    return None


def lifted_gap(pa: Part, pb: Part, tolerance: float, delta: np.ndarray, solids: dict | None = None,
               ka: object = None, kb: object = None) -> float:
    """Surface distance between `pa` and `pb` moved by `delta` (capped a little above the
    tolerance), with the narrow phase `contacts` uses. `solids` caches manifold3d solids by the
    keys `ka`/`kb` (support.carry_directions: one solid per part per call)."""
    def solid(key: object, part: Part):  # noqa: ANN202
        if solids is None or key is None:
            return solid_of(part.mesh)
        if key not in solids:
            solids[key] = solid_of(part.mesh)
        return solids[key]

    sa, sb = solid(ka, pa), solid(kb, pb)
    search = 2.0 * tolerance + 1e-12
    if sa is not None and sb is not None:
        both = np.concatenate([np.asarray(pa.mesh.bounds), np.asarray(pb.mesh.bounds)])
        slack = 4e-7 * float(np.abs(both).max() + np.abs(delta).max())
        gap = float(sb.translate(tuple(float(x) for x in delta)).min_gap(sa, search + slack))
        return max(0.0, gap - slack)
    mb = trimesh.Trimesh(np.asarray(pb.mesh.vertices) + delta, np.asarray(pb.mesh.faces), process=False)
    moved = Part(pb.id, pb.type, mb)
    geom = prepare([pa, moved])
    return _open_gap(pa.mesh, mb, geom, 0, 1, tolerance, search)


def _surface_gap(pa: Part, pb: Part, a: int, b: int, geom: PartGeometry, tolerance: float) -> float:
    """Distance between two parts' surfaces, capped a little above `tolerance`."""
    sa, sb = _manifold(pa, a, geom), _manifold(pb, b, geom)
    search = 2.0 * tolerance + 1e-12
    if sa is not None and sb is not None:
        # float32 meshes: allow the rounding of coordinates of this magnitude
        slack = 4e-7 * float(np.abs(np.concatenate([geom.hi[[a, b]], geom.lo[[a, b]]])).max())
        gap = float(sa.min_gap(sb, search + slack))
        return max(0.0, gap - slack)
    return _open_gap(pa.mesh, pb.mesh, geom, a, b, tolerance, search)


def _open_gap(ma: trimesh.Trimesh, mb: trimesh.Trimesh, geom: PartGeometry, a: int, b: int,
              tolerance: float, search: float) -> float:
    """Fallback for open meshes: vertex-surface distances both ways and edge crossings."""
    lo = np.maximum(geom.lo[a], geom.lo[b]) - search
    hi = np.minimum(geom.hi[a], geom.hi[b]) + search
    best = search
    for m1, m2 in ((ma, mb), (mb, ma)):
        v = np.asarray(m1.vertices)
        near = v[((v >= lo) & (v <= hi)).all(axis=1)]
        if len(near) and len(m2.faces):
            _, dist, _ = trimesh.proximity.closest_point(m2, near)
            best = min(best, float(dist.min()))
            if best <= tolerance:
                return best
    for m1, m2 in ((ma, mb), (mb, ma)):
        edges = np.asarray(m1.vertices)[m1.edges_unique]
        if not len(edges) or not len(m2.faces):
            continue
        # edges whose own bounding box meets the overlap region (an edge may cross it with
        # both end points far outside, as when two thin plates intersect crosswise)
        inside = ((edges.min(axis=1) <= hi) & (edges.max(axis=1) >= lo)).all(axis=1)
        edges = edges[inside]
        if not len(edges):
            continue
        d = edges[:, 1] - edges[:, 0]
        length = np.linalg.norm(d, axis=1)
        ok = length > 0
        if not ok.any():
            continue
        locs, ray_idx, _ = m2.ray.intersects_location(edges[ok, 0], d[ok] / length[ok, None],
                                                      multiple_hits=False)
        if len(locs):
            t = np.linalg.norm(locs - edges[ok, 0][ray_idx], axis=1)
            if (t <= length[ok][ray_idx] + tolerance).any():
                return 0.0
    return best
