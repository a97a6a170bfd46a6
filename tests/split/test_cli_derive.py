"""`grammarkit derive` for split grammars: outputs, options, clear errors, nothing half-written."""
from __future__ import annotations

import json
from pathlib import Path

import trimesh
from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit.geometry.convert import mesh_report

SMALL = """
grammar small
attr h = 6 @range(3, 12)
attr roof = "gable" @enum("gable", "hip")
Lot --> footprint(rect(8, 6)) extrude(h) comp(f) { top: Roof | side: Facade | bottom: NIL | volume: Mass. }
Roof --> case roof == "gable": roofGable(30) color("#aa3322") R. else: roofHip(30) color("#aa3322") R.
Facade --> split(x) { ~1: Wall. | { 1: recess(0.2) color("#223344") Glass. | ~2: Wall. }* }
"""


def _write(tmp_path: Path) -> Path:
    p = tmp_path / "small.grammar"
    p.write_text(SMALL)
    return p


def test_derive_writes_model_preview_tree(tmp_path):
    g = _write(tmp_path)
    out, png, tree = tmp_path / "m.glb", tmp_path / "m.png", tmp_path / "tree.json"
    r = CliRunner().invoke(main, ["derive", str(g), "-o", str(out), "--preview", str(png), "--tree", str(tree),
                                  "--seed", "3", "--set", "h=9", "--set", "roof=hip"])
    assert r.exit_code == 0, r.output
    assert out.stat().st_size > 0 and png.stat().st_size > 0
    data = json.loads(tree.read_text())
    assert data["attrs"]["h"] == 9 and data["attrs"]["roof"] == "hip" and data["seed"] == 3
    assert {"rule", "origin", "axes", "size", "seed", "line"} <= set(data["nodes"][0])
    from grammarkit.geometry.meshio import load_mesh
    loaded = load_mesh(out)
    mesh = loaded if isinstance(loaded, trimesh.Trimesh) else loaded.to_geometry()
    assert mesh_report(mesh).watertight


def test_derive_formats_by_suffix_and_flag(tmp_path):
    g = _write(tmp_path)
    for name, extra in (("m.stl", []), ("m.ply", []), ("m.obj", []), ("m.bin", ["--format", "stl"])):
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / name), *extra])
        assert r.exit_code == 0, r.output
        assert (tmp_path / name).stat().st_size > 0
    r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "m.xyz")])
    assert r.exit_code != 0 and "format" in r.output


def test_bad_set_values_are_clear_and_write_nothing(tmp_path):
    g = _write(tmp_path)
    out = tmp_path / "bad.glb"
    for args, msg in ((["--set", "h=40"], "outside its range [3, 12]"),
                      (["--set", "roof=flat"], "not one of"),
                      (["--set", "h=abc"], "is a number"),
                      (["--set", "nope=1"], "has no attr 'nope'"),
                      (["--set", "h"], "KEY=VALUE")):
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(out), *args])
        assert r.exit_code != 0, args
        assert msg in r.output, (args, r.output)
        assert "Traceback" not in r.output
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".bad")]


def test_runtime_error_names_file_line(tmp_path):
    p = tmp_path / "err.grammar"
    p.write_text("attr w = 0 @range(0, 3)\nLot --> footprint(rect(4, 4)) extrude(2 / w) A.\n")
    r = CliRunner().invoke(main, ["derive", str(p), "-o", str(tmp_path / "e.glb")])
    assert r.exit_code == 1
    assert f"{p}:2:" in r.output and "division by zero" in r.output
    assert not (tmp_path / "e.glb").exists()


def test_variations_folder_and_manifest(tmp_path):
    g = _write(tmp_path)
    out = tmp_path / "vars"
    r = CliRunner().invoke(main, ["derive", str(g), "-o", str(out), "--variations", "3", "--seed", "1"])
    assert r.exit_code == 0, r.output
    manifest = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    assert len(manifest) == 3 and [v["index"] for v in manifest] == [0, 1, 2]
    files = sorted(p.name for p in out.glob("*.glb"))
    assert files == ["small_0000.glb", "small_0001.glb", "small_0002.glb"]
    assert [v["file"] for v in manifest] == files
    hs = [v["attrs"]["h"] for v in manifest]
    assert all(3 <= h <= 12 and isinstance(h, int) for h in hs)
    samples = {(v["attrs"]["h"], v["attrs"]["roof"], v["seed"]) for v in manifest}
    assert len(samples) == 3
    assert all(v["metrics"]["triangles"] > 0 for v in manifest)
    assert json.loads((out / "run.json").read_text())["options"]["variations"] is True


