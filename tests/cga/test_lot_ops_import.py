"""CGA roof options, comp(fe), splitArea and envelope -> grammarkit (translate/handlers/roofs.py, mass.py):
the translated text, and the imported rules deriving what CGA's would."""
from __future__ import annotations

import math

import pytest

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.split.engine import WELD
from _cga_helpers import imported, line, LOT  # noqa: E402  (tests/cga/conftest.py)


def derive(r):
    # CityEngine's open faces: these tests compare terminals with CGA's own geometry
    return grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")


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


def test_roof_even():
    # even=true: grammarkit's even= (the ridge level); false is the default and is left out;
    # with an index CGA ignores even, and so does the translation
    r = imported("Lot --> roofGable(30, 0, 0, true) R\n")
    assert "roofGable(30, overhang=0, overhang_y=0, even=true, ridge=auto)" in line(r, "Lot") and not r.diagnostics
    quad = [(0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (0.0, 12.0)]
    c = 20 / math.hypot(4, 20)  # the gable ends' ridge points: y = c (12 - y) and y = c (8 - y)
    level = math.tan(math.radians(30)) * (12 * c + 8 * c) / (1 + c) / 2
    assert part(grammarkit.derive(r.grammar, lot=quad), "R").size[2] == pytest.approx(level, abs=1e-5)
    r = imported("Lot --> roofHip(30, 0, true) R\n")
    assert "roofHip(30, overhang=0, even=true)" in line(r, "Lot")
    r = imported("Lot --> roofHip(30, 0, false) R\nB --> roofGable(30, 0, 0, true, 1) R\n")
    assert "even" not in line(r, "Lot") and "even" not in line(r, "B")


def test_roof_gable_ridge_follows_the_long_sides_as_in_cga():
    # CGA orients an unindexed gable itself: the ridge along a rectangle's long sides, whatever
    # its scope; grammarkit's own default (ridge=x) is kept for .grammar files
    r = imported("Lot --> roofGable(45) R\n")
    assert "roofGable(45, ridge=auto)" in line(r, "Lot")
    deep = [(0.0, 0.0), (10.0, 0.0), (10.0, 24.0), (0.0, 24.0)]  # 10 wide, 24 deep
    roof = part(grammarkit.derive(r.grammar, lot=deep), "R")
    assert roof.size[2] == pytest.approx(5.0, abs=1e-6)  # the 10 m span: the ridge runs along y
    native = part(grammarkit.derive("Lot --> roofGable(45) R.\n", lot=deep), "R")
    assert native.size[2] == pytest.approx(12.0, abs=1e-6)  # grammarkit's ridge=x: the 24 m span
    r = imported("Lot --> roofGable(45, 0, 0, false, 1) R\n")
    assert "ridge" not in line(r, "Lot")  # the index orients it


def test_roof_by_height_and_shed_index():
    r = imported("Lot --> roofGable(byHeight, 3) R\n")
    assert "roofGable(3, ridge=auto, value_type=byHeight)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(3.0, abs=1e-6)
    r = imported("Lot --> roofShed(30, 1) R\n")
    assert "roofShed(30, index=1)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(20 * math.tan(math.radians(30)), abs=1e-6)
    r = imported("Lot --> roofShed(byHeight, 4) R\n")  # CGA's default edge is 0
    assert "roofShed(4, index=0, value_type=byHeight)" in line(r, "Lot")
    assert part(derive(r), "R").size[2] == pytest.approx(4.0, abs=1e-6)
    r = imported("Lot --> roofHip(30, 0, true) R\n")  # even is translated now, not approximated
    assert not {c.feature for c in r.report.constructs if c.status == "approximated"}


def test_comp_fe_and_other_comp_modes():
    r = imported("Lot --> comp(fe) { 0: A | all: B }\n")
    assert line(r, "Lot") == "Lot --> comp(fe) { 0: A. | all: B. }"
    m = derive(r)
    assert [p.size[0] for p in m.parts] == pytest.approx([20, 16, 20, 16])
    r = imported("Lot --> extrude(3) comp(f) { top: T | side: S }\n")  # comp(f) as before
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
    # a face of a volume: CGA classifies its edges in the object's frame, so only one value
    # for every side is exact (candler.cga's ventilation boxes); different values: dropped
    r = imported("Lot --> extrude(10) comp(f) { top: envelope(world.up, 0.6, 0.45,45,0.45,45,0.45,45) E }\n")
    assert "envelope(worldUp, 0.6, front_base=0.45" in line(r, "Lot") and not r.diagnostics
    m = derive(r)
    e = part(m, "E")
    assert e.origin[2] == pytest.approx(10.0) and e.size == pytest.approx((20.0, 16.0, 0.6))
    h = 0.15  # the hip above 0.45 m: integral_0^h (20 - 2z)(16 - 2z) dz
    top = 320 * h - 36 * h ** 2 + 4 * h ** 3 / 3
    # the engine grows each solid by WELD (1 mm) on every side: 0.33 % of a 0.6 m height
    grown = (20 + 2 * WELD) / 20 * (16 + 2 * WELD) / 16 * (0.6 + 2 * WELD) / 0.6
    assert glb_volume(m) == pytest.approx((20 * 16 * 0.45 + top) * grown, rel=3e-4)
    bad = translate_cga("Lot --> extrude(10) comp(f) { top: envelope(normal, 5, 1, 45, 2, 45) E }\n",
                        filename="t.cga")
    dropped = [c for c in bad.report.constructs if c.status == "dropped" and c.name == "envelope"]
    assert dropped and dropped[0].span.line == 1 and bad.ok
    assert "object's frame" in dropped[0].message


def glb_volume(model) -> float:
    import io

    import trimesh

    from grammarkit.geometry.exporters import encode_glb

    loaded = trimesh.load(io.BytesIO(encode_glb(model)), file_type="glb")
    mesh = loaded.to_mesh() if isinstance(loaded, trimesh.Scene) else loaded
    mesh = trimesh.Trimesh(mesh.vertices, mesh.faces)
    assert mesh.is_watertight
    return float(mesh.volume)


# the lot's edges: 0 front (y = 0), 1 right (x = 20), 2 back (y = 16), 3 left (x = 0);
# the front leaning in at 45 degrees from 5 m, capped at 15 m: the closed form
FRONT_45 = 20 * 16 * 15 - 20 * 10 ** 2 / 2


def test_envelope_per_edge_arrays():
    r = imported("Lot --> envelope(normal, 15, [5, 0, 0, 0], [45, 90, 90, 90]) E\n")
    assert "envelopePerEdge(normal, 15, (5, 0, 0, 0), (45, 90, 90, 90)) E." in line(r, "Lot")
    assert not r.diagnostics
    assert glb_volume(derive(r)) == pytest.approx(FRONT_45, rel=2e-3)


def test_envelope_per_edge_comp_function():
    # comp(fe) { all: expr }: the expression on every edge (comp.index: the edge's index)
    r = imported('attr hs = "5;0;0;0"\nattr a = 45\nattr v = 90\n'
                 "Lot --> envelope(normal, 15, comp(fe) { all: float(listItem(hs, comp.index)) }, "
                 "comp(fe) { 0: a | all: v }) E\n")
    assert ("envelopePerEdge(normal, 15, float(listItem(hs, comp.index)), select(comp.index == 0, a, v))"
            in line(r, "Lot"))
    assert glb_volume(derive(r)) == pytest.approx(FRONT_45, rel=2e-3)
    # selectors: the first that takes an edge gives its value; street./object. fall back to
    # the lot's own sides (noted), CGA's `side` on a lot is every edge
    r = imported("attr b = 5\nattr z = 0\nattr a = 45\nattr v = 90\n"
                 "Lot --> envelope(normal, 15, comp(fe) { street.left: b | all: z }, "
                 "comp(fe) { object.left: a | side: v | 2: a }) E\n")
    text = line(r, "Lot")
    assert 'select(comp.sel == "left", b, z)' in text and 'select(comp.sel == "left", a, v)' in text
    assert any("street.left" in d.message for d in r.diagnostics)
    assert glb_volume(derive(r)) == pytest.approx(20 * 16 * 15 - 16 * 10 ** 2 / 2, rel=2e-3)
    # edges no selector takes get 0 (CGA's default): here the angle 0 cuts flat at the base
    r = imported("attr b = 4\nattr a = 90\nLot --> envelope(normal, 15, comp(fe) { all: b }, "
                 "comp(fe) { front: a }) E\n")
    assert 'select(comp.sel == "front", a, 0)' in line(r, "Lot")
    assert part(derive(r), "E").size[2] == pytest.approx(4.0, abs=1e-6)
    bad = translate_cga("attr b = 4\nLot --> envelope(normal, 15, comp(fe) { world.north: b }, [90]) E\n",
                        filename="t.cga")
    dropped = [c for c in bad.report.constructs if c.status == "dropped" and c.name == "envelope"]
    assert dropped and "world.north" in dropped[0].message and bad.ok
