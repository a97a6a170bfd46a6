"""Real rule packages (grammars/cga/packages/*.rpk) as they come: `grammarkit import-cga` of the
package into another folder, `grammarkit derive` from a third working folder, and the model's
bounding box against CityEngine's (PyPRT's numbers recorded by benchmarks/bench_prt.py in
data/prt_reference.json; these tests never need PyPRT). Also: a project folder, a .cga inside
one, a zip package, --strict, styles and the face selectors of volumes on roof faces."""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cli import main as cli_main
from grammarkit.functions import lshape

from ._cga_helpers import bbox as _bbox, imported

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ROOT / "grammars" / "cga" / "packages"
REFERENCE = json.loads((Path(__file__).parent / "data" / "prt_reference.json").read_text())["packages"]
LOTS = {"rect": [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)],
        "lshape": [tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]}
# heights drawn by rand(): CityEngine's generator and grammarkit's draw different numbers, so
# only the footprint (x, y) and the floor are compared
RANDOM_HEIGHT = {"extrusion_rule", "simple_rule2019"}
# known differences, each a reason (the packages still import and derive as they come)
# (package, lot) pairs with a known difference from CityEngine, each with its cause: none now
# (parthenon on the L lot was 0.54 m off until roofGable gabled each wing of an L-shaped face)
KNOWN: dict[tuple[str, str], str] = {}

py7zr = pytest.importorskip("py7zr", reason="7z rule packages need the optional py7zr (grammarkit[cga])")


def run(*args, cwd: Path):
    old = os.getcwd()
    os.chdir(cwd)
    try:
        return CliRunner().invoke(cli_main, [str(a) for a in args], catch_exceptions=False)
    finally:
        os.chdir(old)



def _import(rpk: Path, tmp_path: Path) -> Path:
    out = tmp_path / "out" / f"{rpk.stem}.grammar"
    out.parent.mkdir()
    work = tmp_path / "elsewhere"
    work.mkdir()
    res = run("import-cga", rpk, "-o", out, "--report", tmp_path / "report.json", cwd=work)
    assert res.exit_code == 0, res.output
    return out


def test_the_committed_corpus():
    names = sorted(p.stem for p in PACKAGES.glob("*.rpk"))
    assert {"candler", "extrusion_rule"} <= set(names)
    assert len(names) >= 8
    readme = (ROOT / "grammars" / "cga" / "README.md").read_text()
    for n in names:
        assert f"`packages/{n}.rpk`" in readme
        assert n in REFERENCE  # PyPRT's numbers were recorded for every committed package


@pytest.mark.parametrize("lot_name", sorted(LOTS))
@pytest.mark.parametrize("rpk", sorted(PACKAGES.glob("*.rpk")), ids=lambda p: p.stem)
def test_package_imports_and_derives_as_it_comes(rpk, lot_name, tmp_path, monkeypatch):
    out = _import(rpk, tmp_path)
    text = out.read_text()
    # derive from a third working folder: the grammar finds its assets on its own
    third = tmp_path / "third"
    third.mkdir()
    monkeypatch.chdir(third)
    model = grammarkit.derive(grammarkit.parse(text, filename=str(out)), seed=0, lot=LOTS[lot_name])
    assert model.triangle_count > 0
    ref = np.array(REFERENCE[rpk.stem][lot_name]["bbox"])
    got = _bbox(model)
    cols = [0, 1] if rpk.stem in RANDOM_HEIGHT else [0, 1, 2]
    diff = float(np.abs(got[:, cols] - ref[:, cols]).max())
    if (rpk.stem, lot_name) in KNOWN and diff > 0.1:  # passes as soon as the cause is fixed
        pytest.xfail(f"{KNOWN[(rpk.stem, lot_name)]} (bbox difference {diff:.2f} m)")
    assert diff <= 0.1, (got.tolist(), ref.tolist())


def test_report_tells_what_was_found(tmp_path):
    _import(PACKAGES / "candler.rpk", tmp_path)
    rep = json.loads((tmp_path / "report.json").read_text())
    assets = {a["path"]: a for a in rep["assets"]}
    # literal names resolve in the project's assets/, as CityEngine resolves them
    assert assets["primitives/cylinder.hor.obj"]["found"] is True
    assert "/assets/primitives/" in assets["primitives/cylinder.hor.obj"]["resolved"]
    # every claim of `found` is a real file; names only known at derive time claim nothing
    for a in rep["assets"]:
        if a["found"]:
            assert Path(a["resolved"]).is_file()
        if a.get("computed") and a["found"] is None:
            assert a["resolved"] is None


def _unpacked(rpk: Path, dest: Path) -> Path:
    with py7zr.SevenZipFile(rpk) as z:
        z.extractall(dest)
    return dest


def test_project_folder_and_cga_inside_it(tmp_path):
    proj = _unpacked(PACKAGES / "candler.rpk", tmp_path / "Candler")
    for source in (proj, proj / "rules" / "candler.cga"):
        out = tmp_path / f"o_{source.name}" / "c.grammar"
        out.parent.mkdir()
        res = run("import-cga", source, "-o", out, cwd=tmp_path)
        assert res.exit_code == 0, res.output
        text = out.read_text()
        # the project's assets folder is where computed names are looked up at derive time
        assert "Candler/assets" in text


