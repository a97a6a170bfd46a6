"""CGA roof options, comp(fe), splitArea and envelope -> grammarkit (translate_lot_ops.py):
the translated text, and the imported rules deriving what CGA's would."""
from __future__ import annotations

import math

import pytest

import grammarkit
from grammarkit.cga import translate_cga
from _cga_helpers import imported, line, LOT  # noqa: E402  (tests/cga/conftest.py)


def derive(r):
    return grammarkit.derive(r.grammar, lot=LOT)


def part(m, name):
    return next(p for p in m.parts if p.name == name)


def test_roof_gable_with_every_option():
    r = imported("Lot --> extrude(5) comp(f) { top: roofGable(45,0,0,false,0) R }\n")
    assert "roofGable(45, overhang=0, overhang_y=0, index=0)" in line(r, "Lot")
    assert not r.diagnostics
    # edge 0 of the 20 x 16 lot runs along x: the ridge too, 8 m above the 16 m span
    assert part(derive(r), "R").size[2] == pytest.approx(8.0, abs=1e-6)
    # CGA measures overhangs on the roof plane: grammarkit's horizontal overhang is o cos(a)
    r = imported("Lot --> roofGable(60, 2, -1) R\n")
    assert "overhang=1" in line(r, "Lot") and "overhang_y=-0.5" in line(r, "Lot")
    assert part(derive(r), "R").size[:2] == pytest.approx((19.0, 18.0), abs=1e-6)


def test_roof_by_height_and_shed_index():
    r = imported("Lot --> roofGable(byHeight, 3) R\n")
    assert "roofGable(3, value_type=byHeight)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(3.0, abs=1e-6)
    r = imported("Lot --> roofShed(30, 1) R\n")
    assert "roofShed(30, index=1)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(20 * math.tan(math.radians(30)), abs=1e-6)
    r = imported("Lot --> roofShed(byHeight, 4) R\n")  # CGA's default edge is 0
    assert "roofShed(4, index=0, value_type=byHeight)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(4.0, abs=1e-6)
    r = imported("Lot --> roofHip(30, 0, true) R\n")
    assert {c.feature for c in r.report.constructs if c.status == "approximated"} == {"roofHip:options"}


def test_comp_fe_and_other_comp_modes():
    r = imported("Lot --> comp(fe) { 0: A | all: B }\n")
    assert line(r, "Lot") == "Lot --> comp(fe) { 0: A. | all: B. }"
    m = derive(r)
    assert [p.size[0] for p in m.parts] == pytest.approx([20, 16, 20, 16])
    r = imported("Lot --> extrude(3) comp(f) { top: T | side: S }\n")  # still translate.py's
    assert "comp(f) { top: T. | side: S. }" in line(r, "Lot")


def test_split_area_on_a_lot():
    r = imported("Lot --> splitArea(z) { 80: A | ~1: B }\n"
                 'A --> report("A", geometry.area)\nB --> report("B", geometry.area)\n')
    # CGA's z on a lot runs from the back to the street: grammarkit's y, the parts reversed
    assert line(r, "Lot") == "Lot --> splitArea(y) { ~1: B | 80: A }"
    m = derive(r)
    assert m.reports["A"]["sum"] == pytest.approx(80.0, abs=1e-6)
    assert m.reports["B"]["sum"] == pytest.approx(240.0, abs=1e-6)
    assert part(m, "A").origin[1] == pytest.approx(12.0, abs=1e-6)  # at the back


def test_envelope_forms():
    r = imported("Lot --> envelope(normal, 15, 5, 45) E\n")
    assert "envelope(normal, 15, front_base=5, front_angle=45) E." in line(r, "Lot")
    assert part(derive(r), "E").size == pytest.approx((20.0, 16.0, 15.0))
    r = imported("Lot --> envelope(world.up, 9, 5, 45, 5, 45, 5, 45) E\n")  # side: right and left
    assert "left_base=5, left_angle=45" in line(r, "Lot")
    assert part(derive(r), "E").size[2] == pytest.approx(9.0, abs=1e-6)
    bad = translate_cga('attr hs = "3;3;0;0"\nLot --> envelope(normal, 15, comp(fe) { all: '
                        'float(listItem(hs, comp.index)) }, comp(fe) { all: float(45) }) E\n', filename="t.cga")
    # CGA's per-edge arrays are not translated: a located warning, the rest of the file stays
    dropped = [c for c in bad.report.constructs if c.status == "dropped" and c.name == "envelope"]
    assert dropped and dropped[0].span.line == 2 and bad.ok
