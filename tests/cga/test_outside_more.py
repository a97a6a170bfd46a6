"""Constructs met in more public CGA files (docs/cga.md, "Rule files from outside"), each
reproduced by a small self-written snippet: @Handle annotations whose shape is a rule-name
pattern (`shape=Post*`), and CGA 2012's setback selectors streetSide/noStreetSide, which select
no edge without CityEngine's street attributes (measured with PyPRT 1.12 on the 20 x 12 lot:
the remainder is the whole lot)."""
from __future__ import annotations

import numpy as np
from click.testing import CliRunner

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.cli import main as cli_main

from ._cga_helpers import LOT, bbox, imported, line

HANDLES = """
@Handle(shape=Post*, axis=y, repeat=none, slip=inside, reference=center, occlusion=false)
@Distance
attr post_height = 1.2
@Handle(shape=Mid, axis=x)
attr w = 2
Lot --> extrude(post_height) Post
"""


def test_handle_with_a_rule_pattern_parses_and_keeps_the_attr():
    r = imported(HANDLES)
    assert "attr post_height = 1.2" in r.text and "attr w = 2" in r.text
    box = bbox(grammarkit.derive(r.grammar, lot=LOT))
    assert np.isclose(box[1][2], 1.2, atol=0.01)


def test_a_star_outside_an_annotation_is_still_multiplication():
    r = imported("attr a = 2\nattr b = a*3\nLot --> extrude(b) X\n")
    assert "attr b = a * 3" in r.text


STREET = """attr d = 3
Lot --> setback(d) { streetSide: Yard | remainder: Inner }
Inner --> setback(1) { noStreetSide: Gap | remainder: Mass }
Mass --> extrude(6)
Yard --> extrude(50)
Gap --> extrude(50)
"""


def test_legacy_street_selectors_select_no_edge():
    r = translate_cga(STREET, filename="t.cga")
    assert r.ok
    warned = [d for d in r.diagnostics if d.severity == "warning"]
    # approximations (said where), not dropped constructs
    assert len(warned) == 2 and all("selects no edge" in d.message for d in warned)
    assert all("approximated" in d.message for d in warned)
    assert line(r, "Lot") == "Lot --> setback(d) { remainder: Inner }"
    box = bbox(grammarkit.derive(r.grammar, lot=LOT))
    # as CityEngine without street attributes: the whole lot is the remainder, 6 m high
    assert np.allclose(box, [[0, 0, 0], [20, 16, 6]], atol=0.02)


def test_legacy_street_selectors_are_errors_with_strict(tmp_path):
    src = tmp_path / "street.cga"
    src.write_text(STREET, encoding="utf-8")
    out = tmp_path / "street.grammar"
    res = CliRunner().invoke(cli_main, ["import-cga", str(src), "-o", str(out), "--strict"])
    assert res.exit_code == 1 and not out.exists()
    assert "street.cga:2:22" in res.output and "streetSide selects no edge" in res.output


ELEVATION = """Lot --> t(0, 2, 0) extrude(10) comp(f) { side: Facade }
Facade --> split(y) { 3: Ground | ~1: Upper }
Upper --> Check
Ground --> Check
Check --> case scope.elevation - initialShape.origin.py > 4: report("high", 1) X. else: report("low", 1) X.
"""


def test_scope_elevation_is_the_world_height_of_the_scope_origin():
    # Esri's Facade_Schematic.cga: `case scope.elevation - initialShape.origin.py > ...`
    r = imported(ELEVATION)
    assert "scope.tz - 0" in line(r, "Check")
    reports = grammarkit.derive(r.grammar, lot=LOT).reports
    # the lot raised 2 m: ground floors start at 2, upper floors at 5, on each of 4 facades
    assert reports["high"]["n"] == 4 and reports["low"]["n"] == 4


