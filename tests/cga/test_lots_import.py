"""CGA setbacks and shapeL/U/O/innerRectangle -> grammarkit: selectors per frame, the
comp(fe) form of per-edge distances, and the imported rules deriving what CGA's would."""
from __future__ import annotations

import pytest

import grammarkit
from _cga_helpers import imported, line, LOT  # noqa: E402  (tests/cga/conftest.py)


def test_setback_selectors_on_a_lot():
    r = imported("Lot --> setback(3) { street.front: Yard | world.north: N | side: S | remainder: extrude(9) B }\n")
    assert line(r, "Lot") == "Lot --> setback(3) { front: Yard. | north: N. | all: S. | remainder: extrude(9) B. }"
    assert {c.feature for c in r.report.constructs if c.status == "approximated"} == {
        "setback-selector:street.front"}
    m = grammarkit.derive(r.grammar, lot=LOT)
    # the front yard is 3 m deep; north and the sides take the other edges, 3 m each
    assert sorted(round(p.size[1], 6) for p in m.parts if p.name == "B") == [10.0]


def test_setback_selectors_on_a_facade():
    r = imported("Lot --> extrude(9) comp(f) { front: F }\n"
                 "F --> setback(1) { top: Cornice | bottom: Base | front: X | remainder: Wall }\n")
    assert "setback(1) { top: Cornice. | bottom: Base. | remainder: Wall. }" in line(r, "F")
    m = grammarkit.derive(r.grammar, lot=LOT)
    wall = [p for p in m.parts if p.name == "Wall"]
    assert len(wall) == 1 and wall[0].size[:2] == pytest.approx((20.0, 7.0))


def test_comp_fe_distances_become_setback_per_edge():
    r = imported('attr sides = "4;4;0;0"\n'
                 "Lot --> setback(comp(fe) { all: float(listItem(sides, comp.index)) }) "
                 "{ all: T | remainder: extrude(3) R }\n")
    assert "setbackPerEdge(float(listItem(sides, comp.index)))" in line(r, "Lot")
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert [p.size[:2] for p in m.parts if p.name == "R"] == [pytest.approx((16.0, 12.0))]


def test_shape_operations_and_inner_rectangle():
    r = imported("Lot --> shapeU(5, 4, 3) { shape: extrude(6) S | remainder = G }\n"
                 "L2 --> innerRectangle(edge) { shape: I | remainder: R }\n")
    assert line(r, "Lot") == "Lot --> shapeU(5, 4, 3) { shape: extrude(6) S. | remainder: G. }"
    assert line(r, "L2") == "L2 --> innerRectangle(edge) { shape: I. | remainder: R. }"
    m = grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")  # the remainder G stays open
    assert m.manifold.volume() == pytest.approx((320 - 13 * 11) * 6, rel=2e-3)


def test_what_is_not_translated():
    r = imported("Lot --> extrude(5) comp(f) { front: F }\nF --> shapeL(1, 1) { shape: S }\n"
                 "L2 --> setback([1, 2, 3, 4]) { all: A }\n")
    features = {c.feature for c in r.report.constructs if c.status == "dropped"}
    assert "shapeL:face" not in features  # translated now (tests/cga/test_outside_constructs.py)
