"""CGA comp(e), comp(v) and comp.sel -> grammarkit, and the imported rules deriving."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import translate_cga

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def test_edges_vertices_and_comp_sel_translate_and_derive():
    text = ("Lot --> extrude(3) comp(e) { vertical: s('1, 0.6, 0.6) center(yz) primitiveCube() Pipe }\n"
            "L2 --> [ comp(e) { all: report(\"edge\", scope.sx) NIL } ] extrude(1) M\n"
            "L3 --> extrude(5) comp(f) { left: S | right: S | front: S }\n"
            "S --> case comp.sel == \"left\": color(\"#ff0000\") X. else: Y.\n"
            "L4 --> extrude(4) comp(v) { all: V. }\n")
    r = translate_cga(text, filename="t.cga")
    assert r.ok and r.report.warned == 0
    assert ("comp(e) { vertical: s(scope.sx, 0.6, 0.6) center(yz) i(\"builtin:cube\") Pipe. }" in r.text)
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert [p.size for p in m.parts] == [pytest.approx((3.0, 0.6, 0.6))] * 4
    assert m.mesh.is_watertight
    m = grammarkit.derive(r.grammar, lot=LOT, start="L2")
    assert m.reports["edge"]["sum"] == pytest.approx(72.0)
    m = grammarkit.derive(r.grammar, lot=LOT, start="L3")
    assert sorted((p.name, p.color) for p in m.parts) == [("X", "#ff0000"), ("Y", None), ("Y", None)]


def test_orientation_selectors_on_a_face_volume_are_reported():
    r = translate_cga("Lot --> extrude(3) comp(f) { front: extrude(1) comp(e) { vertical: P | all: Q } }\n",
                      filename="t.cga")
    assert r.ok
    assert {c.feature for c in r.report.constructs if c.status == "dropped"} == {"comp-selector:vertical"}


def test_horizontal_and_vertical_faces_of_a_volume_on_a_facade():
    r = translate_cga("Lot --> extrude(6) comp(f) { front: B }\nB --> extrude(1) comp(f) { horizontal: H | vertical: V }\n",
                      filename="t.cga")
    assert r.ok and r.report.warned == 0
    m = grammarkit.derive(r.grammar, lot=LOT)
    sizes = sorted((p.name, tuple(round(v, 6) for v in p.size)) for p in m.parts)
    # the balcony's top and bottom slabs are CGA's horizontal faces; its front, back and ends vertical
    assert sizes == [("H", (20.0, 1.0, 0.0))] * 2 + [("V", (6.0, 1.0, 0.0))] * 2 + [("V", (20.0, 6.0, 0.0))] * 2
