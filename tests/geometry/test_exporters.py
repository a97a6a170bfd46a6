import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from grammarkit.errors import ShapeError
from grammarkit.geometry.convert import mesh_report
from grammarkit.geometry.exporters import (export, exporter_for, grammarkit_exporters,
                                           known_formats, scene_from_parts)
from grammarkit.geometry.meshio import load_mesh


@pytest.fixture
def parts_scene(building):
    wall = trimesh.creation.box((4.0, 0.8, 3.0))
    wall.apply_translation([12.0, 0, 1.5])
    wall.visual.face_colors = [10, 200, 30, 255]
    return scene_from_parts([("Tower.0", "Tower", building, {"rule": "Lot", "line": 3}),
                             ("Wall.1", "Wall", wall)])


def _colours_by_position(mesh):
    """Face colours in the order of the faces' sorted vertex positions (order-free comparison)."""
    key = np.round(np.sort(mesh.vertices[mesh.faces].reshape(len(mesh.faces), -1), axis=1), 5)
    order = np.lexsort(key.T[::-1])
    return np.asarray(mesh.visual.face_colors)[order]


def node_info(scene):
    out = {}
    for node in scene.graph.nodes_geometry:
        matrix, gname = scene.graph[node]
        parent = scene.graph.transforms.parents[node]
        extras = scene.graph.transforms.edge_data[(parent, node)].get("metadata")
        mesh = scene.geometry[gname].copy()
        mesh.apply_transform(matrix)
        out[node] = (mesh, extras)
    return out


@pytest.mark.parametrize("fmt", ["glb", "gltf", "obj"])
def test_scene_formats_round_trip_names_extras_colours(tmp_path, parts_scene, building, fmt):
    path = export(parts_scene, tmp_path / f"model.{fmt}")
    back = load_mesh(path)
    assert isinstance(back, trimesh.Scene)
    nodes = node_info(back)
    assert set(nodes) == {"Tower.0", "Wall.1"}
    tower, extras = nodes["Tower.0"]
    assert extras["type"] == "Tower" and extras["id"] == "Tower.0" and extras["rule"] == "Lot"
    assert extras["line"] == 3
    assert nodes["Wall.1"][1]["type"] == "Wall"
    report = mesh_report(tower)
    assert report.ok, report
    assert len(tower.vertices) == len(building.vertices)
    assert len(tower.faces) == len(building.faces)
    assert tower.volume == pytest.approx(building.volume, rel=1e-6)
    # every face keeps its exact colour (glTF groups faces by material, so compare by position)
    assert np.array_equal(_colours_by_position(tower), _colours_by_position(building))
    wall = nodes["Wall.1"][0]
    assert mesh_report(wall).ok
    assert np.allclose(wall.bounds, [[10, -0.4, 0], [14, 0.4, 3]])


@pytest.mark.parametrize("fmt", ["stl", "ply"])
def test_single_mesh_formats_round_trip(tmp_path, parts_scene, building, fmt):
    path = export(parts_scene, tmp_path / f"model.{fmt}")
    back = load_mesh(path)
    assert isinstance(back, trimesh.Trimesh)
    report = mesh_report(back)
    assert report.ok and report.euler_number == 4  # two closed genus-0 parts
    assert back.volume == pytest.approx(building.volume + 4 * 0.8 * 3, rel=1e-5)
    assert len(back.faces) == len(building.faces) + 12
    if fmt == "ply":
        expected = np.vstack([building.visual.face_colors, np.tile([10, 200, 30, 255], (12, 1))])
        assert np.array_equal(back.visual.face_colors, expected)


def test_export_single_trimesh(tmp_path, building):
    back = load_mesh(export(building, tmp_path / "one.glb"))
    (mesh, _extras), = node_info(back).values()
    assert mesh_report(mesh).ok and mesh.volume == pytest.approx(building.volume)


def test_format_choice_and_unknown_format(tmp_path, box):
    assert exporter_for("a.GLB").format == "glb"
    assert exporter_for("a.bin", format="stl").format == "stl"
    with pytest.raises(ShapeError, match=r"unknown export format 'fbx'; known formats: .*glb.*"
                                         r"obj.*ply.*stl"):
        export(box, tmp_path / "x.fbx", format="fbx")
    with pytest.raises(ShapeError, match=r"suffix '\.fbx'.*\.glb"):
        export(box, tmp_path / "x.fbx")
    assert not (tmp_path / "x.fbx").exists()
    assert {"glb", "gltf", "obj", "stl", "ply"} <= set(known_formats())


@pytest.mark.parametrize("fmt", ["glb", "obj", "stl", "ply"])
def test_failed_write_leaves_nothing(tmp_path, box, monkeypatch, fmt):
    target = tmp_path / f"m.{fmt}"
    target.write_bytes(b"old content")
    real_open = open

    def disk_full(self, data):  # writes part of the data, then fails like a full disk would
        with real_open(self, "wb") as fh:
            fh.write(data[:10] if isinstance(data, bytes) else data[:10].encode())
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", disk_full)
    monkeypatch.setattr(Path, "write_text", lambda self, data, encoding=None: disk_full(self, data))
    with pytest.raises(OSError, match="No space"):
        export(box, target)
    assert target.read_bytes() == b"old content"  # the old file is untouched
    assert [p.name for p in tmp_path.iterdir()] == [target.name]  # no temporary left


def test_missing_folder_is_created_and_a_file_in_the_way_is_an_error(tmp_path, box):
    # the one writer (grammarkit.run.writer.write_files) creates missing parent folders
    assert export(box, tmp_path / "missing" / "x.glb").is_file()
    (tmp_path / "afile").write_text("x")
    with pytest.raises(ShapeError, match="is a file, not a folder"):
        export(box, tmp_path / "afile" / "x.glb")


def test_nothing_to_export(tmp_path):
    with pytest.raises(ShapeError, match="no triangles"):
        export(trimesh.Scene(), tmp_path / "e.glb")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ShapeError, match="cannot export a str"):
        export("hello", tmp_path / "e.glb")


def test_hookimpl_and_plugin_manager_list_the_exporters():
    formats = {spec.format for spec in grammarkit_exporters()}
    assert formats == {"glb", "gltf", "obj", "stl", "ply"}
    from grammarkit.plugins import get_plugin_manager

    registered = get_plugin_manager().exporters()
    assert {"glb", "obj", "stl", "ply"} <= set(registered)


def test_obj_has_groups_and_extras_comment(tmp_path, parts_scene):
    text = export(parts_scene, tmp_path / "m.obj").read_text()
    assert "o Tower.0\ng Tower.0\n# extras " in text
    line = next(l for l in text.splitlines() if l.startswith("# extras") and "Wall" in l)
    assert json.loads(line[len("# extras "):]) == {"id": "Wall.1", "type": "Wall"}
