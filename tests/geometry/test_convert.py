import manifold3d
import numpy as np
import pytest
import trimesh

from grammarkit.errors import ShapeError
from grammarkit.geometry.convert import assert_manifold, mesh_report, to_manifold, to_trimesh


def test_box_round_trip_through_manifold(box):
    solid = to_manifold(box)
    assert solid.status() == manifold3d.Error.NoError
    assert solid.volume() == pytest.approx(1.0)
    back = to_trimesh(solid)
    report = mesh_report(back)
    assert report.ok and report.euler_number == 2 and report.triangles == 12
    assert back.volume == pytest.approx(1.0)


def test_triangle_soup_is_welded(box):
    soup = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3), np.arange(36).reshape(-1, 3),
                           process=False)
    assert not soup.is_watertight  # by index: 36 unshared vertices
    assert to_manifold(soup).volume() == pytest.approx(1.0)


def test_open_mesh_raises_with_name(box):
    open_mesh = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    with pytest.raises(ShapeError, match="Wall.3.*not a closed manifold"):
        to_manifold(open_mesh, "Wall.3")
    report = mesh_report(open_mesh)
    assert not report.ok and not report.watertight and not report.manifold
    assert report.status == "NotManifold"
    with pytest.raises(ShapeError, match="part Wall.3: mesh is not a watertight manifold"):
        assert_manifold(open_mesh, "part Wall.3")


def test_nan_and_empty_meshes_raise(box):
    verts = box.vertices.copy()
    verts[0, 0] = np.nan
    with pytest.raises(ShapeError, match="NaN"):
        to_manifold(trimesh.Trimesh(verts, box.faces, process=False))
    with pytest.raises(ShapeError, match="empty"):
        to_manifold(trimesh.Trimesh())
    assert not mesh_report(trimesh.Trimesh()).ok


def test_torus_euler_number_and_scene_report():
    torus = trimesh.creation.torus(2.0, 0.5)
    assert mesh_report(torus).euler_number == 0
    scene = trimesh.Scene([trimesh.creation.box((1, 1, 1))])
    assert assert_manifold(scene).volume == pytest.approx(1.0)


def test_to_trimesh_keeps_manifold_output_manifold(building):
    report = mesh_report(building)
    assert report.ok, report
    assert to_manifold(building).volume() == pytest.approx(building.volume)