class _FakeBackend:
    """A back end plugin recording the Request it gets."""

    seen: list = []

    @staticmethod
    def run(request):
        from grammarkit.run import Result

        _FakeBackend.seen.append(request)
        advance = request.progress("sampling", request.n)
        for i in range(request.start, request.n):
            advance(1, ok=1)
            yield Result(id=f"fake_{i}", index=i, model=trimesh_box(i), seed=request.seed)
        return {"models": request.n}


def trimesh_box(i):
    import trimesh

    return trimesh.creation.box(extents=(1 + i, 1, 1))


def test_tiling_grammar_goes_to_backend(tmp_path):
    from pydantic import BaseModel

    from grammarkit import hookimpl
    from grammarkit.plugins import get_plugin_manager
    from grammarkit.run import BackendSpec

    class FakeOptions(BaseModel):
        temperature: float = 1.0

    class Plugin:
        @staticmethod
        @hookimpl
        def grammarkit_backends():
            return [BackendSpec("fake-test", "records requests", frozenset({"tiling"}), _FakeBackend.run,
                                options=FakeOptions)]

    pm = get_plugin_manager()
    pm.register(Plugin, name="fake-backend-test")
    try:
        g = tmp_path / "castle.grammar"
        g.write_text("part Wall = box(4, 0.8, 3)\npart Tower = box(2, 2, 6)\n")
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "out"), "--backend", "fake-test",
                                      "-n", "3", "--iterations", "7", "--seed", "5", "--workers", "2",
                                      "--option", "temperature=0.5"])
        assert r.exit_code == 0, r.output
        req = _FakeBackend.seen[-1]
        assert req.grammar.family == "tiling" and req.n == 3 and req.iterations == 7 and req.seed == 5
        assert req.executor.workers == 2 and req.options.temperature == 0.5
        assert "wrote 3 results" in r.output  # a line for people; --json gives the document
        assert sorted(p.name for p in (tmp_path / "out").glob("*.glb")) == ["fake_0.glb", "fake_1.glb", "fake_2.glb"]
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "o2"), "--backend", "fake-test",
                                      "--option", "temperature=hot"])
        assert r.exit_code == 1 and "temperature=hot" in r.output and "expects a number" in r.output
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "o2"), "--backend", "nope"])
        assert r.exit_code == 1 and "unknown back end 'nope'" in r.output
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "o2"), "--backend", "fake-test",
                                      "--set", "h=3"])
        assert r.exit_code != 0 and "applies to split grammars" in r.output
        assert not (tmp_path / "o2").exists()
    finally:
        pm.unregister("fake-backend-test")


def test_variations_with_workers_match_single_process(tmp_path):
    g = _write(tmp_path)
    runs = {}
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        r = CliRunner().invoke(main, ["derive", str(g), "-o", str(out), "--variations", "2", "--seed", "9",
                                      "--workers", workers])
        assert r.exit_code == 0, r.output
        runs[workers] = (out / "manifest.jsonl").read_text()
        files = {p.name: p.read_bytes() for p in out.glob("*.glb")}
        runs[workers + "files"] = files
    strip = lambda text: [{k: v for k, v in json.loads(line).items() if k != "metrics"}  # noqa: E731
                          for line in text.splitlines()]
    assert strip(runs["1"]) == strip(runs["2"])
    assert runs["1files"] == runs["2files"]


def test_output_folders_are_created(tmp_path):
    g = _write(tmp_path)
    out = tmp_path / "new" / "dir" / "m.glb"
    r = CliRunner().invoke(main, ["derive", str(g), "-o", str(out), "--preview", str(tmp_path / "pics" / "m.png")])
    assert r.exit_code == 0, r.output
    assert out.exists() and (tmp_path / "pics" / "m.png").exists()
