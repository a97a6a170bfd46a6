import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from grammarkit.errors import ShapeError
from grammarkit.tiling import dock, local_frame
from grammarkit.tiling.dock import apply
from grammarkit.tiling.frames import local_frames, symmetry_offsets


def random_rigid(rng):
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.uniform(-10, 10, 3)
    return T


@pytest.mark.parametrize("seed", range(5))
def test_dock_recovers_random_rigid_transform(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(6, 3))
    T = random_rigid(rng)
    b = apply(T, a)
    got, rms = dock(a, b)
    np.testing.assert_allclose(got, T, atol=1e-9)
    assert rms < 1e-9
    assert np.isclose(np.linalg.det(got[:3, :3]), 1.0)


def test_dock_least_squares_with_noise():
    rng = np.random.default_rng(11)
    a = rng.normal(size=(50, 3)) * 3
    T = random_rigid(rng)
    b = apply(T, a) + rng.normal(scale=0.01, size=a.shape)
    got, rms = dock(a, b)
    assert np.abs(got - T).max() < 0.02
    assert 0.005 < rms < 0.03


def test_dock_never_reflects():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(8, 3))
    mirrored = a * np.array([1, 1, -1])  # best fit would be a reflection
    T, rms = dock(a, mirrored)
    assert np.isclose(np.linalg.det(T[:3, :3]), 1.0)
    assert rms > 0.1  # a proper rotation cannot fit a mirror image exactly


def test_dock_small_inputs_and_errors():
    T, rms = dock([[0, 0, 0], [1, 0, 0]], [[5, 1, 0], [6, 1, 0]])
    np.testing.assert_allclose(T[:3, 3], (5, 1, 0))
    np.testing.assert_allclose(T[:3, :3], np.eye(3))
    with pytest.raises(ShapeError, match="non-collinear"):
        dock([[0, 0, 0], [1, 0, 0]], [[0, 0, 0], [1, 0, 0]], allow_translation=False)
    with pytest.raises(ShapeError, match="collinear"):
        dock([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 0, 0], [0, 1, 0], [0, 2, 0]])
    with pytest.raises(ShapeError, match="same size"):
        dock(np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(ShapeError, match="NaN"):
        dock([[np.nan, 0, 0], [1, 0, 0], [0, 1, 0]], np.eye(3))


def test_local_frame_moves_rigidly_with_the_part():
    rng = np.random.default_rng(5)
    mesh = trimesh.creation.icosphere(subdivisions=1)
    mesh.vertices = mesh.vertices * [1.0, 2.0, 3.5] + rng.normal(scale=0.05, size=mesh.vertices.shape)
    F = local_frame(mesh.vertices, mesh.faces)
    assert np.isclose(np.linalg.det(F[:3, :3]), 1.0)
    for _ in range(3):
        T = random_rigid(rng)
        moved = mesh.copy()
        moved.apply_transform(T)
        np.testing.assert_allclose(local_frame(moved.vertices, moved.faces), T @ F, atol=1e-8)
        np.testing.assert_allclose(local_frames([moved])[0], T @ F, atol=1e-8)


def test_symmetric_part_frames_are_consistent_and_symmetries_found():
    cube = trimesh.creation.box(extents=(1, 1, 1))
    rng = np.random.default_rng(1)
    T = random_rigid(rng)
    moved = cube.copy()
    moved.apply_transform(T)
    # ties are broken by vertex order, so rigid copies get corresponding frames
    np.testing.assert_allclose(local_frame(moved.vertices, moved.faces), T @ local_frame(cube.vertices, cube.faces),
                               atol=1e-8)
    assert len(symmetry_offsets(cube.vertices, cube.faces)) == 24  # the cube's rotation group
    brick = trimesh.creation.box(extents=(1, 2, 3))
    assert len(symmetry_offsets(brick.vertices, brick.faces)) == 4
