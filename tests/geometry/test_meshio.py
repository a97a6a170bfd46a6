import numpy as np
import pytest
import trimesh

from grammarkit.errors import ShapeError
from grammarkit.geometry.convert import mesh_report
from grammarkit.geometry.meshio import load_mesh, weld


def test_missing_and_non_mesh_files(tmp_path):
    with pytest.raises(ShapeError, match=r"nope\.glb: mesh file not found"):
        load_mesh(tmp_path / "nope.glb")
    (tmp_path / "junk.glb").write_bytes(b"this is not a glb file at all")
    with pytest.raises(ShapeError, match=r"junk\.glb: cannot read as GLB"):
        load_mesh(tmp_path / "junk.glb")
    (tmp_path / "empty.stl").write_bytes(b"")
    with pytest.raises(ShapeError, match=r"empty\.stl: the file is empty"):
        load_mesh(tmp_path / "empty.stl")
    (tmp_path / "notes.txt").write_text("hi")
    with pytest.raises(ShapeError, match=r"notes\.txt: unsupported mesh format '\.txt'"):
        load_mesh(tmp_path / "notes.txt")
    with pytest.raises(ShapeError, match="not a file"):
        load_mesh(tmp_path)


def test_obj_errors_name_file_and_line(tmp_path):
    p = tmp_path / "bad.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n")
    with pytest.raises(ShapeError, match=r"bad\.obj:3: cannot read OBJ line"):
        load_mesh(p)
    p.write_text("v 0 0 0\nv 1 0 0\n")
    with pytest.raises(ShapeError, match="no triangle meshes"):
        load_mesh(p)
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(ShapeError, match="missing vertices"):
        load_mesh(p)
    p.write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ShapeError, match=r"bad\.obj: mesh 'bad' has NaN"):
        load_mesh(p)


def test_obj_polygons_groups_and_negative_indices(tmp_path):
    p = tmp_path / "quad.obj"
    p.write_text("o A.0\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
                 "g B.1\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n")
    scene = load_mesh(p)
    assert set(scene.geometry) == {"A.0", "B.1"}
    assert len(scene.geometry["A.0"].faces) == 2 and len(scene.geometry["B.1"].faces) == 1
    assert scene.geometry["A.0"].area == pytest.approx(1.0)


def test_nan_in_stl(tmp_path):
    box = trimesh.creation.box((1, 1, 1))
    box.vertices[0] = [np.nan, 0, 0]
    p = tmp_path / "nan.stl"
    p.write_bytes(box.export(file_type="stl"))
    with pytest.raises(ShapeError, match=r"nan\.stl: the mesh has NaN"):
        load_mesh(p)


def test_stl_soup_is_welded_watertight(tmp_path):
    p = tmp_path / "box.stl"
    p.write_bytes(trimesh.creation.box((1, 2, 3)).export(file_type="stl"))
    mesh = load_mesh(p)
    assert len(mesh.vertices) == 8 and mesh_report(mesh).ok
    raw = load_mesh(p, weld_vertices=False)
    assert len(raw.vertices) == 36 and not raw.is_watertight


def test_weld_keeps_face_colours():
    box = trimesh.creation.box((1, 1, 1))
    soup = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3), np.arange(36).reshape(-1, 3),
                           process=False)
    colours = np.random.default_rng(0).integers(0, 255, (12, 4)).astype(np.uint8)
    soup.visual.face_colors = colours
    welded = weld(soup)
    assert len(welded.vertices) == 8 and welded.is_watertight
    assert np.array_equal(welded.visual.face_colors, colours)


def test_single_flattens_scene_in_world_coordinates(tmp_path):
    from grammarkit.geometry.exporters import export, scene_from_parts

    a = trimesh.creation.box((1, 1, 1))
    a.visual.face_colors = [255, 0, 0, 255]
    b = trimesh.creation.box((1, 1, 1))
    b.apply_translation([5, 0, 0])
    path = export(scene_from_parts([("A.0", "A", a), ("B.1", "B", b)]), tmp_path / "two.glb")
    mesh = load_mesh(path, single=True)
    assert isinstance(mesh, trimesh.Trimesh)
    assert len(mesh.faces) == 24 and mesh_report(mesh).ok
    assert mesh.volume == pytest.approx(2.0)
    assert np.allclose(mesh.bounds, [[-0.5, -0.5, -0.5], [5.5, 0.5, 0.5]])
    assert (mesh.visual.face_colors[:, :3] == [255, 0, 0]).all(axis=1).sum() == 12


def test_obj_group_naming(tmp_path):
    p = tmp_path / "names.obj"
    tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
    p.write_text("o Tower.0\ng Tower_material\n" + tri + "o Wall.1\n" + tri + "o Wall.1\n" + tri)
    scene = load_mesh(p)
    assert list(scene.geometry) == ["Tower.0", "Wall.1", "Wall.1_1"]
