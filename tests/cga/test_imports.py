"""Rule sets of several files (`import alias: "file.cga"`): the imported files' rules derive
the buildings, and what they leave out is said, located in their own files (issue 26: a
14-file public set derived only the lot, and its untranslated constructs were silent)."""
from __future__ import annotations

import colorsys
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.cga.colors import hsv_to_rgb, rgb_to_hex
from grammarkit.cli import main as cli_main
from _cga_helpers import bbox as _bbox  # noqa: E402  (tests/cga/conftest.py)

ROOT = Path(__file__).resolve().parents[2]
CORPUS = ROOT / "grammars" / "cga"
RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]



def _two_files(tmp_path: Path) -> Path:
    (tmp_path / "lib.cga").write_text('attr brown = colorHSVToHex(32.5, 0.575, 0.675)\n'
                                      'House --> copyUV(0, 1) extrude(9) comp(f) { top: Roof. | side: Wall. }\n')
    main = tmp_path / "main.cga"
    main.write_text('import L: "lib.cga"\nLot --> color(L.brown) L.House\n')
    return main


def test_imported_files_warn_in_their_own_file(tmp_path):
    main = _two_files(tmp_path)
    result = translate_cga(main)
    assert result.ok, [d.message for d in result.diagnostics]
    lib = str(tmp_path / "lib.cga")
    warned = [d for d in result.diagnostics if d.severity == "warning"]
    assert [d.span.file for d in warned] == [lib] and "copyUV" in warned[0].message
    assert (warned[0].span.line, warned[0].span.column) == (2, 11)
    # the caret is under the imported file's line, not under line 2 of main.cga
    assert "House --> copyUV(0, 1)" in result.format(warned[0])
    rep = result.report.to_json()
    assert rep["constructs"]["warned"] == 0  # main.cga's own constructs all translate
    assert [(w["file"], w["line"]) for w in rep["imported_warned"]] == [(lib, 2)]
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT, surfaces="cga")
    assert abs(_bbox(model)[1][2] - 9.0) < 1e-6
    assert {p.color for p in model.parts} == {"#ac7f49"}


def test_strict_counts_the_imported_files(tmp_path):
    main = _two_files(tmp_path)
    out = tmp_path / "o.grammar"
    res = CliRunner().invoke(cli_main, ["import-cga", str(main), "-o", str(out)])
    assert res.exit_code == 0 and "1 warned in imported files" in res.output
    assert "lib.cga:2:11: warning: not translated: copyUV()" in res.output
    out.unlink()
    res = CliRunner().invoke(cli_main, ["import-cga", str(main), "-o", str(out), "--strict"])
    assert res.exit_code == 1 and not out.exists()


def test_envelope2002_derives_its_buildings():
    """Esri's envelope2002 set (grammars/cga: envelope2002 imports volume0110, facade,
    ground_floor_plan, landscape and, through /ESRI.lib/ paths, Plant_Distributor ->
    Plant_Loader): the imported rules build the volume, facades and plants."""
    result = translate_cga(CORPUS / "envelope2002.cga", missing_assets="drop")
    assert result.ok
    imports = [c for c in result.report.constructs if c.kind == "import"]
    assert len(imports) == 6 and all(c.status == "translated" for c in imports)
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT)
    box = _bbox(model)
    assert model.triangle_count > 1000  # the lot alone is 2
    assert box[1][2] > 10.0  # a building's height, not a lot's
    assert box[0][0] >= -0.01 and box[1][0] <= 20.01 and box[0][1] >= -0.01 and box[1][1] <= 12.01
    # the terminals come from the imported files' rules (alias_Rule), not from envelope2002's
    prefixes = {p.rule.split("_")[0] for p in model.parts}
    assert {"volume", "landscape", "plant"} <= prefixes


def test_rule_a_imports_rule_b_with_an_argument():
    result = translate_cga(CORPUS / "ruleA.cga")
    assert result.ok
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT)
    assert abs(_bbox(model)[1][2] - 10.0) < 0.01  # ruleB's extrusion, h = 10 from the import


