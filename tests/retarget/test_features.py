"""Poisson-disc sampling and the SHOT descriptor."""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from grammarkit_retarget.features import SHOT_DIMENSIONS, Frame, SamplingParams, build_cloud, poisson_disc, shot


def test_poisson_disc_is_a_maximal_disc_sample():
    rng = np.random.default_rng(1)
    pts = rng.uniform(0, 1, (4000, 3)) * [1, 1, 0]
    keep = poisson_disc(pts, 0.05)
    kept = pts[keep]
    # no two kept points closer than the radius
    assert cKDTree(kept).query_pairs(0.05 - 1e-12) == set()
    # maximal: every candidate is within the radius of a kept point
    d, _ = cKDTree(kept).query(pts)
    assert d.max() <= 0.05
    # deterministic
    assert (poisson_disc(pts, 0.05) == keep).all()


def test_frame_normalises_the_longest_side_to_two():
    m = trimesh.creation.box((4.0, 1.0, 2.0))
    m.apply_translation((10, 0, 0))
    f = Frame.of(m)
    n = f.to_normalised(m.vertices)
    assert np.allclose(n.min(0)[0], -1) and np.allclose(n.max(0)[0], 1)
    assert np.allclose(f.to_world(n), m.vertices)


def test_shot_is_unit_length_and_translation_invariant():
    m = trimesh.creation.box((1.0, 0.6, 0.4))
    m2 = m.copy()
    m2.apply_translation((0.37, -0.2, 0.11))
    pts, faces = trimesh.sample.sample_surface(m, 800, seed=3)
    normals = m.face_normals[faces]
    q = pts[:20]
    a = shot(q, normals[:20], pts, normals, 0.3)
    b = shot(q + (0.37, -0.2, 0.11), normals[:20], pts + (0.37, -0.2, 0.11), normals, 0.3)
    assert a.shape == (20, SHOT_DIMENSIONS)
    assert np.allclose(np.linalg.norm(a, axis=1), 1, atol=1e-5)
    assert np.allclose(a, b, atol=1e-5)


def test_shot_tells_a_corner_from_a_flat_face_and_fixes_the_frame_to_the_world():
    m = trimesh.creation.box((1.0, 1.0, 1.0))
    pts, faces = trimesh.sample.sample_surface_even(m, 6000, radius=0.01, seed=2)
    normals = m.face_normals[faces]
    q = np.array([[0.5, 0.5, 0.5], [0.0, 0.0, 0.5], [-0.5, -0.5, -0.5]])
    n = np.array([[1, 1, 1], [0, 0, 1], [-1, -1, -1]], dtype=float)
    d = shot(q, n / np.linalg.norm(n, axis=1, keepdims=True), pts, normals, 0.3)
    assert np.linalg.norm(d[0] - d[1]) > 0.5
    # opposite corners are alike up to a rotation, which a world-fixed frame does not
    # forgive: only translations may match
    assert np.linalg.norm(d[0] - d[2]) > 0.5


def test_cloud_has_the_papers_densities():
    m = trimesh.creation.box((2.0, 1.0, 0.5))
    cloud = build_cloud(m, SamplingParams())
    dense_nn = cKDTree(cloud.dense).query(cloud.dense, k=2)[0][:, 1]
    assert dense_nn.min() >= 0.02 - 1e-12
    sparse = cloud.features[~cloud.is_vertex]
    assert cKDTree(sparse).query(sparse, k=2)[0][:, 1].min() >= 0.06 - 1e-12
    assert cloud.is_vertex.sum() == 8  # the box's corners
    assert cloud.descriptors.shape == (len(cloud.features), SHOT_DIMENSIONS)
