"""Normalisation, Poisson-disc sampling and SHOT descriptors (Wu et al., section III-A and V).

- `Frame`: the normalisation that makes the longest side of the bounding box span [-1, 1];
  every length parameter of the method (0.02, 0.06, 0.2, 0.15, 0.05) is in these units.
- `poisson_disc`: a maximal Poisson-disc subset of candidate points (no two closer than the
  radius, every candidate within the radius of a kept one).
- `build_cloud`: dense samples (spacing 0.02) with their face normals, the features (sparse
  samples at 0.06 re-sampled from the dense cloud, plus the mesh vertices) and one SHOT
  descriptor per feature.
- `shot`: the SHOT descriptor (Tombari, Salti, di Stefano 2010) with the local reference frame
  fixed to the world axes, as the paper does (only translations are matched).

Written by hand because no SHOT implementation with wheels exists on PyPI (NOTES.md,
"Retargeting anchors"); FPFH lives in open3d, a large optional dependency we do not need.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import trimesh
from scipy.spatial import cKDTree

__all__ = ["FeatureCloud", "Frame", "SamplingParams", "build_cloud", "poisson_disc", "shot",
           "SHOT_DIMENSIONS"]

# SHOT's spatial grid: 8 azimuth x 2 elevation x 2 radial volumes, 11 cosine bins in each.
AZIMUTH, ELEVATION, RADIAL, COS_BINS = 8, 2, 2, 11
SHOT_DIMENSIONS = AZIMUTH * ELEVATION * RADIAL * COS_BINS  # 352


@dataclass(frozen=True)
class Frame:
    """x_normalised = (x_world - center) * scale; the longest bounding-box side spans [-1, 1]."""

    center: np.ndarray
    scale: float

    @classmethod
    def of(cls, mesh: trimesh.Trimesh) -> "Frame":
        lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
        longest = float((hi - lo).max())
        return cls(center=(lo + hi) / 2.0, scale=2.0 / longest)

    def to_normalised(self, points: np.ndarray) -> np.ndarray:
        return (np.asarray(points, dtype=np.float64) - self.center) * self.scale

    def to_world(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, dtype=np.float64) / self.scale + self.center


@dataclass(frozen=True)
class SamplingParams:
    """The paper's sampling and descriptor parameters (normalised units) plus resource guards.

    dense:   Poisson-disc spacing of the descriptor support cloud (paper: 0.02).
    sparse:  spacing of the feature samples, re-sampled from the dense cloud (paper: 0.06).
    radius:  SHOT support radius (paper: 0.2).
    vertices: include the mesh vertices as features (paper: yes).
    max_features: guard for finely tessellated meshes: when sparse samples plus vertices
             exceed it, the vertices are thinned by Poisson-disc sampling (radius grown in
             steps of 1.5x from `dense`) until they fit. The matching step is quadratic in
             the feature count.
    oversample: uniform candidates per expected Poisson-disc sample (makes the disc sample
             close to maximal).
    seed:    seed of the random candidates; the same seed gives the same samples.
    """

    dense: float = 0.02
    sparse: float = 0.06
    radius: float = 0.2
    vertices: bool = True
    max_features: int = 4000
    oversample: float = 4.0
    seed: int = 0


@dataclass
class FeatureCloud:
    """Everything the offset statistics and the labelling read, in normalised units."""

    dense: np.ndarray  # (D, 3) dense Poisson-disc samples
    dense_normals: np.ndarray  # (D, 3)
    dense_faces: np.ndarray  # (D,) the face each dense sample lies on
    features: np.ndarray  # (F, 3) sparse samples and mesh vertices
    feature_normals: np.ndarray  # (F, 3)
    is_vertex: np.ndarray  # (F,) bool
    descriptors: np.ndarray  # (F, 352) float32, unit length (zero where no support)
    params: SamplingParams = field(default_factory=SamplingParams)
    thinned_vertex_radius: float | None = None  # set when max_features thinned the vertices
    mesh_vertices: np.ndarray | None = None  # (V, 3) all vertices used by faces (for ICP)

    def describe(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """SHOT descriptors of further points over the same dense support cloud."""
        return shot(points, normals, self.dense, self.dense_normals, self.params.radius,
                    tree=self._tree())

    def _tree(self) -> cKDTree:
        tree = getattr(self, "_dense_tree", None)
        if tree is None:
            tree = cKDTree(self.dense)
            self._dense_tree = tree
        return tree


def poisson_disc(points: np.ndarray, radius: float, priority: np.ndarray | None = None) -> np.ndarray:
    """Indices of a maximal subset of `points` with no two closer than `radius`.

    Greedy in order of `priority` (lowest first; default: index order), computed in rounds
    without a Python loop over points: a candidate is kept when it comes first among its
    undecided neighbours, and its neighbours are then dropped (Luby's maximal independent set
    with fixed priorities, which equals the sequential greedy result)."""
    n = len(points)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    prio = np.arange(n) if priority is None else np.argsort(np.argsort(priority, kind="stable"))
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    state = np.zeros(n, dtype=np.int8)  # 0 undecided, 1 kept, -1 dropped
    a, b = pairs[:, 0], pairs[:, 1]
    while True:
        undecided = state == 0
        if not undecided.any():
            break
        live = undecided[a] & undecided[b]
        a, b = a[live], b[live]
        # a candidate loses when an undecided neighbour has a smaller priority
        loses = np.zeros(n, dtype=bool)
        first_a = prio[a] < prio[b]
        loses[b[first_a]] = True
        loses[a[~first_a]] = True
        winners = undecided & ~loses
        state[winners] = 1
        drop = np.zeros(n, dtype=bool)
        drop[b[winners[a]]] = True
        drop[a[winners[b]]] = True
        state[drop & (state == 0)] = -1
    return np.flatnonzero(state == 1)


def _uniform_samples(mesh: trimesh.Trimesh, count: int, rng: np.random.Generator):
    area = np.asarray(mesh.area_faces, dtype=np.float64)
    cdf = np.cumsum(area)
    faces = np.searchsorted(cdf, rng.random(count) * cdf[-1], side="right")
    faces = np.minimum(faces, len(area) - 1)
    tri = np.asarray(mesh.triangles, dtype=np.float64)[faces]
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1.0
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    pts = tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0])
    return pts, faces


def build_cloud(mesh_n: trimesh.Trimesh, params: SamplingParams = SamplingParams()) -> FeatureCloud:
    """Sample a mesh already in normalised units and describe its features."""
    rng = np.random.default_rng(params.seed)
    area = float(mesh_n.area)
    count = int(np.clip(params.oversample * area / params.dense ** 2, 1000, 2_000_000))
    cand, cand_faces = _uniform_samples(mesh_n, count, rng)
    keep = poisson_disc(cand, params.dense)
    dense = cand[keep]
    face_normals = np.asarray(mesh_n.face_normals, dtype=np.float64)
    dense_normals = face_normals[cand_faces[keep]]
    sparse_idx = poisson_disc(dense, params.sparse)
    feats = [dense[sparse_idx]]
    normals = [dense_normals[sparse_idx]]
    is_vertex = [np.zeros(len(sparse_idx), dtype=bool)]
    thinned = None
    all_vertices = np.asarray(mesh_n.vertices, dtype=np.float64)[np.unique(np.asarray(mesh_n.faces))]
    if params.vertices:
        verts = np.asarray(mesh_n.vertices, dtype=np.float64)
        vnormals = np.asarray(mesh_n.vertex_normals, dtype=np.float64)
        used = np.unique(np.asarray(mesh_n.faces).ravel())
        verts, vnormals = verts[used], vnormals[used]
        budget = max(0, params.max_features - len(sparse_idx))
        if len(verts) > budget:
            radius = params.dense
            while True:
                pick = poisson_disc(verts, radius)
                if len(pick) <= budget:
                    break
                radius *= 1.5
            verts, vnormals, thinned = verts[pick], vnormals[pick], radius
        feats.append(verts)
        normals.append(vnormals)
        is_vertex.append(np.ones(len(verts), dtype=bool))
    features = np.concatenate(feats)
    feature_normals = np.concatenate(normals)
    cloud = FeatureCloud(dense=dense, dense_normals=dense_normals,
                         dense_faces=cand_faces[keep], features=features,
                         feature_normals=feature_normals, is_vertex=np.concatenate(is_vertex),
                         descriptors=np.zeros((0, SHOT_DIMENSIONS), np.float32), params=params,
                         thinned_vertex_radius=thinned, mesh_vertices=all_vertices)
    cloud.descriptors = cloud.describe(features, feature_normals)
    return cloud


def _linear_bins(pos: np.ndarray, n: int, circular: bool = False):
    """Two neighbouring bins and their weights for a continuous bin coordinate `pos`
    (bin centres at 0, 1, ..., n-1): SHOT's linear interpolation between adjacent bins."""
    lo = np.floor(pos)
    w_hi = pos - lo
    lo = lo.astype(np.int64)
    hi = lo + 1
    if circular:
        return lo % n, hi % n, 1.0 - w_hi, w_hi
    # outside the first/last centre all weight goes to the end bin
    lo_c = np.clip(lo, 0, n - 1)
    hi_c = np.clip(hi, 0, n - 1)
    w_lo = np.where(lo < 0, 0.0, np.where(hi > n - 1, 1.0, 1.0 - w_hi))
    w_h = 1.0 - w_lo
    return lo_c, hi_c, w_lo, w_h


