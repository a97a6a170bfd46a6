"""Model.save / face_labels / _repr_png_, assemblies through the exporters, old files, and
byte-identical output for the same seed."""
from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

import grammarkit
from grammarkit.errors import ShapeError
from grammarkit.geometry.convert import mesh_report
from grammarkit.geometry.exporters import Z_UP_TO_Y_UP_MATRIX, encode, srgb_to_linear
from grammarkit.geometry.meshio import face_labels, gltf_root_extras, load_mesh

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"


@pytest.fixture(scope="module")
def paris():
    return grammarkit.derive(PARIS, seed=0)


def test_srgb_to_linear_reference_values():
    assert np.allclose(srgb_to_linear([0.0, 0.04045, 0.5, 1.0]), [0.0, 0.04045 / 12.92, 0.214041, 1.0], atol=1e-6)


def test_save_every_format_and_unknown_suffix(paris, tmp_path):
    for fmt in ("glb", "gltf", "obj", "stl", "ply"):
        path = paris.save(tmp_path / f"p.{fmt}")
        assert path.is_file() and path.stat().st_size > 1000
        assert mesh_report(load_mesh(path, single=True)).ok, fmt
    assert paris.save(tmp_path / "odd.bin", format="glb").read_bytes()[:4] == b"glTF"
    with pytest.raises(ShapeError, match="suffix"):
        paris.save(tmp_path / "p.xyz")
    assert not (tmp_path / "p.xyz").exists()


def test_same_seed_same_bytes():
    a = encode(grammarkit.derive(PARIS, seed=3), "glb")
    b = encode(grammarkit.derive(PARIS, seed=3), "glb")
    assert a == b
    assert encode(grammarkit.derive(PARIS, seed=4), "glb") != a


def test_face_labels_and_colours_survive_the_file(paris, tmp_path):
    path = paris.save(tmp_path / "p.glb")
    labels = face_labels(path)
    mesh = load_mesh(path, single=True)
    assert sorted(labels) == sorted(paris.face_labels())
    assert len(labels) == len(mesh.faces)
    # a face's label and colour in the file are the model's for the same triangle
    key = lambda v, f: [tuple(np.round(np.sort(v[t], axis=0), 4).ravel()) for t in f]  # noqa: E731
    model_of = dict(zip(key(paris.vertices, paris.faces),
                        zip(paris.face_labels(), map(tuple, np.asarray(paris.mesh.visual.face_colors)))))
    for k, label, colour in zip(key(mesh.vertices, mesh.faces), labels, map(tuple, mesh.visual.face_colors)):
        assert model_of[k] == (label, colour)
    assert gltf_root_extras(path)["format"] == 3
    with pytest.raises(ShapeError, match="not found"):
        face_labels(tmp_path / "missing.glb")


def test_root_rotation_is_undone_on_reading(paris, tmp_path):
    path = paris.save(tmp_path / "p.glb")
    as_trimesh = trimesh.load(path).to_mesh()  # trimesh applies the root: Y up
    assert np.allclose(as_trimesh.bounds[:, 1], paris.mesh.bounds[:, 2], atol=1e-4)
    assert np.allclose(load_mesh(path, single=True).bounds, paris.mesh.bounds, atol=1e-4)


def test_old_files_without_the_rotation_still_read(tmp_path, paris):
    # a GLB as grammarkit wrote it before (trimesh's exporter, no root rotation, no marker)
    old = tmp_path / "old.glb"
    scene = trimesh.Scene()
    scene.add_geometry(paris.mesh, node_name="paris", geom_name="paris", metadata={"type": "Tower"})
    old.write_bytes(scene.export(file_type="glb"))
    assert gltf_root_extras(old) == {}
    assert np.allclose(load_mesh(old, single=True).bounds, paris.mesh.bounds, atol=1e-4)
    from grammarkit.tiling import read_assembly

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the old file's colour seams make the part "open"
        asm = read_assembly(old)
    assert [p.type for p in asm.parts] == ["Tower"]
    assert np.allclose(asm.parts[0].mesh.bounds, paris.mesh.bounds, atol=1e-4)


def test_repr_png_shows_the_building(paris):
    img = Image.open(io.BytesIO(paris._repr_png_()))
    assert img.size == (480, 480)
    px = np.asarray(img.convert("RGB")).reshape(-1, 3)
    assert (px != 255).any(axis=1).mean() > 0.1  # a building, not a blank page


def test_assembly_files_node_per_part_type_colours_and_read_back(tmp_path):
    from grammarkit.tiling import read_assembly, write_assembly

    asm = read_assembly(ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb")
    for suffix in (".glb", ".gltf", ".obj", ".ply", ".stl", ""):
        path = write_assembly(asm, tmp_path / f"c{suffix}")
        if suffix in (".glb", ".gltf", ".obj", ""):
            back = read_assembly(path)
            got = back.by_id()
            if suffix:  # files keep the order; a folder is read in natural file-name order
                assert list(got) == [p.id for p in asm.parts], suffix
            assert sorted(got) == sorted(p.id for p in asm.parts), suffix
            for a in asm.parts:
                assert got[a.id].type == a.type, (suffix, a.id)
                assert np.allclose(a.mesh.bounds, got[a.id].mesh.bounds, atol=1e-4), (suffix, a.id)
    data = (tmp_path / "c.glb").read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    root = doc["nodes"][doc["scenes"][0]["nodes"][0]]
    parts = [doc["nodes"][i] for i in root["children"]]
    assert [n["extras"]["type"] for n in parts] == [p.type for p in asm.parts]
    types = sorted({p.type for p in asm.parts})
    assert sorted(m["name"] for m in doc["materials"]) == types  # a colour (material) per part type
    assert len({tuple(m["pbrMetallicRoughness"]["baseColorFactor"]) for m in doc["materials"]}) == len(types)
    img = Image.open(io.BytesIO(asm._repr_png_()))
    assert img.size == (480, 480)


def test_learn_and_validate_show_progress_only_on_a_terminal(tmp_path, monkeypatch):
    from click.testing import CliRunner
    from rich.console import Console

    import grammarkit.cli.tiling as cli_tiling
    from grammarkit.cli import main

    shape = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
    runner = CliRunner()
    plain = runner.invoke(main, ["learn", str(shape), "-o", str(tmp_path / "a.grammar")])
    assert plain.exit_code == 0, plain.output
    assert "reading" not in plain.output and "learning" not in plain.output
    buf = io.StringIO()
    monkeypatch.setattr(cli_tiling, "_console", lambda: Console(file=buf, force_terminal=True, width=120))
    shown = runner.invoke(main, ["learn", str(shape), "-o", str(tmp_path / "b.grammar")])
    assert shown.exit_code == 0, shown.output
    text = buf.getvalue()
    assert "reading" in text and "castle_small.glb" in text and "learning from 20 parts" in text
    a_text = (tmp_path / "a.grammar").read_text().replace("grammar a\n", "", 1)
    assert a_text == (tmp_path / "b.grammar").read_text().replace("grammar b\n", "", 1)
    buf.truncate(0)
    checked = runner.invoke(main, ["validate", str(tmp_path / "b.grammar"), str(shape)])
    assert checked.exit_code == 0, checked.output
    assert "validating castle_small (20 parts" in buf.getvalue()
