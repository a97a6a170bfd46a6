"""Tiling API/CLI and `grammarkit render` with bad arguments: GrammarkitErrors that say what is
wrong, never a traceback or a silently wrong result."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh

from grammarkit.dsl import load
from grammarkit.errors import GrammarError, GrammarkitError, ShapeError
from grammarkit.geometry.camera import Camera
from grammarkit.tiling import dock, learn, read_assembly, rules_from_grammar, shape_graph, validate
from grammarkit.tiling.assembly import Assembly, Part

CASTLE = Path(__file__).resolve().parents[2] / "grammars" / "tiling" / "castle"


def _two_boxes(types=("Tower", "Wall")) -> Assembly:
    parts = []
    for i, t in enumerate(types):
        m = trimesh.creation.box((1, 1, 1))
        m.apply_translation((i * 1.0, 0, 0.5))
        parts.append(Part(f"{t}.{i}", t, m))
    return Assembly(parts, name="two")


@pytest.fixture(scope="module")
def castle_grammar():
    return load(CASTLE / "castle.grammar")


@pytest.mark.parametrize("tol", [float("nan"), -1.0, float("inf"), "a"])
def test_bad_tolerance_is_refused(castle_grammar, tol):
    asm = _two_boxes()
    with pytest.raises(ShapeError, match="tolerance"):
        shape_graph(asm, tolerance=tol)
    with pytest.raises(ShapeError, match="tolerance"):
        validate(castle_grammar, asm, tolerance=tol)
    with pytest.raises(ShapeError, match="tolerance"):
        learn([asm], tolerance=tol)


@pytest.mark.parametrize("bw", [float("nan"), float("inf"), 0, -1])
def test_bad_bandwidth_is_refused(bw):
    with pytest.raises(ShapeError, match="bandwidth"):
        learn([_two_boxes()], bandwidth=bw)


def test_learn_takes_a_single_assembly_too():
    g = learn(_two_boxes())
    assert {p.name for p in g.parts} == {"Tower", "Wall"}


def test_api_type_errors_are_grammarkit_errors(castle_grammar):
    asm = _two_boxes()
    for call in (lambda: read_assembly(None), lambda: shape_graph("x"), lambda: validate("text", asm),
                 lambda: validate(castle_grammar, None), lambda: rules_from_grammar(None),
                 lambda: dock("abc", "def"),
                 lambda: learn([asm], example_paths=["a", "b"])):
        with pytest.raises(GrammarkitError):
            call()


def test_validate_refuses_a_split_grammar():
    g = load("Lot --> extrude(3) X.\n")
    with pytest.raises(GrammarError, match="split grammar"):
        validate(g, _two_boxes())
    with pytest.raises(GrammarError, match="without tiling statements"):
        validate(load("attr x = 1\n"), _two_boxes())  # not "OK: no rules broken"


@pytest.fixture
def bad_files(tmp_path):
    files = {}
    (tmp_path / "notmesh.glb").write_text("not a mesh")
    files["notmesh"] = tmp_path / "notmesh.glb"
    (tmp_path / "empty.glb").write_bytes(b"")
    files["empty"] = tmp_path / "empty.glb"
    js = json.dumps({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}).encode()
    js += b" " * ((4 - len(js) % 4) % 4)
    (tmp_path / "noparts.glb").write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(js))
                                           + struct.pack("<I", len(js)) + b"JSON" + js)
    files["noparts"] = tmp_path / "noparts.glb"
    box = trimesh.creation.box()
    v = box.vertices.copy()
    v[0] = [np.nan, 0, 0]
    s = trimesh.Scene()
    s.add_geometry(trimesh.Trimesh(v, box.faces, process=False), node_name="Tower.0", geom_name="g")
    s.export(tmp_path / "nan.glb")
    files["nan"] = tmp_path / "nan.glb"
    return files


@pytest.mark.parametrize("which", ["notmesh", "empty", "noparts", "nan"])
def test_learn_and_validate_name_the_bad_file(cli, bad_files, tmp_path, which):
    f = bad_files[which]
    out = tmp_path / "learned.grammar"
    for argv in (["learn", f, "-o", out], ["validate", CASTLE / "castle.grammar", f]):
        code, text = cli(*argv)
        assert code == 1 and "Traceback" not in text and f.name in text, text
    assert not out.exists()


@pytest.mark.parametrize("opt", [["--tolerance", "nan"], ["--tolerance", "inf"]])
def test_validate_cli_bad_tolerance(cli, opt):
    code, text = cli("validate", CASTLE / "castle.grammar", CASTLE / "castle_small.glb", *opt)
    assert code == 1 and "tolerance" in text and "Traceback" not in text, text


@pytest.mark.parametrize("bw", ["nan", "inf"])
def test_learn_cli_bad_bandwidth(cli, tmp_path, bw):
    code, text = cli("learn", CASTLE / "castle_small.glb", "--bandwidth", bw, "-o", tmp_path / "x.grammar")
    assert code == 1 and "bandwidth" in text and "TRACEBACK" not in text, text


def test_learn_to_an_unwritable_path(cli):
    code, text = cli("learn", CASTLE / "castle_small.glb", "-o", "/proc/grammarkit-qa.grammar")
    assert code == 1 and "cannot write" in text and "TRACEBACK" not in text, text


@pytest.mark.parametrize("kw", [{"pitch": float("nan")}, {"yaw": float("inf")}, {"distance": float("nan")},
                                {"target": (0, float("nan"), 0)}, {"ortho_height": float("inf")}])
def test_camera_refuses_non_finite_values(kw):
    with pytest.raises(ValueError):
        Camera(**kw)


@pytest.mark.parametrize("opt", [["--pitch", "nan"], ["--yaw", "inf"], ["--distance", "nan"],
                                 ["--line-width", "inf"]])
def test_render_cli_non_finite_options(cli, tmp_path, opt):
    code, text = cli("render", CASTLE / "castle_small.glb", "-o", tmp_path / "r.png", *opt)
    assert code == 2 and opt[0].lstrip("-").replace("-", " ").split()[0] in text, text
    assert not (tmp_path / "r.png").exists()


def test_render_a_tiling_grammar_says_what_to_do(cli, tmp_path):
    code, text = cli("render", CASTLE / "castle.grammar", "-o", tmp_path / "r.png")
    assert code == 1 and "tiling grammar" in text, text


def test_render_missing_model(cli, tmp_path):
    code, text = cli("render", tmp_path / "missing.glb", "-o", tmp_path / "r.png")
    assert code == 1 and "missing.glb" in text and "TRACEBACK" not in text, text
