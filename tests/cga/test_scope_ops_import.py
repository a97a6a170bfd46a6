"""Importing CGA's scope operations: rotateScope about any axes, alignScopeToAxes(axis),
alignScopeToGeometry(up, face, edge), mirrorScope, mirror, setPivot; the translated text, the
frame the shape is in afterwards, and the derived scopes in numbers."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import translate_cga

from ._cga_helpers import LOT, imported, line


def warned(result) -> list[str]:
    return [c.feature for c in result.report.constructs if c.status != "translated"]


def test_rotate_scope_about_cga_axes_maps_per_frame():
    # frame Y (a lot volume): CGA's x is grammarkit's x, its y (up) grammarkit's z, its z -y
    r = imported("Lot --> extrude(3) rotateScope(90, 0, 0) A.\n")
    assert line(r, "Lot") == "Lot --> extrude(3) rotateScope(90, 0, 0) A." and not warned(r)
    r = imported("Lot --> extrude(3) rotateScope(0, 30, 10) A.\n")
    assert "rotateScope(0, 0, 30) rotateScope(0, -10, 0)" in line(r, "Lot")
    # frame Z (a comp(f) face): the identity
    r = imported("Lot --> extrude(3) comp(f) { front: rotateScope(90, 0, 0) A. }\n")
    assert "front: rotateScope(90, 0, 0) A." in line(r, "Lot") and not warned(r)
    # CGA rotateScope(90, 0, 0) on the box: CGA's y (up) turns to the street (-y in grammarkit)
    m = grammarkit.derive(imported("Lot --> extrude(3) rotateScope(90, 0, 0) A.\n").grammar, lot=LOT)
    p = m.parts[0]
    assert p.axes[2] == pytest.approx((0, -1, 0)) and p.size == pytest.approx((20, 3, 16))


def test_align_scope_to_axes_y_on_a_balcony_volume_switches_to_the_lot_frame():
    # a balcony extruded from a facade (frame Z), aligned y-up: CGA's comp(f) top is the
    # world's top again (frame Y), so `top` stays `top` in grammarkit
    r = imported("Lot --> extrude(6) comp(f) { front: Balcony }\n"
                 "Balcony --> extrude(1.5) alignScopeToAxes(y) comp(f) { top: T. | side: S. | bottom: B. }\n")
    assert line(r, "Balcony") == ('Balcony --> extrude(1.5) alignScopeToAxes("z") '
                                  "comp(f) { top: T. | side: S. | bottom: B. }")
    assert not warned(r)
    m = grammarkit.derive(r.grammar, lot=LOT)
    top = next(p for p in m.parts if p.name == "T")
    # the top of the balcony: 20 m along the facade, 1.5 m out into the street, at 6 m
    assert top.axes[2] == pytest.approx((0, 0, 1)) and top.origin[2] == pytest.approx(6)
    assert sorted(top.size[:2]) == pytest.approx([1.5, 20])


def test_align_scope_to_axes_variants_and_what_is_refused():
    r = imported("Lot --> alignScopeToAxes(world.xyz) alignScopeToAxes(world.z) alignScopeToAxes(world.x) X.\n")
    assert line(r, "Lot") == 'Lot --> alignScopeToAxes() alignScopeToAxes("y") alignScopeToAxes("x") X.'
    r = translate_cga("Lot --> extrude(3) comp(f) { front: extrude(1) alignScopeToAxes(x) A. }\n", filename="t.cga")
    assert warned(r) == ["alignScopeToAxes:axis"]
    assert r.diagnostics[0].span.line == 1 and r.diagnostics[0].span.column == 48
    # on a face of frame Z (facade or top: the importer cannot tell) it is reported
    r = translate_cga("Lot --> extrude(3) comp(f) { front: alignScopeToAxes(y) A. }\n", filename="t.cga")
    assert warned(r) == ["alignScopeToAxes:face"]
    r = translate_cga("Lot --> alignScopeToAxes(object.y) A.\n", filename="t.cga")
    assert warned(r) == ["alignScopeToAxes:axis"]


def test_align_scope_to_geometry_face_selectors():
    r = imported("Lot --> extrude(3) alignScopeToGeometry(yUp, largest, world.lowest) A.\n"
                 "B --> extrude(3) alignScopeToGeometry(zUp, 2, longest) split(y) { 1: C. | ~1: D. }\n"
                 "E --> alignScopeToGeometry(zUp, any, longest) E.\n")
    assert 'alignScopeToGeometry("lowest", "largest")' in line(r, "Lot")
    # zUp leaves the shape in frame Z: CGA's split(y) is grammarkit's
    assert 'alignScopeToGeometry("longest", 2) split(y) { 1: C. | ~1: D. }' in line(r, "B")
    assert 'alignScopeToGeometry("longest", "any")' in line(r, "E")
    assert not warned(r)
    m = grammarkit.derive(imported("Lot --> extrude(3) alignScopeToGeometry(zUp, 2, longest) "
                                   "split(y) { 1: C. | ~1: D. }\n").grammar, lot=LOT)
    c = next(p for p in m.parts if p.name == "C")
    # face 2 is the front: z its normal (the street, -y), y up: the first metre up the facade
    assert c.axes[2] == pytest.approx((0, -1, 0)) and c.axes[1] == pytest.approx((0, 0, 1))
    assert c.size == pytest.approx((20, 1, 16))


def test_mirror_mirror_scope_and_set_pivot():
    r = imported("Lot --> extrude(3) mirror(false, true, false) mirrorScope(true, false, true) "
                 "setPivot(xyz, 2) X.\n")
    # frame Y: CGA's y and z are grammarkit's z and y
    assert line(r, "Lot") == "Lot --> extrude(3) mirrorGeometry(false, false, true) mirrorScope(true, true, false) X."
    assert not warned(r)  # setPivot(xyz, n) changes nothing in grammarkit: translated to nothing
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert m.parts[0].origin == pytest.approx((20, 16, 0)) and m.mesh.is_watertight
    r = translate_cga("Lot --> mirrorScope(true, false, false) setPivot(yzx, 1) X.\n", filename="t.cga")
    assert warned(r) == ["mirrorScope:handedness", "setPivot:orientation"]
