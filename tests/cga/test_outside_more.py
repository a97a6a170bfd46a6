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