# the preset pattern of Esri's Building_From_OpenStreetMap.cga: CityEngine stores a rule's
# attribute presets as `style` blocks; a style overrides hidden "estimated" attrs that other
# attrs derive from (a chain through functions), with values that read the lot's area
PRESETS = """
@Order(1) attr Levels = _getLevels
@Order(2) @Distance attr Eave_Ht = _getEaveHeight
@Hidden attr height = -1
@Hidden attr estimatedLevels = defaultLevels
@Hidden attr estimatedFloorHeight = 3.7
const defaultLevels = 2
hasHeight = height != -1
_getLevels = case hasHeight: max(rint(height / estimatedFloorHeight), 1) else: estimatedLevels
_getEaveHeight = case hasHeight: height else: Levels * estimatedFloorHeight
@StartRule
Generate --> extrude(Eave_Ht) Mass.

style Town
attr estimatedLevels =
	case geometry.area < 100 : 1
	case geometry.area < 500 : 4
	else                     : 9
attr estimatedFloorHeight = 3

style Plain
attr height = 10
"""


def test_a_packages_presets_are_its_styles_and_change_the_building():
    heights = {}
    for style in (None, "Town", "Plain"):
        r = imported(PRESETS, **({"style": style} if style else {}))
        heights[style] = bbox(grammarkit.derive(r.grammar, lot=LOT))[1][2]
    # default 2 x 3.7; Town on the 320 m2 lot: 4 levels of 3 m; Plain: the height itself
    assert np.allclose([heights[None], heights["Town"], heights["Plain"]], [7.4, 12.0, 10.0], atol=0.01)


def test_array_index_ranges_select_rows_and_columns_ends_included():
    # Esri's Plant_Loader.cga (envelope2002.rpk): `m[1:n, 0]`, `m[n:-1:1, 4]`; a syntax error
    # there made the whole import (and every plant) fall away, then they were warnings
    text = ('const m = [1, 2; 3, 4; 5, 6]\nconst n = 2\nconst first = findFirst(m[1:n, 0], 5)\n'
            'const back = findFirst(m[n:-1:0, 1], 2)\nLot --> extrude(1 + first + back * 10) X\n')
    r = translate_cga(text, filename="t.cga")
    assert r.ok, [d.format(text) for d in r.diagnostics]
    assert not [d for d in r.diagnostics if d.severity == "warning"]
    # rows 1..2 of column 0: (3, 5), 5 at 1; rows 2, 1, 0 of column 1: (6, 4, 2), 2 at 2
    assert np.isclose(bbox(grammarkit.derive(r.grammar, lot=LOT))[1][2], 1 + 1 + 2 * 10, atol=0.01)


RESOLVE_MAP = """<?xml version="1.0" encoding="UTF-8"?>
<resolvemap>
  <entry key="/Lib/assets/tree.glb/img0" value="gltf:.ws/Lib/assets/tree.glb!/10/20/tree_0.png" />
  <entry key="/Lib/rules/Tall.cga" value=".ws/Lib/rules/Tall.cga" />
  <entry key="/Pkg/rules/main.cga" value="rules/main.cga" />
</resolvemap>
"""


def test_a_package_finds_the_projects_it_carries_under_ws(tmp_path):
    # a value with a reader's scheme (`gltf:.ws/...`) named the imported project as the
    # package's own, so `/Lib/rules/...` was looked for in the package and not found
    pkg = tmp_path / "Pkg"
    (pkg / "rules").mkdir(parents=True)
    (pkg / ".ws" / "Lib" / "rules").mkdir(parents=True)
    (pkg / ".resolvemap.xml").write_text(RESOLVE_MAP, encoding="utf-8")
    (pkg / ".ws" / "Lib" / "rules" / "Tall.cga").write_text("Generate --> extrude(25) T.\n", encoding="utf-8")
    (pkg / "rules" / "main.cga").write_text('import Tall: "/Lib/rules/Tall.cga"\n'
                                            "@StartRule\nLot --> Tall.Generate\n", encoding="utf-8")
    out = tmp_path / "o" / "main.grammar"
    res = CliRunner().invoke(cli_main, ["import-cga", str(pkg), "-o", str(out)])
    assert res.exit_code == 0 and "not found" not in res.output, res.output
    model = grammarkit.derive(grammarkit.parse(out.read_text(), filename=str(out)), lot=LOT)
    assert np.isclose(bbox(model)[1][2], 25.0, atol=0.01)


