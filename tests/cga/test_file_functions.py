"""CGA's file functions (fileSearch, fileRandom, fileExists, fileName, ...) and text helpers
(getRange, getPrefix, ...) in .grammar expressions, computed i()/texture() file names, and
their translation by the importer."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from _cga_helpers import LOT, imported, line

from grammarkit import functions as F
from grammarkit.dsl import load
from grammarkit.errors import GrammarkitError
from grammarkit.split import derive

PARTS = Path(__file__).resolve().parents[2] / "grammars" / "parts"


@pytest.mark.parametrize("fn, arg, want", [  # the CGA reference's examples
    (F.file_name, "assets/obj/mygeometry.01.obj", "mygeometry.01.obj"),
    (F.file_basename, "assets/obj/mygeometry.01.obj", "mygeometry.01"),
    (F.file_directory, "assets/obj/mygeometry.01.obj", "assets/obj/"),
    (F.file_extension, "assets/obj/mygeometry.01.obj", "obj"),
    (F.file_directory, "a.obj", ""), (F.file_extension, "README", ""), (F.file_basename, ".hidden", ".hidden"),
    (F.file_name, "dir\\sub\\x.png", "x.png"),
])
def test_path_functions(fn, arg, want):
    assert fn(arg) == want


@pytest.mark.parametrize("args, want", [  # the CGA reference's examples
    (("rule your city with cityengine", "y", "city"), "our city with "),
    (("myTexture.hasName.001.jpg", "hasName.", ".jpg"), "001"),
    (("myTexture.hasName.001.jpg", ".", "."), "hasName.001"),
    (("CityEngine", "CityEn", "tyEngine"), ""),
    (("abc", "x", "c"), ""),
])
def test_get_range(args, want):
    assert F.get_range(*args) == want


def test_prefix_suffix_find():
    assert F.get_prefix("rule your city with cityengine", "city") == "rule your "
    assert F.get_prefix("myTexture.has.prefix.jpg", ".") == "myTexture"
    assert F.get_suffix("rule your city with cityengine", "city") == "engine"
    assert F.get_prefix("abc", "x") == "" and F.get_suffix("abc", "x") == ""
    assert F.find_first("rule your city with cityengine", "city") == 10
    assert F.find_last("rule your city with cityengine", "city") == 20
    assert F.find_first("abc", "x") == -1


@pytest.fixture
def project(tmp_path):
    """A CityEngine-like project: rules/ (where the grammar goes) beside assets/."""
    for rel in ("assets/textures/1.png", "assets/textures/2.png", "assets/textures/4.png",
                "assets/tower.png", "assets/tower.obj", "assets/.hidden/x.png", "data/table.csv"):
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"x")
    (tmp_path / "rules").mkdir()
    parts = tmp_path / "assets" / "parts"
    parts.mkdir()
    for glb in ("chimney.glb", "dormer.glb"):
        shutil.copy(PARTS / glb, parts / glb)
    return tmp_path


def _report(project: Path, expr: str, seed: int = 0, name: str = "t.grammar"):
    path = project / "rules" / name
    path.write_text(f'grammar t\nLot --> footprint(rect(4, 4)) report("k", {expr}) extrude(1) A.\n')
    m = derive(load(path), seed=seed)
    r = m.reports["k"]
    return r["sum"] if "sum" in r else next(iter(r["values"]))


def test_file_search_follows_cga_queries(project):
    a = (project / "assets").as_posix()
    tex = [f"{a}/textures/{n}.png" for n in (1, 2, 4)]
    assert _report(project, 'fileSearch("textures/*")') == "".join(p + ";" for p in tex)
    # a leading wildcard searches everywhere; * crosses folders; hidden folders are skipped
    assert _report(project, 'fileSearch("*.png")') == "".join(p + ";" for p in tex + [f"{a}/tower.png"])
    assert _report(project, 'fileSearch("*/?.png")') == "".join(p + ";" for p in tex)
    assert _report(project, 'fileSearch("?.png")') == ""  # no 1-character png at the top
    assert _report(project, 'fileSearch("$textures/[12].png")') == f"{tex[0]};{tex[1]};"
    assert _report(project, 'fileSearch("$textures/[2-5].png")') == f"{tex[1]};{tex[2]};"
    assert _report(project, 'fileSearch("Name=1.png")') == f"{tex[0]};"
    assert _report(project, 'fileSearch("Ext=obj")') == f"{a}/tower.obj;"
    assert _report(project, 'fileSearch("Ext=png tower*")') == f"{a}/tower.png;"  # whitespace: AND
    assert _report(project, 'fileSearch("/data/*.csv")') == f"{project.as_posix()}/data/table.csv;"
    assert _report(project, 'listSize(fileSearch("textures/*.png"))') == 3


def test_file_random_is_seeded_and_uniform_over_the_sorted_list(project):
    picks = [_report(project, 'fileName(fileRandom("textures/*.png"))', seed=s) for s in range(40)]
    assert picks == [_report(project, 'fileName(fileRandom("textures/*.png"))', seed=s) for s in range(40)]
    assert set(picks) == {"1.png", "2.png", "4.png"}
    assert _report(project, 'fileRandom("nothing/*.png")') == ""


def test_file_exists_is_relative_to_the_grammar(project):
    def exists(path):
        return _report(project, f'select(fileExists({path}), "yes", "no")')
    assert exists('"../assets/tower.obj"') == "yes"
    assert exists('"tower.obj"') == "no"  # i() would not find it either
    assert exists('"builtin:cube"') == "yes" and exists('"builtin:nothing"') == "no"
    assert exists('fileRandom("textures/*")') == "yes"  # an absolute path


def test_computed_insert_and_texture(project):
    import trimesh

    path = project / "rules" / "t.grammar"
    path.write_text('grammar t\nattr which = "chimney"\n'
                    'Lot --> footprint(rect(4, 4)) extrude(3) texture(fileRandom("textures/*.png")) '
                    'i("../assets/parts/" + which + ".glb") A.\n')
    m = derive(load(path), seed=1)
    assert m.mesh.bounds.ravel().tolist() == pytest.approx([0, 0, 0, 4, 4, 3], abs=2e-3)
    ref = trimesh.load(PARTS / "chimney.glb", force="mesh")
    assert len(m.mesh.faces) == len(ref.faces)  # the chimney, scaled into the scope
    out = m.save(project / "m.glb")
    back = trimesh.load(out, force="mesh")
    assert back.is_watertight
    # the texture is one of the three, picked with the shape's generator
    maps = {dict(t.texturing.mat).get("colormap") for t in m.tags}
    assert maps and maps <= {(project / f"assets/textures/{n}.png").as_posix() for n in (1, 2, 4)}
    # i(fileRandom(...)): any of the two parts, deterministic per seed
    path.write_text('grammar t\nLot --> footprint(rect(4, 4)) extrude(3) i(fileRandom("parts/*.glb")) A.\n')
    counts = {len(derive(load(path), seed=s).mesh.faces) for s in range(12)}
    assert len(counts) == 2


def test_missing_computed_file_is_a_located_error(project):
    path = project / "rules" / "t.grammar"
    path.write_text('grammar t\nattr which = "nothere"\n'
                    'Lot --> footprint(rect(4, 4)) extrude(3) i("../assets/parts/" + which + ".glb") A.\n')
    with pytest.raises(GrammarkitError) as e:
        derive(load(path))
    assert "mesh file not found" in str(e.value)
    assert e.value.span is not None and (e.value.span.line, e.value.span.column) == (3, 42)


def test_bad_queries_are_located_errors(project, monkeypatch):
    with pytest.raises(GrammarkitError) as e:
        _report(project, 'fileSearch(3)')
    assert "must be a string" in str(e.value) and e.value.span.line == 2
    with pytest.raises(GrammarkitError) as e:
        _report(project, 'fileSearch("$[unclosed")')
    assert "bad regular expression" in str(e.value) and e.value.span is not None
    monkeypatch.setattr(F, "MAX_FILE_SEARCH", 3)
    with pytest.raises(GrammarkitError) as e:
        _report(project, 'fileSearch("*.png")')
    assert "more than 3 files" in str(e.value) and e.value.span is not None


def test_check_accepts_file_functions_and_counts_arguments(project):
    from grammarkit.dsl import check

    ok = 'grammar t\nLot --> footprint(rect(4, 4)) extrude(3) i(fileRandom("parts/*.glb")) A.\n'
    assert [d for d in check(ok) if d.severity == "error"] == []
    bad = check('grammar t\nLot --> footprint(rect(4, 4)) report("k", fileSearch()) A.\n')
    assert any(d.code == "function-arity" and d.span.line == 2 for d in bad)


def test_cli_derive_with_computed_names(project):
    from click.testing import CliRunner

    from grammarkit.cli import main

    path = project / "rules" / "t.grammar"
    path.write_text('grammar t\nLot --> footprint(rect(4, 4)) extrude(3) i(fileRandom("parts/*.glb")) A.\n')
    r = CliRunner().invoke(main, ["derive", str(path), "-o", str(project / "out.glb"), "--seed", "2"])
    assert r.exit_code == 0, r.output
    assert (project / "out.glb").is_file()


# -- the importer ------------------------------------------------------------------------------
def test_importer_translates_file_functions_and_computed_names():
    r = imported('attr tex = fileRandom("Roofs/Flat/flat*.jpg")\n'
                 'attr part = "parts/a.obj"\n'
                 'floors(t) = float(getRange(fileName(t), "f", "_t"))\n'
                 'Lot --> extrude(10) comp(f) { top: Roof | side: Wall }\n'
                 'Roof --> texture(tex) set(material.bumpmap, fileSearch("b*.jpg")) X.\n'
                 'Wall --> report("n", floors(tex)) i(part) i(fileRandom("parts/*.obj")) Y.\n')
    assert 'fileRandom("Roofs/Flat/flat*.jpg")' in r.text
    assert "texture(tex)" in line(r, "Roof") and 'fileSearch("b*.jpg")' in line(r, "Roof")
    wall = line(r, "Wall")
    assert 'float(getRange(fileName(tex), "f", "_t"))' in wall
    assert "i(part_, missing=skip)" in wall and 'i(fileRandom("parts/*.obj"), missing=skip)' in wall
    features = {c.feature for c in r.report.constructs if c.status != "translated"}
    assert not features & {"i:expression", "texture:expression", "fn:fileRandom", "fn:fileSearch",
                           "fn:getRange"}
    # the attr's default names a file: listed in the report's assets like a literal
    assert any(a["path"] == "parts/a.obj" for a in r.report.assets)


def test_importer_drops_a_missing_known_computed_asset_when_asked():
    text = 'attr part = "parts/none.obj"\nLot --> extrude(1) i(part) X.\n'
    keep = imported(text)
    assert "i(part_, missing=skip)" in line(keep, "Lot")
    assert "i(part_) X." in line(imported(text, missing_assets="error"), "Lot")
    drop = imported(text, missing_assets="drop")
    assert "i(" not in line(drop, "Lot")
    assert any(c.feature == "asset:missing" for c in drop.report.constructs)


def test_undefined_rule_with_arguments_is_a_leaf():
    """CGA: a call of a rule no rule defines leaves the shape as it is (a leaf); the
    arguments are not used."""
    r = imported('Lot --> extrude(3) split(x) { 2: Glazing(1.4) | ~1: Wall }\n')
    assert "Glazing." in line(r, "Lot")
    assert not any(c.feature == "rule:undefined" for c in r.report.constructs)
    m = derive(load(r.text), lot=LOT)
    assert {t.name for t in m.tags} >= {"Glazing", "Wall"}


def test_importer_guards_an_unknown_computed_asset_when_dropping_missing_ones(tmp_path):
    """With missing_assets="drop", an i() whose file is only known while deriving runs only
    when the file exists (`(case fileExists(p): i(p))`); the shape is kept as it is otherwise,
    as a dropped i() of a known missing file leaves it."""
    text = ('Lot --> extrude(2) split(x) { 1: Part("parts/chimney.glb") | ~1: Part("parts/none.glb") }\n'
            'Part(asset) --> i(asset) X.\n')
    r = imported(text, missing_assets="drop")
    assert "Part(asset) --> (case fileExists(asset): i(asset)) X." in r.text
    (tmp_path / "parts").mkdir()
    shutil.copy(PARTS / "chimney.glb", tmp_path / "parts" / "chimney.glb")
    path = tmp_path / "t.grammar"
    path.write_text(r.text)
    m = derive(load(path), lot=[(0, 0), (3, 0), (3, 2), (0, 2)])
    import trimesh
    chimney = trimesh.load(PARTS / "chimney.glb", force="mesh")
    # the chimney in the first metre, the second part's box kept as it was (12 triangles)
    assert len(m.mesh.faces) >= len(chimney.faces)
    assert m.mesh.bounds.ravel().tolist() == pytest.approx([0, 0, 0, 3, 2, 2], abs=2e-3)
    assert "Part(asset) --> i(asset, missing=skip) X." in imported(text).text
