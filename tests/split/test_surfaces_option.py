"""`--surfaces solid|cga` on the command line and the split back end's `surfaces=` option:
the same choice as `grammarkit.derive(..., surfaces=)` for one model, -n, --variations and
batch (issue 27: CityEngine's open faces on request, one watertight solid by default)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import trimesh

RULE = "Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { side: Wall. | top: Roof. }\n"


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "grammarkit", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=600)


def test_the_command_line_chooses_open_faces_or_the_solid(tmp_path):
    (tmp_path / "box.grammar").write_text(RULE, encoding="utf-8")
    solid = _run("derive", "box.grammar", "-o", "solid.glb", cwd=tmp_path)
    cga = _run("derive", "box.grammar", "-o", "cga.glb", "--surfaces", "cga", cwd=tmp_path)
    assert solid.returncode == 0 and cga.returncode == 0, solid.stderr + cga.stderr
    s = trimesh.load(tmp_path / "solid.glb", force="mesh")
    c = trimesh.load(tmp_path / "cga.glb", force="mesh")
    assert s.is_watertight and len(s.faces) == 12           # closed, its bottom included
    assert not c.is_watertight and len(c.faces) == 10       # CityEngine's open box
    var = _run("derive", "box.grammar", "-o", "var", "--variations", "2", "--surfaces", "cga", cwd=tmp_path)
    assert var.returncode == 0, var.stderr
    for p in sorted((tmp_path / "var").glob("*.glb")):
        assert len(trimesh.load(p, force="mesh").faces) == 10
    bad = _run("derive", "box.grammar", "-o", "x.glb", "--surfaces", "open", cwd=tmp_path)
    assert bad.returncode == 2 and "open" in bad.stderr and "Traceback" not in bad.stderr


def test_the_split_back_end_option_reaches_every_item():
    from grammarkit.run.split_backend import SplitOptions

    assert SplitOptions().surfaces == "solid"
    assert SplitOptions(surfaces="cga").surfaces == "cga"
