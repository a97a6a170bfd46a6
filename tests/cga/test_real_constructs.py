"""Constructs real CGA files use (issue 26): comp functions with `=` selectors, operations
inside scatter blocks, per-edge setbacks from comp(fe), rotate(), taper, and located
warnings for what is not translated."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import importer, translate_cga

from ._cga_helpers import LOT, imported, line


def test_comp_function_with_equals_selectors_parses():
    # a shared library defines per-edge values with `=`; it is a located warning, not a syntax error
    r = translate_cga("f = comp(fe) { side = 1 | all = 0 }\nLot --> extrude(3) X\n", filename="t.cga")
    assert r.ok
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert warn and warn[0].span.line == 1 and "comp(...) { ... } as a value" in warn[0].message


def test_setback_with_per_edge_comp_function():
    r = imported("Lot --> setback(comp(fe) { front = 3 | all : 0 }) { front: A | remainder: B }\n")
    assert 'setbackPerEdge(select(comp.sel == "front", 3, 0))' in line(r, "Lot")
    model = grammarkit.derive(r.grammar, lot=LOT)
    assert model.triangle_count > 0


def test_operations_inside_a_scatter_block():
    r = imported("Lot --> scatter(surface, 10, uniform) { t(0, 0, 1) s(1, 1, 1) Tree }\nTree --> i(\"builtin:cube\")\n")
    text = line(r, "Lot")
    # CGA's z on the scattered points (y up) is grammarkit's -y
    assert "{ all: t(0, -1, 0) " in text and "s(1, 1, 1) Tree }" in text
    model = grammarkit.derive(r.grammar, lot=LOT)
    assert model.triangle_count >= 10 * 12


def test_rotate_is_a_located_warning_until_the_engine_has_it(monkeypatch):
    r = translate_cga("Lot --> extrude(10) rotate(rel, scope, 0, 45, 0) X\n", filename="t.cga")
    if "rotate" in importer._operation_names():
        assert "rotate(" in r.text
        return
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert warn[0].span.line == 1 and warn[0].span.column == 21 and "rotate" in warn[0].message


@pytest.mark.parametrize("frame_rule, expected", [
    # on the lot's volume (CGA y up): about CGA's y is about grammarkit's z
    ("Lot --> extrude(10) rotate(rel, scope, 0, 45, 0) X\n", 'rotate(rel, scope, 0, 0, 45)'),
    # about CGA's z (towards the street) is about grammarkit's -y
    ("Lot --> extrude(10) rotate(rel, scope, 0, 0, 30) X\n", 'rotate(rel, scope, 0, -30, 0)'),
    # absolute angles about two axes: the first set, the second turned on by
    ("Lot --> extrude(10) rotate(abs, world, 10, 20, 0) X\n",
     'rotate(abs, world, 10, 0, 0) rotate(rel, world, 0, 0, 20)'),
    # on a face (frame Z) the scope's axes are the same
    ("Lot --> extrude(10) comp(f) { front: F }\nF --> rotate(rel, scope, 5, 0, 0) X\n", 'rotate(rel, scope, 5, 0, 0)'),
])
def test_rotate_maps_cga_axes(monkeypatch, frame_rule, expected):
    names = importer._operation_names() | {"rotate"}
    monkeypatch.setattr(importer, "_operation_names", lambda: names)
    r = translate_cga(frame_rule, filename="t.cga")
    assert r.text is not None and expected in r.text, r.text


def test_taper_makes_a_pyramid():
    r = imported("Lot --> taper(6)\n")
    model = grammarkit.derive(r.grammar, lot=LOT)
    assert abs(float(model.mesh.bounds[1][2]) - 6.0) < 0.01  # (the mesh is padded by 1 mm)


def test_untranslatable_constructs_are_located_warnings():
    r = translate_cga("Lot --> extrude(10)\n  copyUV(0, 1) X\n", filename="t.cga")
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert [(d.span.line, d.span.column) for d in warn] == [(2, 3)]


@pytest.mark.parametrize("op", ["extrude(2)", "offset(-1)"])
def test_extrude_and_offset_on_volumes_pass_through(op):
    # CGA applies them per face of a volume; the engine does too (INTERFACES.md item 3), so
    # the importer passes them on unchanged and without a warning
    r = imported(f"Lot --> extrude(10) {op} X\n")
    assert line(r, "Lot") == f"Lot --> extrude(10) {op} X."
    assert not [d for d in r.diagnostics if d.severity == "warning"]