@pytest.mark.parametrize("hsv", [(32.5, 0.575, 0.675), (200.0, 1.0, 1.0), (359.0, 0.3, 0.2),
                                 (0.0, 0.0, 0.97), (120.0, 0.5, 0.0), (420.0, 0.5, 0.5)])
def test_hsv_matches_the_sector_definition(hsv):
    h, s, v = hsv
    want = colorsys.hsv_to_rgb((h % 360.0) / 360.0, s, v)
    assert np.allclose(hsv_to_rgb(h, s, v), want)


def test_colour_functions_fold_and_evaluate():
    text = ('attr h = 30\nattr c = colorHSVToHex(h, 0.5, 0.8)\n'
            'Lot --> color(colorRGBToHex(0.9, 0.3, 0.1)) extrude(3) color(c) X.\n')
    result = translate_cga(text, filename="c.cga")
    assert result.ok and '"#e64d1a"' in result.text  # folded: literal arguments
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT)
    assert {p.color for p in model.parts} == {rgb_to_hex(*hsv_to_rgb(30, 0.5, 0.8))} == {"#cc9966"}
    # an attr of the model (set per derivation) goes through the same expression
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT, attrs={"h": 200})
    assert {p.color for p in model.parts} == {rgb_to_hex(*hsv_to_rgb(200, 0.5, 0.8))}


def test_a_random_colour_argument_is_a_located_warning():
    result = translate_cga("attr w = colorRGBToHex(rand(0.8, 0.9), 0.2, 1)\nLot --> X.\n", filename="r.cga")
    (d,) = [d for d in result.diagnostics if d.severity == "warning"]
    assert (d.span.line, "rand()") == (1, "rand()") and "random value" in d.message
    assert json.dumps(result.report.to_json())  # the report stays serialisable


@pytest.mark.parametrize("hexcolor", ["#ac7f49", "#ff0000", "#00ff80", "#123456", "#777777", "#000000", "#fa0"])
def test_hex_to_hsv_matches_colorsys(hexcolor):
    from grammarkit.cga.colors import hex_to_hsv
    t = hexcolor.lstrip("#")
    t = "".join(c * 2 for c in t) if len(t) == 3 else t
    want = colorsys.rgb_to_hsv(*(int(t[i:i + 2], 16) / 255 for i in (0, 2, 4)))
    assert np.allclose(hex_to_hsv(hexcolor), (want[0] * 360, want[1], want[2]))


def test_colour_of_a_rule_parameter_at_derive_time():
    """A colour computed from a rule parameter at derive time; a hue below 0 wraps."""
    from grammarkit.cga.colors import hex_to_hsv
    text = ('Lot --> extrude(2) R("#3a7fc4", -170)\n'
            'R(c, h) --> color(colorHSVToHex(h, 0.5, 0.6)) X. color(colorRGBToHex(colorHexToV(c), 0, 0)) Y.\n')
    result = translate_cga(text, filename="h.cga")
    assert result.ok and "colorHex" not in result.text
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT)
    v = hex_to_hsv("#3a7fc4")[2]
    assert {p.color for p in model.parts} == {rgb_to_hex(*hsv_to_rgb(190, 0.5, 0.6)), rgb_to_hex(v, 0, 0)}


def test_nested_computed_colours_are_refused_not_blown_up():
    """The public rule set's shutters nest colorHexToH(c) inside colorHSVToHex: written out as
    one expression that is tens of thousands of terms (the import once ran out of memory);
    refused with a located warning, quickly."""
    text = ('Lot --> extrude(2) R("#3a7fc4")\n'
            'R(c) --> color(colorHSVToHex(colorHexToH(c) - 190, colorHexToS(c) - 0.15, colorHexToV(c) - 0.25)) X.\n')
    result = translate_cga(text, filename="h.cga")
    assert result.ok and len(result.text) < 5000
    (d,) = [d for d in result.diagnostics if "nested too deeply" in d.message]
    assert (d.span.line, d.span.column) == (2, 10)
    folded = translate_cga('attr c = colorHexToH("#00ff80")\nLot --> X.\n', filename="f.cga")
    assert "attr c = 150" in folded.text
