"""`grammarkit retarget`: outputs, pictures, and every bad input refused with an error that
names the file, nothing written."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner
from PIL import Image

from grammarkit.cli import main
from grammarkit.geometry.convert import mesh_report
from grammarkit.geometry.exporters import exporter_for
from grammarkit.geometry.meshio import load_mesh
from grammarkit_retarget import testmodels


def run(*args):
    return CliRunner().invoke(main, ["retarget", *map(str, args)])


def _write(path, mesh):
    path.write_bytes(exporter_for(path).encode(mesh))
    return path


@pytest.fixture
def fence(tmp_path, models):
    return _write(tmp_path / "fence.glb", models["picket_fence"].mesh)


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def test_retarget_writes_model_preview_and_explanation(tmp_path, fence, models):
    out, prev, expl = tmp_path / "wide.glb", tmp_path / "p.png", tmp_path / "e.png"
    r = run(fence, "--scale", 2, 1, 1, "-o", out, "--preview", prev, "--explain", expl)
    assert r.exit_code == 0, r.output
    assert "wrote" in r.output and "stitched" in r.output
    mesh = load_mesh(out, single=True)
    assert mesh_report(mesh).ok
    before = testmodels.measure(models["picket_fence"].mesh, models["picket_fence"].probes[0])
    after = testmodels.measure(mesh, models["picket_fence"].probes[0])
    assert after["count"] == 25 and np.allclose(after["sizes"], 0.08, rtol=0.05)
    assert before["count"] == 12
    for png in (prev, expl):
        with Image.open(png) as img:
            assert img.format == "PNG" and img.width >= 600


def test_size_option_and_json_summary(tmp_path, fence):
    import json

    out = tmp_path / "w.stl"
    r = run(fence, "--size", 4.7, 0.105, 1.2, "-o", out, "--json")
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    assert summary["method"] == "retarget" and summary["steps"][0] == 6
    assert summary["size"][0] == pytest.approx(4.7, abs=1e-5)
    assert summary["offsets"]["principal"][0][0] == pytest.approx(0.25, abs=1e-6)
    assert trimesh.load(out).is_watertight


def test_no_repetitive_structure_is_refused_unless_allow_scale(tmp_path):
    ball = _write(tmp_path / "ball.glb", trimesh.creation.icosphere(subdivisions=3))
    out = tmp_path / "o.glb"
    r = run(ball, "--scale", 2, 1, 1, "-o", out)
    assert r.exit_code == 1
    assert f"{ball}: no principal offset found" in r.output and "--allow-scale" in r.output
    assert "Traceback" not in r.output and not out.exists()
    r = run(ball, "--scale", 2, 1, 1, "-o", out, "--allow-scale")
    assert r.exit_code == 0, r.output and "scaled (no principal offset)" in r.output
    assert np.allclose(load_mesh(out, single=True).extents, [4, 2, 2], rtol=1e-3)


def test_open_mesh_is_refused_unless_stitched_as_a_surface(tmp_path, models):
    mesh = models["picket_fence"].mesh.copy()
    keep = np.ones(len(mesh.faces), dtype=bool)
    keep[np.argmin(mesh.triangles_center[:, 2])] = False  # a hole in the bottom of a post
    open_fence = trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False)
    path = _write(tmp_path / "open.obj", open_fence)
    out = tmp_path / "o.obj"
    r = run(path, "--scale", 1.5, 1, 1, "-o", out)
    assert r.exit_code == 1 and f"{path}: the mesh is not closed" in r.output
    assert "--open-surface" in r.output and not out.exists()
    r = run(path, "--scale", 1.5, 1, 1, "-o", out, "--open-surface")
    assert r.exit_code == 0, r.output
    got = load_mesh(out, single=True)
    assert not got.is_watertight  # open where the input was open
    assert got.extents[0] == pytest.approx(4.7, abs=1e-4)
    assert len(got.faces) > len(open_fence.faces)


@pytest.mark.parametrize("args,message", [
    (("--size", 0, 1, 1), "must be positive on every axis"),
    (("--size", 3, -1, 1), "must be positive on every axis"),
    (("--scale", 1, 1, 0), "must be positive on every axis"),
    (("--size", "nan", 1, 1), "is not finite"),
])
def test_bad_target_size(tmp_path, fence, args, message):
    out = tmp_path / "o.glb"
    r = run(fence, *args, "-o", out)
    assert r.exit_code == 1 and f"{fence}:" in r.output and message in r.output, r.output
    assert _files(tmp_path) == ["fence.glb"]


def test_nan_empty_and_missing_meshes_name_the_file(tmp_path):
    nan = tmp_path / "nan.obj"
    nan.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n")
    empty = tmp_path / "empty.obj"
    empty.write_text("v 0 0 0\nv 1 0 0\n")
    missing = tmp_path / "missing.glb"
    for path, message in ((nan, "NaN"), (empty, "no triangle"), (missing, "not found")):
        out = tmp_path / "o.glb"
        r = run(path, "--scale", 2, 1, 1, "-o", out)
        assert r.exit_code == 1 and str(path) in r.output and message in r.output, r.output
        assert "Traceback" not in r.output and not out.exists()


def test_usage_errors(tmp_path, fence):
    out = tmp_path / "o.glb"
    assert run(fence, "-o", out).exit_code == 2
    assert run(fence, "--size", 1, 1, 1, "--scale", 1, 1, 1, "-o", out).exit_code == 2
    r = run(fence, "--scale", 2, 1, 1, "-o", out, "--preview", tmp_path / "p.jpg")
    assert r.exit_code == 2 and "PNG" in r.output
    r = run(fence, "--scale", 2, 1, 1, "-o", fence)
    assert r.exit_code == 1 and "overwrite the input" in r.output
    r = run(fence, "--scale", 2, 1, 1, "-o", tmp_path / "o.xyz")
    assert r.exit_code == 1 and "suffix" in r.output
    assert _files(tmp_path) == ["fence.glb"]


def test_failure_after_the_work_writes_nothing(tmp_path, fence, monkeypatch):
    # the pictures are made before anything is written: a failing picture leaves no model
    from grammarkit_retarget import pictures

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(pictures, "explain_png", broken)
    out = tmp_path / "o.glb"
    r = run(fence, "--scale", 2, 1, 1, "-o", out, "--explain", tmp_path / "e.png")
    assert r.exit_code != 0 and not out.exists()
    assert _files(tmp_path) == ["fence.glb"]