def test_zip_package(tmp_path):
    src = _unpacked(PACKAGES / "extrusion_rule.rpk", tmp_path / "src")
    z = tmp_path / "pkg.rpk"
    with zipfile.ZipFile(z, "w") as zf:
        for f in src.rglob("*"):
            if f.is_file():
                zf.write(f, f.relative_to(src).as_posix())
    out = tmp_path / "o" / "pkg.grammar"
    res = run("import-cga", z, "-o", out, cwd=tmp_path)
    assert res.exit_code == 0, res.output
    model = grammarkit.derive(grammarkit.parse(out.read_text(), filename=str(out)), seed=0, lot=LOTS["rect"])
    assert model.triangle_count == 12


def test_bad_package_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.rpk"
    bad.write_bytes(b"not an archive")
    res = run("import-cga", bad, "-o", tmp_path / "x.grammar", cwd=tmp_path)
    assert res.exit_code == 1 and "not a rule package" in res.output
    empty = tmp_path / "proj"
    (empty / "rules").mkdir(parents=True)
    res = run("import-cga", empty, "-o", tmp_path / "y.grammar", cwd=tmp_path)
    assert res.exit_code == 1 and "no rules/*.cga" in res.output


def test_strict_makes_warnings_errors(tmp_path):
    cga = tmp_path / "w.cga"
    cga.write_text("Lot --> extrude(10) copyUV(0, 1) X\n")
    out = tmp_path / "w.grammar"
    assert run("import-cga", cga, "-o", out, cwd=tmp_path).exit_code == 0 and out.exists()
    out.unlink()
    res = run("import-cga", cga, "-o", out, "--strict", cwd=tmp_path)
    assert res.exit_code == 1 and not out.exists() and "error: not translated" in res.output


STYLED = """attr h = 10
@Range(min=1, max=50)
attr w = 3
Lot --> extrude(h) X

style Tall
attr h = 40
attr w = 60
"""


def test_styles_default_and_chosen():
    default = imported(STYLED)
    assert "attr h = 10" in default.text
    tall = imported(STYLED, style="Tall")
    # the style's value; the annotated attr keeps its range (widened to the new default)
    assert "attr h = 40" in tall.text and "attr w = 60 @range(1, 60)" in tall.text
    from grammarkit.cga import translate_cga
    bad = translate_cga(STYLED, filename="t.cga", style="Nope")
    assert not bad.ok and "no style 'Nope'" in bad.diagnostics[-1].message


ROOF_TIER = """Lot --> extrude(10) comp(f) { top: Top | side: F. }
Top --> Tier
Tier --> extrude(5) comp(f) { top: Roof. | side: F. }
Balcony --> extrude(1) comp(f) { top: T. | side: F. }
Facade --> Balcony
Lot2 --> extrude(3) comp(f) { front: Facade | top: Top }
"""


def test_volume_on_a_roof_face_keeps_its_top_up():
    res = imported(ROOF_TIER)
    lines = res.text.splitlines()
    tier = [ln for ln in lines if ln.startswith("Tier")]
    # from the roof face: CGA scopes the extruded volume as a lot's (top is the cap, up)
    assert any("top: Roof" in ln for ln in tier), tier
    model = grammarkit.derive(res.grammar, seed=0, lot=LOTS["rect"])
    box = _bbox(model)
    assert abs(box[1][1] - 12.0) < 0.01 and abs(box[1][2] - 15.0) < 0.01


def test_massing_tiers_stay_on_the_lot():
    """The massing tier-3 case of issue 26 in miniature: the top of a setback remainder."""
    text = """Lot --> extrude(10) comp(f) { top: T1 | side: F. }
T1 --> setback(2) { front: N. | remainder: Tier3 }
Tier3 --> extrude(20) comp(f) { top: R. | side: F. }
"""
    res = imported(text)
    model = grammarkit.derive(res.grammar, seed=0, lot=LOTS["rect"])
    box = _bbox(model)
    assert box[1][1] <= 12.0 + 0.01 and abs(box[1][2] - 30.0) < 0.01


def test_all_faces_selector_translates_both_orientations():
    # comp(f) { all: T } hands T horizontal and vertical faces; T extrudes: the horizontal
    # faces are translated as such (their volume's top is the cap), the others as facades
    res = imported("Lot --> extrude(10) comp(f) { all: T }\nT --> extrude(2) comp(f) { top: R. | side: S. }\n")
    lot_line = next(ln for ln in res.text.splitlines() if ln.startswith("Lot -->"))
    assert "{ horizontal: T_h | all: T }" in lot_line
    assert "T_h --> extrude(2) comp(f) { top: R. | side: S. }" in res.text
    # comp(f) { 1: T }: face 1 of a lot's volume is its top, horizontal
    res = imported("Lot --> extrude(10) comp(f) { 1: T }\nT --> extrude(2) comp(f) { top: R. | side: S. }\n")
    assert "T --> extrude(2) comp(f) { top: R. | side: S. }" in res.text
