"""Offset statistics and principal offsets (Wu et al., sections III-A, IV and V).

1. Every feature x is matched to the feature x + v whose SHOT descriptor is nearest (L2), among
   those with |v| > tau (0.15): Eq. (1) (with the tie rule below).
2. The offsets are binned in a 3D histogram with cubic bins of 0.05; its peaks after
   non-maximum suppression with radius 0.15 are the dominant offsets (at most 20).
3. Each dominant offset is refined by ICP over the whole dense cloud (translation only,
   point-to-plane), from the mean of the offsets in its bin and the adjacent bins.
4. Principal offsets, greedily in decreasing count: v1 the strongest; each next one makes an
   angle of at least 60 degrees with those taken (|cos| <= cos(pi/3)); at most 3.
   Missing directions get dummy generators of length 0.2, orthogonal to the others, along
   which the model is never retargeted. The chosen offsets are finally snapped by
   point-to-point ICP on the mesh vertices (exact where the mesh repeats exactly, which the
   stitching relies on).

Checks not in the paper (see `OffsetParams`; each can be switched off): a peak needs a share
of the strongest peak's count; a principal offset must map part of the surface onto the
surface (`self_overlap`), else a sphere would have principal offsets; and it must map the
faces that face it, on both sides (`self_overlap(facing=True)`), else a sliding symmetry (a
picket sliding along its own length) or a coincidence (the top of one rail landing on the top
of another) would count as a repetition.

The best match is the paper's Eq. (1) exactly (`tie_ratio=1.0`, the default). In a row of n
identical pickets every other picket matches a picket feature equally well up to sampling
noise, so the strict argmin spreads the matches over v, 2v, 3v, ... and the histogram peak
may be any multiple; and matches closer than tau (0.15, 7.5% of the longest side) are never
made, so in a row of more than ~13 elements every match is a multiple. Both are repaired after
the selection (`fundamental=True`, not in the paper): each principal offset is replaced by its
shortest divisor v/k that is a repetition as well (`fundamental_offset`). The project's
earlier repair, the tie rule (`tie_ratio=1.5`: the *nearest* of the matches within 1.5x of
the best descriptor distance), stays available and measured (benchmarks/bench_retarget.py):
on a facade whose storeys are taller than its windows it gathered the votes at a window-sized
offset instead of the storey.

The sparsity statistic of section IV (share of offsets in the fullest 7% and 20% of the
non-empty bins) is reported in `Offsets.sparsity`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from .features import FeatureCloud, Frame, SamplingParams, build_cloud
from .surface import SurfaceDistance

__all__ = ["OffsetParams", "Offsets", "principal_offsets", "find_offsets", "sparsity"]


@dataclass(frozen=True)
class OffsetParams:
    """The paper's parameters (normalised units) and this implementation's few extras.

    tau: minimum offset length of a match (0.15). bin: histogram bin edge (0.05).
    nms_radius: non-maximum suppression radius (0.15). max_dominant: dominant offsets kept (20).
    min_angle: minimum angle between principal offsets, degrees (60). max_principal: 3.
    dummy_length: length of a dummy generator (0.2).
    min_count / min_share: a dominant offset needs at least this many matches, and at least
        `min_share` of the matches in the strongest bin (drops one-off noise peaks, e.g. the
        two rails of the fence, 11% of the pickets' count).
    min_overlap: a principal offset must map at least this share of the surface onto the
        surface (`self_overlap`); below it, the peak came from features that only look alike
        (measured: 0.0-0.002 on a sphere, torus and capsule; 0.33-0.87 for the repetitions of
        the test models and the sliding symmetries of a box).
        min_count, min_share and min_overlap are not in the paper (which takes every peak).
    icp_iterations / icp_radius: translation-only point-to-plane ICP.
    tie_ratio: matches whose descriptor distance is within this factor of the best one count
        as equally good, and the shortest offset among them is taken (see module); 1.0 (the
        default) is Eq. (1) exactly; 1.5 is the project's earlier tie rule.
    min_facing_overlap: a principal offset must map at least this share of the faces facing
        it, on each side (+v and -v), onto the surface (not in the paper; 0 switches it off;
        measured: 0.28-0.78 for the repetitions of the test models, 0.0 for their sliding
        symmetries and coincidences).
    fundamental: replace each principal offset by its shortest divisor that is a repetition
        as well (`fundamental_offset`; not in the paper, which keeps the multiple).
        The paper's choice: tie_ratio=1.0, min_count=1, min_share=0, min_overlap=0,
        min_facing_overlap=0, fundamental=False.
    """

    tau: float = 0.15
    bin: float = 0.05
    nms_radius: float = 0.15
    max_dominant: int = 20
    min_angle: float = 60.0
    max_principal: int = 3
    dummy_length: float = 0.2
    min_count: int = 3
    min_share: float = 0.2
    min_overlap: float = 0.1
    icp_iterations: int = 30
    icp_radius: float = 0.05
    tie_ratio: float = 1.0  # 1.0: Eq. (1), the strict argmin; 1.5: the old tie rule
    min_facing_overlap: float = 0.1
    fundamental: bool = True


@dataclass
class Offsets:
    """What `principal_offsets` found. World units unless the name says normalised.

    generators: (3, 3) rows: the principal offsets first (strongest first), then dummies.
    structured: (3,) bool: a real principal offset (True) or a dummy generator (False).
    counts:     (3,) histogram count of each generator's peak (0 for dummies).
    dominant:   (K, 3) the dominant offsets after ICP, strongest first; dominant_counts (K,).
    sparsity:   {"top7": share of offsets in the fullest 7% of non-empty bins, "top20": ...,
                 "bins": non-empty bins, "offsets": matched features}.
    frame:      the normalisation (x_n = (x - center) * scale).
    """

    generators: np.ndarray
    structured: np.ndarray
    counts: np.ndarray
    dominant: np.ndarray
    dominant_counts: np.ndarray
    sparsity: dict
    frame: Frame
    params: OffsetParams = field(default_factory=OffsetParams)
    stats: dict = field(default_factory=dict)
    cloud: FeatureCloud | None = field(default=None, repr=False)
    matches: np.ndarray | None = field(default=None, repr=False)  # (F,) matched feature or -1
    match_offsets: np.ndarray | None = field(default=None, repr=False)  # (F, 3) normalised

    @property
    def principal(self) -> list[np.ndarray]:
        """The real principal offsets (world units), strongest first."""
        return [g for g, s in zip(self.generators, self.structured) if s]

    @property
    def generators_normalised(self) -> np.ndarray:
        return self.generators * self.frame.scale

    def __len__(self) -> int:
        return int(self.structured.sum())

    def summary(self) -> dict:
        return {"principal": [np.round(g, 6).tolist() for g in self.principal],
                "counts": [int(c) for c, s in zip(self.counts, self.structured) if s],
                "dominant": len(self.dominant),
                "sparsity": {k: (round(v, 4) if isinstance(v, float) else v)
                             for k, v in self.sparsity.items()},
                **{k: v for k, v in self.stats.items() if not k.startswith("_")}}


# ------------------------------------------------------------------------------------------
# Matching
# ------------------------------------------------------------------------------------------
def best_matches(points: np.ndarray, descriptors: np.ndarray, tau: float,
                 tie_ratio: float = 1.0, chunk: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """For every feature, the index of its best match with |offset| > tau (Eq. 1), or -1.

    Brute force over descriptor space in row chunks (352-D: a k-d tree does not help), squared
    L2 distances by one matrix product per chunk. Returns (match index, squared distance)."""
    desc = np.asarray(descriptors, dtype=np.float32)
    n = len(desc)
    match = np.full(n, -1, dtype=np.int64)
    best = np.full(n, np.inf, dtype=np.float64)
    valid = np.linalg.norm(desc, axis=1) > 0
    sq = (desc * desc).sum(1)
    pts = np.asarray(points, dtype=np.float64)
    cols = np.flatnonzero(valid)
    if len(cols) < 2:
        return match, best
    dc, pc, sqc = desc[cols], pts[cols], sq[cols]
    for start in range(0, n, chunk):
        rows = np.arange(start, min(n, start + chunk))
        rows = rows[valid[rows]]
        if len(rows) == 0:
            continue
        d2 = sq[rows, None] + sqc[None, :] - 2.0 * (desc[rows] @ dc.T)
        np.maximum(d2, 0.0, out=d2)
        spatial = np.linalg.norm(pts[rows, None, :] - pc[None, :, :], axis=2)
        d2[spatial <= tau] = np.inf
        dmin = d2.min(axis=1)
        ok = np.isfinite(dmin)
        # among (near-)equal best matches take the nearest one
        tie = np.sqrt(d2) <= (np.sqrt(dmin)[:, None] * tie_ratio + 1e-6)
        spatial_t = np.where(tie, spatial, np.inf)
        j = spatial_t.argmin(axis=1)
        match[rows[ok]] = cols[j[ok]]
        best[rows[ok]] = dmin[ok]
    return match, best


# ------------------------------------------------------------------------------------------
# Histogram, peaks, sparsity
# ------------------------------------------------------------------------------------------
def histogram(offsets: np.ndarray, bin_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Non-empty bins of the 3D offset histogram: (integer bin keys (B,3), counts (B,),
    bin index of every offset (N,))."""
    keys = np.floor(offsets / bin_size).astype(np.int64)
    uniq, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return uniq, counts, inverse.reshape(-1)


def sparsity(counts: np.ndarray, shares=(0.07, 0.20)) -> dict:
    """Share of all offsets that fall in the fullest `share` of the non-empty bins (section IV:
    79.9% in 7% and 97.1% in 20% for man-made models, 40.4% in 7% for natural ones)."""
    c = np.sort(np.asarray(counts))[::-1]
    total = float(c.sum())
    out = {"bins": int(len(c)), "offsets": int(total)}
    for s in shares:
        k = max(1, int(math.ceil(s * len(c))))
        out[f"top{round(s * 100)}"] = float(c[:k].sum() / total) if total else 0.0
    return out


def peaks(keys: np.ndarray, counts: np.ndarray, bin_size: float, radius: float,
          max_peaks: int) -> list[int]:
    """Greedy non-maximum suppression: bins in decreasing count (ties by key, for
    determinism); a bin is a peak unless a stronger peak's centre is within `radius`."""
    order = np.lexsort((keys[:, 2], keys[:, 1], keys[:, 0], -counts))
    centres = (keys + 0.5) * bin_size
    taken: list[int] = []
    for b in order:
        if taken:
            d = np.linalg.norm(centres[taken] - centres[b], axis=1)
            if (d <= radius + 1e-9).any():
                continue
        taken.append(int(b))
        if len(taken) >= max_peaks:
            break
    return taken


# ------------------------------------------------------------------------------------------
# ICP over the dense cloud
# ------------------------------------------------------------------------------------------
class SelfAlignment:
    """Translation-only ICP of the dense cloud onto itself."""

    def __init__(self, points: np.ndarray, normals: np.ndarray, spacing: float,
                 max_moving: int = 4000):
        self.points = points
        self.normals = normals
        self.tree = cKDTree(points)
        self.spacing = spacing
        # the moving cloud: an even subset (every k-th sample) when the cloud is large
        step = max(1, int(np.ceil(len(points) / max_moving)))
        self.moving = np.arange(0, len(points), step)

    def _pairs(self, t: np.ndarray, radius: float, moving: np.ndarray | None = None):
        i = self.moving if moving is None else moving
        dist, j = self.tree.query(self.points[i] + t, distance_upper_bound=radius)
        ok = np.isfinite(dist)
        i = i[ok]
        j = j[ok]
        agree = np.einsum("ij,ij->i", self.normals[i], self.normals[j]) > 0.9
        return i[agree], j[agree]

    def snap_to_vertices(self, t: np.ndarray, vertices: np.ndarray, tree: cKDTree,
                         min_share: float = 0.05, k: int = 8) -> np.ndarray:
        """The vertex displacement near `t` that the most vertex pairs share: where the mesh
        repeats exactly, its vertices land on vertices and the offset becomes exact to
        rounding; on curved surfaces the point-to-plane fit on samples is biased by the
        curvature between a sample and its neighbour (~1e-4 here). Every vertex is paired
        with its `k` nearest vertices within two sample spacings of v + t, and the most
        frequent displacement (to 1e-7) wins, averaged over the pairs that share it. (The
        mean over all pairs, with a shrinking radius, was pulled off by pairs with a
        neighbouring feature: a storey offset of 9.0 became 8.95 on a facade whose sills
        are 0.05 tall.) Kept only when at least `min_share` of the vertices (and at least
        8) share it, so a mesh whose copies are tessellated differently keeps the
        point-to-plane result."""
        t = np.asarray(t, dtype=np.float64).copy()
        need = max(8, int(min_share * len(vertices)))
        dist, j = tree.query(vertices + t, k=min(k, len(vertices)),
                             distance_upper_bound=2.0 * self.spacing)
        dist, j = np.atleast_2d(dist.T).T, np.atleast_2d(j.T).T
        ok = np.isfinite(dist)
        if ok.sum() < need:
            return t
        rows = np.nonzero(ok)[0]
        disp = vertices[j[ok]] - vertices[rows]
        keys, inverse, counts = np.unique(np.round(disp / 1e-7).astype(np.int64), axis=0,
                                          return_inverse=True, return_counts=True)
        best = int(np.argmax(counts))
        inverse = np.asarray(inverse).reshape(-1)
        if len(np.unique(rows[inverse == best])) < need:
            return t
        return disp[inverse == best].mean(axis=0)

    def refine(self, t0: np.ndarray, iterations: int = 30, radius: float = 0.05) -> np.ndarray:
        """Point-to-plane: minimise sum (n_q . (p + t - q))^2 over nearest pairs with agreeing
        normals. Pairs whose plane distance exceeds a threshold are dropped, and the threshold
        halves from `radius` down to 1e-6 once the estimate settles (so pairs with a
        neighbouring feature, e.g. the next window's reveal, stop pulling the estimate); a
        small damping keeps directions the pairs do not constrain in place."""
        t = np.asarray(t0, dtype=np.float64).copy()
        threshold = radius
        search = max(radius, 1.5 * self.spacing)
        while threshold > 1e-6:
            for _ in range(iterations):
                i, j = self._pairs(t, search)
                n = self.normals[j]
                r = np.einsum("ij,ij->i", self.points[i] + t - self.points[j], n)
                keep = np.abs(r) <= threshold
                if keep.sum() < 6:
                    return t
                n, r = n[keep], r[keep]
                A = n.T @ n + 1e-6 * len(r) * np.eye(3)
                dt = -np.linalg.solve(A, n.T @ r)
                t += dt
                if np.linalg.norm(dt) < 0.1 * threshold:
                    break
            threshold *= 0.5
            search = max(min(search, 4 * threshold), 1.5 * self.spacing)
        return t


def self_overlap(distance: SurfaceDistance, cloud: FeatureCloud, v: np.ndarray,
                 max_points: int = 3000, facing: bool = False) -> float:
    """Share of the dense samples that a translation by v puts (back) on the surface, within
    1e-3 of the sample spacing: how much of the model v maps onto itself. A real repetition
    (or a flat face sliding along itself) scores high; a best match that only looked similar
    (a sphere's neighbouring points) scores about zero.

    facing=True counts only the samples on faces that face the translation (|n . v| >= half
    |v|), the faces facing +v and those facing -v separately, and returns the smaller share:
    faces parallel to v slide along themselves under any small or wrong translation, so only
    the facing ones tell a repetition (the rungs of a ladder, the sides of pickets) from a
    sliding symmetry (its stiles); and a repeated element maps both its +v and its -v faces,
    where a coincidence (the top of one rail landing on the top of another) maps one side
    only. NaN when no sample faces v."""
    if not facing:
        return _overlap_of(distance, cloud, np.arange(len(cloud.dense)), v, max_points)
    u = np.asarray(v, dtype=np.float64) / max(float(np.linalg.norm(v)), 1e-300)
    along = cloud.dense_normals @ u
    sides = [np.flatnonzero(along >= 0.5), np.flatnonzero(along <= -0.5)]
    if any(len(idx) == 0 for idx in sides):
        return float("nan")
    return min(_overlap_of(distance, cloud, idx, v, max_points // 2) for idx in sides)


def _overlap_of(distance: SurfaceDistance, cloud: FeatureCloud, idx: np.ndarray,
                v: np.ndarray, max_points: int) -> float:
    step = max(1, int(np.ceil(len(idx) / max_points)))
    idx = idx[::step]
    d = distance(cloud.dense[idx] + v, cloud.dense_normals[idx])
    return float(np.mean(d <= 1e-3 * cloud.params.dense))


def fundamental_offset(distance: SurfaceDistance, cloud: FeatureCloud, v: np.ndarray,
                       min_length: float, max_divisor: int = 64,
                       keep: float = 0.95) -> tuple[np.ndarray, int]:
    """The shortest v/k (k >= 1) that is a repetition of the model as well as v: every
    multiple j v/k (j = 1..k-1) maps the faces facing v onto the surface at least `keep` times
    as well as v itself does. Returns (v/k, k).

    Why: Eq. (1) only matches features more than tau apart, so in a row of n elements with a
    spacing under tau (n > ~13) every match is a multiple of the spacing and the principal
    offset is one; the strict argmin also spreads the matches of a row over v, 2v, 3v, ... and
    the histogram peak may be any of them. Retargeting along a multiple adds or removes
    elements only in groups of k. A true period d of a row maps the facing faces at least as
    well as any multiple of d does (fewer elements fall off the end); a wrong divisor (half a
    period) moves them into the gaps. Divisors shorter than `min_length` (two sample
    spacings) are not tried: the samples cannot resolve them."""
    base = self_overlap(distance, cloud, v, facing=True)
    if not np.isfinite(base) or base <= 0:
        return v, 1
    length = float(np.linalg.norm(v))
    cache: dict[tuple[int, int], float] = {}

    def score(j: int, k: int) -> float:
        g = math.gcd(j, k)
        key = (j // g, k // g)
        if key not in cache:
            cache[key] = self_overlap(distance, cloud, v * key[0] / key[1], facing=True)
        return cache[key]

    for k in range(min(max_divisor, int(length / min_length)), 1, -1):
        if all(score(j, k) >= keep * base for j in range(1, k)):
            return v / k, k
    return v, 1


# ------------------------------------------------------------------------------------------
# Principal offsets
# ------------------------------------------------------------------------------------------
def _dummy_directions(taken: list[np.ndarray]) -> list[np.ndarray]:
    """Unit directions orthogonal to the taken generators (and to each other), each as close
    to a world axis as possible."""
    basis = [g / np.linalg.norm(g) for g in taken]
    out = []
    while len(basis) < 3:
        best, best_norm = None, -1.0
        for axis in np.eye(3):
            v = axis.copy()
            for b in basis:
                v -= (v @ b) * b
            if np.linalg.norm(v) > best_norm + 1e-12:
                best, best_norm = v, float(np.linalg.norm(v))
        d = best / np.linalg.norm(best)
        basis.append(d)
        out.append(d)
    return out


def _canonical_sign(v: np.ndarray) -> np.ndarray:
    k = int(np.argmax(np.abs(v)))
    return v if v[k] >= 0 else -v


def _snapped(align: SelfAlignment, offsets: list[np.ndarray], vertices: np.ndarray,
             tree: cKDTree, tolerance: float) -> list[np.ndarray]:
    """Each offset snapped onto the mesh vertices, where the snap moves it by at most
    `tolerance`."""
    snapped = [align.snap_to_vertices(g, vertices, tree) for g in offsets]
    return [s if np.linalg.norm(s - g) <= tolerance else g for s, g in zip(snapped, offsets)]


def find_offsets(cloud: FeatureCloud, params: OffsetParams = OffsetParams(),
                 mesh_n: trimesh.Trimesh | None = None) -> dict:
    """Matching, histogram, dominant offsets and principal offsets on a normalised cloud."""
    t0 = time.perf_counter()
    match, dist2 = best_matches(cloud.features, cloud.descriptors, params.tau, params.tie_ratio)
    t1 = time.perf_counter()
    ok = match >= 0
    offsets = np.zeros_like(cloud.features)
    offsets[ok] = cloud.features[match[ok]] - cloud.features[ok]
    result: dict = {"match": match, "offsets": offsets, "timings": {"match": t1 - t0}}
    if ok.sum() == 0:
        result.update(dominant=np.zeros((0, 3)), dominant_counts=np.zeros(0, np.int64),
                      sparsity=sparsity(np.zeros(0)), principal=[], principal_counts=[])
        return result
    keys, counts, inverse = histogram(offsets[ok], params.bin)
    stats = sparsity(counts)
    peak_bins = peaks(keys, counts, params.bin, params.nms_radius, params.max_dominant)
    strongest = counts[peak_bins[0]]
    peak_bins = [b for b in peak_bins
                 if counts[b] >= max(params.min_count, params.min_share * strongest)]
    align = SelfAlignment(cloud.dense, cloud.dense_normals, cloud.params.dense)
    vertices = cloud.mesh_vertices if cloud.mesh_vertices is not None else np.zeros((0, 3))
    vertex_tree = cKDTree(vertices) if len(vertices) else None
    dominant, dom_counts = [], []
    matched = offsets[ok]
    for b in peak_bins:
        near = np.abs(keys[inverse] - keys[b]).max(axis=1) <= 1
        start = matched[near].mean(axis=0)
        refined = align.refine(start, params.icp_iterations, params.icp_radius)
        # ICP must stay near its peak (within two bins) and keep |v| > tau (on a shape without
        # repetition it slides towards the trivial offset 0)
        if np.linalg.norm(refined - start) > 2 * params.bin or np.linalg.norm(refined) <= params.tau:
            refined = start
        if any(np.linalg.norm(refined - d) < params.bin / 2 for d in dominant):
            continue  # two peaks converged to the same offset
        dominant.append(refined)
        dom_counts.append(int(counts[b]))
    t2 = time.perf_counter()
    # greedy selection by count with the minimum angle
    cos_max = math.cos(math.radians(params.min_angle))
    taken, taken_counts, overlaps, facing, divisors = [], [], {}, {}, []
    check = mesh_n is not None and (params.min_overlap > 0 or params.min_facing_overlap > 0
                                    or params.fundamental)
    distance = SurfaceDistance(cloud, mesh_n, 0.06, oriented=True) if check else None
    for i, (d, c) in enumerate(zip(dominant, dom_counts)):
        if len(taken) >= params.max_principal:
            break
        u = d / np.linalg.norm(d)
        if not all(abs(u @ (g / np.linalg.norm(g))) <= cos_max + 1e-9 for g in taken):
            continue
        if distance is not None and params.min_overlap > 0:
            overlaps[i] = self_overlap(distance, cloud, d)
            if overlaps[i] < params.min_overlap:
                continue
        if distance is not None and params.min_facing_overlap > 0:
            facing[i] = self_overlap(distance, cloud, d, facing=True)
            if np.isfinite(facing[i]) and facing[i] < params.min_facing_overlap:
                continue
        taken.append(d)
        taken_counts.append(c)
    if vertex_tree is not None:  # exact where the mesh repeats exactly (after the choice)
        taken = _snapped(align, taken, vertices, vertex_tree, params.bin / 2)
    if distance is not None and params.fundamental:
        found = [fundamental_offset(distance, cloud, g, 2.0 * cloud.params.dense) for g in taken]
        divisors = [k for _, k in found]
        taken = [g for g, _ in found]
        if vertex_tree is not None:
            taken = _snapped(align, taken, vertices, vertex_tree, params.bin / 2)
    result.update(dominant=np.array(dominant).reshape(-1, 3),
                  dominant_counts=np.array(dom_counts, dtype=np.int64), sparsity=stats,
                  principal=[_canonical_sign(g) for g in taken], principal_counts=taken_counts,
                  overlaps={i: round(v, 4) for i, v in overlaps.items()},
                  facing_overlaps={i: round(v, 4) for i, v in facing.items()},
                  divisors=divisors,
                  peak_keys=keys[peak_bins], bin_keys=keys,
                  bin_counts=counts)
    result["timings"].update(dominant=t2 - t1, principal=time.perf_counter() - t2)
    return result


def principal_offsets(mesh: trimesh.Trimesh, *, sampling: SamplingParams = SamplingParams(),
                      params: OffsetParams = OffsetParams()) -> Offsets:
    """The principal offsets of `mesh` (world units) with their statistics.

    Raises nothing for a mesh without repetitive structure: `len(result) == 0` then."""
    t0 = time.perf_counter()
    frame = Frame.of(mesh)
    mesh_n = trimesh.Trimesh(frame.to_normalised(mesh.vertices), np.asarray(mesh.faces),
                             process=False)
    cloud = build_cloud(mesh_n, sampling)
    t1 = time.perf_counter()
    found = find_offsets(cloud, params, mesh_n)
    principal = found["principal"]
    # order and sign: principal offsets strongest first; a right-handed basis
    dummies = [d * params.dummy_length for d in _dummy_directions(principal)]
    gens = np.array(list(principal) + dummies, dtype=np.float64).reshape(3, 3)
    if np.linalg.det(gens) < 0:
        gens[2] = -gens[2]
    structured = np.array([True] * len(principal) + [False] * len(dummies))
    counts = np.array(list(found["principal_counts"]) + [0] * len(dummies), dtype=np.int64)
    stats = {"features": int(len(cloud.features)), "dense": int(len(cloud.dense)),
             "vertices": int(cloud.is_vertex.sum()),
             "matched": int((found["match"] >= 0).sum()),
             "overlap_checked": {int(k): v for k, v in found.get("overlaps", {}).items()},
             "facing_overlap_checked": {int(k): v for k, v in
                                        found.get("facing_overlaps", {}).items()},
             "divisors": list(found.get("divisors", [])),
             "seconds": {"sample_describe": round(t1 - t0, 4),
                         **{k: round(v, 4) for k, v in found["timings"].items()}}}
    if cloud.thinned_vertex_radius is not None:
        stats["vertex_thinning_radius"] = cloud.thinned_vertex_radius
    gens = np.where(np.abs(gens) < 1e-15, 0.0, gens)  # no -0.0 in what users print
    return Offsets(generators=gens / frame.scale, structured=structured, counts=counts,
                   dominant=found["dominant"] / frame.scale, dominant_counts=found["dominant_counts"],
                   sparsity=found["sparsity"], frame=frame, params=params, stats=stats,
                   cloud=cloud, matches=found["match"], match_offsets=found["offsets"])
