import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from grammarkit.errors import ShapeError
from grammarkit.ir import Grammar
from grammarkit.ir.tiling import NeighborRule
from grammarkit.tiling import Assembly, Part, ShapeWarning, read_assembly, shape_graph, write_assembly

sys.path.insert(0, str(Path(__file__).parent))
from _tiling_helpers import box_part, load_make_examples  # noqa: E402


def castle():
    return load_make_examples().castle("castle_t", 3, 2, {(0, 0, 1)})


def same_assembly(a: Assembly, b: Assembly, atol=1e-5):
    a = Assembly(sorted(a.parts, key=lambda p: p.id))
    b = Assembly(sorted(b.parts, key=lambda p: p.id))
    assert [p.id for p in a.parts] == [p.id for p in b.parts]
    assert [p.type for p in a.parts] == [p.type for p in b.parts]
    for p, q in zip(a.parts, b.parts):
        np.testing.assert_allclose(np.sort(p.mesh.vertices, axis=0), np.sort(q.mesh.vertices, axis=0), atol=atol)
        assert len(p.mesh.faces) == len(q.mesh.faces)


@pytest.mark.parametrize("suffix", [".glb", ".gltf", ".obj", ""])
def test_round_trip(tmp_path, suffix):
    a = castle()
    path = write_assembly(a, tmp_path / f"castle{suffix}")
    b = read_assembly(path)
    same_assembly(a, b)
    assert {tuple(sorted(e)) for e in shape_graph(a).edges()} == {tuple(sorted(e)) for e in shape_graph(b).edges()}
    if suffix in (".glb", ".gltf"):  # transforms survive in scene formats
        for p, q in zip(a.parts, b.parts):
            assert p.id == q.id  # scene formats keep the part order
            np.testing.assert_allclose(p.transform, q.transform, atol=1e-6)
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary files left behind


def test_glb_instances_identical_parts(tmp_path):
    a = castle()
    path = write_assembly(a, tmp_path / "c.glb")
    scene = trimesh.load(path, force="scene")
    assert len(scene.geometry) == 3  # one mesh per distinct part (Tower, Wall, Gate)
    assert len(scene.graph.nodes_geometry) == len(a)


def test_type_from_extras_overrides_name(tmp_path):
    a = Assembly([box_part("left", "Wall", (0, 0, 0)), box_part("right", "Wall", (1, 0, 0))])
    b = read_assembly(write_assembly(a, tmp_path / "w.glb"))
    assert [p.type for p in b.parts] == ["Wall", "Wall"]
    c = read_assembly(write_assembly(a, tmp_path / "w.obj"))  # OBJ: the type goes into the name
    assert [p.type for p in c.parts] == ["Wall", "Wall"]


def test_unknown_type_names_file_and_part(tmp_path):
    a = Assembly([box_part("Tower.0", "Tower", (0, 0, 0)), box_part("Dragon.0", "Dragon", (1, 0, 0))])
    path = write_assembly(a, tmp_path / "m.glb")
    g = Grammar(name="g", statements=(NeighborRule(part="Tower", multisets=(("Tower",),)),))
    with pytest.raises(ShapeError) as exc:
        read_assembly(path, grammar=g)
    msg = str(exc.value)
    assert "m.glb" in msg and "Dragon.0" in msg and "'Dragon'" in msg


def test_nan_vertices(tmp_path):
    p = tmp_path / "bad.obj"
    p.write_text("o Wall.0\nv 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    with pytest.raises(ShapeError, match=r"bad\.obj.*Wall\.0.*NaN"):
        read_assembly(p)


def test_empty_part_and_degenerate_part(tmp_path):
    p = tmp_path / "empty.obj"
    p.write_text("o Wall.0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no Wall.1\nv 0 0 0\nv 1 1 1\nv 2 2 2\nf 4 5 6\n")
    with pytest.raises(ShapeError, match=r"Wall\.1.*degenerate"):
        read_assembly(p)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), int)), node_name="Wall.0")
    a = Assembly([Part("Wall.0", "Wall", trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)))])
    from grammarkit.tiling.io import finish_assembly
    with pytest.raises(ShapeError, match=r"Wall\.0.*no geometry"):
        finish_assembly(a, "memory")


def test_not_a_mesh(tmp_path):
    for name, data in (("x.glb", b"this is not a gltf file"), ("x.obj", b"\x00\x01\x02garbage"),
                       ("x.txt", b"hello")):
        f = tmp_path / name
        f.write_bytes(data)
        with pytest.raises(ShapeError, match=name.replace(".", r"\.")):
            read_assembly(f)
    bad_line = tmp_path / "line.obj"
    bad_line.write_text("o A.0\nv 0 0 0\nv 1 0 oops\n")
    with pytest.raises(ShapeError, match=r"line\.obj:3"):
        read_assembly(bad_line)
    with pytest.raises(ShapeError, match="no such file"):
        read_assembly(tmp_path / "missing.glb")


def test_open_mesh_is_accepted_with_warning(tmp_path):
    box = trimesh.creation.box()
    a = Assembly([Part("Roof.0", "Roof", trimesh.Trimesh(box.vertices, box.faces[:-2], process=False)),
                  box_part("Wall.0", "Wall", (1, 0, 0))])
    path = write_assembly(a, tmp_path / "open.obj")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        b = read_assembly(path)
    assert any(issubclass(w.category, ShapeWarning) and "Roof.0" in str(w.message) for w in caught)
    assert "Roof.0" in b.meta["warnings"][0]
    assert shape_graph(b).number_of_edges() == 1


def test_example_parts_are_watertight():
    from grammarkit.geometry.convert import mesh_report

    root = Path(__file__).resolve().parents[2] / "grammars" / "tiling"
    files = sorted(root.glob("*/*.glb"))
    assert len(files) == 9  # castle, balltrack, facade: 2 each; wfc: tiles + 2 tilings
    for f in files:
        a = read_assembly(f)
        assert 15 <= len(a) <= 70 or f.name == "tiles.glb"
        for p in a.parts:
            assert mesh_report(p.mesh).ok, (f, p.id)


def test_triangle_limit(tmp_path):
    path = write_assembly(castle(), tmp_path / "c.glb")
    with pytest.raises(ShapeError, match="exceed the limit of 100"):
        read_assembly(path, max_triangles=100)