def test_a_sources_only_package_starts_at_the_file_no_other_imports(tmp_path):
    # Esri/pyprt-examples' envelope2002.rpk: five rule files, no compiled bin/; the entry is the
    # one the others do not import (it imports them)
    pkg = tmp_path / "Set"
    (pkg / "rules" / "typology").mkdir(parents=True)
    (pkg / "rules" / "typology" / "main.cga").write_text(
        'import vol: "volume.cga"\nimport fac : "/Set/rules/typology/facade.cga"\n'
        "@StartRule\nLot --> vol.Mass\n", encoding="utf-8")
    (pkg / "rules" / "typology" / "volume.cga").write_text(
        'import fac: "facade.cga"\nMass --> extrude(9) fac.Wall\n', encoding="utf-8")
    (pkg / "rules" / "typology" / "facade.cga").write_text("Wall --> W.\n", encoding="utf-8")
    out = tmp_path / "o" / "set.grammar"
    res = CliRunner().invoke(cli_main, ["import-cga", str(pkg), "-o", str(out)])
    assert res.exit_code == 0, res.output
    model = grammarkit.derive(grammarkit.parse(out.read_text(), filename=str(out)), lot=LOT)
    assert np.isclose(bbox(model)[1][2], 9.0, atol=0.01)


def test_a_computed_workspace_asset_path_is_found_in_the_carried_project(tmp_path):
    # Esri's Plant_Loader builds `AssetFolder + "/" + name` with AssetFolder = "/ESRI.lib/..."
    pkg = tmp_path / "Pkg"
    (pkg / "rules").mkdir(parents=True)
    assets = pkg / ".ws" / "Lib" / "assets"
    assets.mkdir(parents=True)
    (assets / "box.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\n"
                                    "v 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\n"
                                    "f 4 1 5 8\n", encoding="utf-8")
    (pkg / "rules" / "main.cga").write_text(
        'const folder = "/Lib/assets"\nattr name = "box"\n'
        '@StartRule\nLot --> extrude(4) i(folder + "/" + name + ".obj") X.\n', encoding="utf-8")
    out = tmp_path / "o" / "main.grammar"
    res = CliRunner().invoke(cli_main, ["import-cga", str(pkg), "-o", str(out)])
    assert res.exit_code == 0, res.output
    model = grammarkit.derive(grammarkit.parse(out.read_text(), filename=str(out)), lot=LOT)
    assert np.allclose(bbox(model), [[0, 0, 0], [20, 16, 4]], atol=0.02)


def test_an_untranslatable_colour_attr_keeps_its_type():
    # Esri's Facade_Schematic.cga without its import: `attr PrimaryColor = _getInitialPrimaryColor`,
    # a function whose arms are colours and one call into the missing file; the stand-in was
    # the number 0, and `color(PrimaryColor)` made the whole translation fail `check`
    text = ('import lib: "missing.cga"\nattr x = 1\n'
            '_pick = case x == 1: lib.colorOf(x) else: "#ff0000"\n'
            "attr C = _pick\nLot --> color(C) extrude(2) X.\n")
    r = translate_cga(text, filename="t.cga")
    assert r.ok, [d.format(text) for d in r.diagnostics]
    assert 'attr C = ""' in r.text
    assert any(d.span and d.span.line == 4 for d in r.diagnostics if d.severity == "warning")


def test_an_untranslatable_color_attr_stands_in_as_white():
    text = ('import lib: "missing.cga"\nattr x = 1\n'
            '_pick = case x == 1: lib.colorOf(x) else: "#ff0000"\n'
            "@Color\nattr C = _pick\nLot --> extrude(2) color(C) X.\n")
    r = imported(text)
    assert 'attr C = "#ffffff"' in r.text
    assert grammarkit.derive(r.grammar, lot=LOT).triangle_count == 12