def shot(points: np.ndarray, normals: np.ndarray, support: np.ndarray,
         support_normals: np.ndarray, radius: float, *, tree: cKDTree | None = None,
         chunk_pairs: int = 150_000) -> np.ndarray:
    """SHOT descriptors (352-D, unit length) of `points` over the `support` cloud.

    The support sphere of `radius` is divided into 8 azimuth sectors (about world z),
    2 elevation halves (above/below the point) and 2 radial shells (at radius/2); in each of
    these 32 volumes, a histogram of 11 bins of cos(angle between the neighbour's normal and
    the point's normal). Every neighbour is spread over the neighbouring bins of all four
    coordinates (quadrilinear interpolation), as in the original. The local reference frame
    is the world frame (the paper fixes it so that descriptors match under translation only).
    """
    points = np.asarray(points, dtype=np.float64)
    out = np.zeros((len(points), SHOT_DIMENSIONS), dtype=np.float64)
    if len(points) == 0 or len(support) == 0:
        return out.astype(np.float32)
    tree = tree or cKDTree(support)
    neighbours = tree.query_ball_point(points, radius, return_sorted=False)
    counts = np.fromiter((len(n) for n in neighbours), dtype=np.int64, count=len(neighbours))
    owner = np.repeat(np.arange(len(points)), counts)
    idx = np.fromiter(itertools.chain.from_iterable(neighbours), dtype=np.int64,
                      count=int(counts.sum()))
    flat_out = out.ravel()
    for start in range(0, len(idx), chunk_pairs):
        sl = slice(start, start + chunk_pairs)
        own, nb = owner[sl], idx[sl]
        d = support[nb] - points[own]
        horiz = np.hypot(d[:, 0], d[:, 1])
        dist = np.sqrt(horiz ** 2 + d[:, 2] ** 2)
        cosang = np.clip(np.einsum("ij,ij->i", support_normals[nb], normals[own]), -1.0, 1.0)
        c = _linear_bins((cosang + 1.0) / 2.0 * COS_BINS - 0.5, COS_BINS)
        az = _linear_bins((np.arctan2(d[:, 1], d[:, 0]) + np.pi) / (2 * np.pi) * AZIMUTH - 0.5,
                          AZIMUTH, circular=True)
        el = _linear_bins((np.arctan2(d[:, 2], horiz) + np.pi / 2) / np.pi * ELEVATION - 0.5, ELEVATION)
        ra = _linear_bins(dist / radius * RADIAL - 0.5, RADIAL)
        base = own * SHOT_DIMENSIONS
        flats, weights = [], []
        for ri, rw in ((ra[0], ra[2]), (ra[1], ra[3])):
            for ei, ew in ((el[0], el[2]), (el[1], el[3])):
                for ai, aw in ((az[0], az[2]), (az[1], az[3])):
                    volume = (ri * ELEVATION + ei) * AZIMUTH + ai
                    w_vol = rw * ew * aw
                    for ci, cw in ((c[0], c[2]), (c[1], c[3])):
                        flats.append(base + volume * COS_BINS + ci)
                        weights.append(w_vol * cw)
        flat_out += np.bincount(np.concatenate(flats), weights=np.concatenate(weights),
                                minlength=out.size)
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    out = np.divide(out, norm, out=np.zeros_like(out), where=norm > 0)
    return out.astype(np.float32)
