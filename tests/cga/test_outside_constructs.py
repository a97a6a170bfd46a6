"""Constructs found in public CGA files from outside the project (docs/cga.md, "Rule files
from outside"), each reproduced by a small self-written snippet: rotate() that checks and
derives, geometry.nEdges / nFaces, built-in functions called without parentheses, translate()
along the world's up axis, and located warnings for what stays untranslated."""
from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.cli import main as cli_main

from ._cga_helpers import LOT, bbox, imported, line


def test_rotate_translates_to_a_grammar_that_checks_and_derives():
    # rotate's mode and system are identifiers of the engine's operation, not strings
    r = imported("Lot --> extrude(10) rotate(rel, scope, 0, 90, 0) X\n")
    assert "rotate(rel, scope, 0, 0, 90)" in line(r, "Lot")
    box = bbox(grammarkit.derive(r.grammar, lot=LOT))
    # a 20 x 16 x 10 box turned +90 degrees about CGA's y (grammarkit's z) at its origin
    assert np.allclose(box, [[-16, 0, 0], [0, 20, 10]], atol=0.01)


def test_rotate_abs_world_on_an_inserted_cube_checks():
    r = imported('Lot --> extrude(1) X\nX --> i("builtin:cube") rotate(abs, world, 18, 0, 0) '
                 'rotate(rel, world, 0, -32.5, 0) Y\n')
    assert "rotate(abs, world, 18, 0, 0) rotate(rel, world, 0, 0, -32.5)" in line(r, "X")
    assert grammarkit.derive(r.grammar, lot=LOT).triangle_count > 0


@pytest.mark.parametrize("query, on_face, on_volume", [
    ("geometry.nEdges", 4, 12), ("geometry.nEdges()", 4, 12), ("geometry.nFaces", 1, 6)])
def test_geometry_edge_and_face_counts(query, on_face, on_volume):
    r = imported(f'Lot --> report("face", {query}) extrude(3) V\nV --> report("volume", {query}) X\n')
    reports = grammarkit.derive(r.grammar, lot=LOT).reports
    assert reports["face"]["sum"] == on_face and reports["volume"]["sum"] == on_volume


def test_geometry_edges_of_an_l_shaped_prism():
    from grammarkit.functions import lshape
    r = imported('Lot --> extrude(3) report("e", geometry.nEdges) report("f", geometry.nFaces) X\n')
    reports = grammarkit.derive(r.grammar, lot=[tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]).reports
    assert reports["e"]["sum"] == 18 and reports["f"]["sum"] == 8  # 6 corners: 18 edges, 6 sides + 2


def test_builtin_function_without_parentheses():
    # `~(rand)` (CityEngine's International City example): rand without () is rand()
    r = imported("Lot --> split(x) { ~(rand): A | 4: B | ~rand: C }\n")
    assert "~rand(): A. | 4: B. | ~rand(): C." in line(r, "Lot")
    assert grammarkit.derive(r.grammar, lot=LOT).triangle_count > 0


def test_translate_straight_up_in_the_world_on_a_lot():
    r = translate_cga("Lot --> translate(rel, world, 0, 0.3, 0) extrude(5) X\n", filename="t.cga")
    assert r.ok and "t(0, 0, 0.3) extrude(5)" in r.text
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert len(warn) == 1 and (warn[0].span.line, warn[0].span.column) == (1, 9)
    assert "approximated" in warn[0].message
    box = bbox(grammarkit.derive(r.grammar, lot=LOT))
    assert abs(box[0][2] - 0.3) < 0.01 and abs(box[1][2] - 5.3) < 0.01


def test_translate_sideways_in_the_world_is_a_located_warning_and_strict_refuses_it(tmp_path):
    text = "Lot --> translate(rel, world, 2, 0, 0) extrude(5) X\n"
    r = translate_cga(text, filename="t.cga")
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert r.ok and len(warn) == 1 and (warn[0].span.line, warn[0].span.column) == (1, 9)
    assert "translate(rel, world" in warn[0].message
    src, out = tmp_path / "t.cga", tmp_path / "t.grammar"
    src.write_text(text)
    res = CliRunner().invoke(cli_main, ["import-cga", str(src), "-o", str(out), "--strict"])
    assert res.exit_code == 1 and not out.exists() and "t.cga:1:9:" in res.output


def test_import_without_quotes_is_an_error_at_the_import():
    # not a syntax error on the next line: the import itself, and what it should look like
    r = translate_cga("version \"2025.0\"\nimport Lib_01.cga\n\nattr H = 3\nLot --> extrude(H) X\n",
                      filename="t.cga")
    err = [d for d in r.diagnostics if d.severity == "error"]
    assert not r.ok and r.text is None and len(err) == 1
    assert (err[0].span.line, err[0].span.column) == (2, 1) and "in quotes" in err[0].message


def test_attrs_that_read_the_shape_are_evaluated_on_the_lot():
    # Esri's Building_From_Footprint: `attr Eave_Ht = case geometry.area < 100: ...`; CGA
    # evaluates attrs and consts once, on the initial shape (the lot), before any rule
    text = ("attr Eave_Ht = case geometry.area > 200: 12 else: 5\n"
            "const half = scope.sx / 2\nattr total = Eave_Ht + 1\n"
            "Lot --> extrude(total) s(half, '1, '1) X\n")
    r = imported(text)
    assert not [d for d in r.diagnostics if d.severity == "warning"]
    model = grammarkit.derive(r.grammar, lot=[(0, 0), (20, 0), (20, 12), (0, 12)])
    assert model.attrs == {"Eave_Ht": 12, "total": 13}
    assert np.allclose(bbox(model), [[0, 0, 0], [10, 12, 13]], atol=0.01)
    small = bbox(grammarkit.derive(r.grammar, lot=[(0, 0), (10, 0), (10, 12), (0, 12)]))
    assert np.allclose(small, [[0, 0, 0], [5, 12, 6]], atol=0.01)  # 120 m2: 5 m eaves
    # an attr set by the user is not evaluated again; what reads it is
    fixed = grammarkit.derive(r.grammar, lot=[(0, 0), (10, 0), (10, 12), (0, 12)], attrs={"Eave_Ht": 30})
    assert np.allclose(bbox(fixed)[1], [5, 12, 31], atol=0.01)


def test_shape_reading_attrs_do_not_change_the_lots_own_draws():
    # the lot's rand() draws are the same with or without an attr evaluated on the lot
    plain = imported("attr a = 2\nLot --> extrude(rand(5, 9)) X\n")
    reading = imported("attr a = scope.sx + rand(0, 1)\nLot --> extrude(rand(5, 9)) X\n")
    for seed in (0, 3):
        h1 = bbox(grammarkit.derive(plain.grammar, lot=LOT, seed=seed))[1][2]
        h2 = bbox(grammarkit.derive(reading.grammar, lot=LOT, seed=seed))[1][2]
        assert h1 == h2


def test_inner_rect_without_parentheses_continues_on_the_rectangle():
    # CGA's old `innerRect` (International City): the rest of the body works on the rectangle
    from grammarkit.functions import lshape
    r = imported("Lot --> innerRect extrude(3) A\n")
    assert line(r, "Lot") == "Lot --> innerRectangle(scope) { shape: extrude(3) A. }"
    box = bbox(grammarkit.derive(r.grammar, lot=[tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]))
    assert np.allclose(box, [[0, 0, 0], [20, 5, 3]], atol=0.01)  # the 20 x 5 wing, not the L


def test_unknown_align_face_selector_still_switches_the_frame():
    # alignScopeToGeometry(yUp, auto): the old `auto` is a located warning, but the rest of the
    # rule is y-up as in CGA, so split(z) is a split along the face (not a runtime error)
    r = translate_cga("Lot --> extrude(6) comp(f) { top: R }\n"
                      "R --> alignScopeToGeometry(yUp, auto) split(z) { 4: A | ~1: B }\n", filename="t.cga")
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert r.ok and len(warn) == 1 and (warn[0].span.line, warn[0].span.column) == (2, 7)
    assert "face selector 'auto'" in warn[0].message
    assert "R --> split(y) { ~1: B. | 4: A. }" in r.text
    assert grammarkit.derive(r.grammar, lot=LOT).triangle_count > 0


@pytest.mark.parametrize("op, box", [
    # CGA: the given size, centred in the scope's xz, standing on its y = 0 (here the lot)
    ("primitiveCube(4, 6, 2)", [[8, 7, 0], [12, 9, 6]]),
    ("primitiveCylinder(16, 1, 5)", [[9, 7, 0], [11, 9, 5]]),
])
def test_primitives_with_dimensions(op, box):
    r = imported(f"Lot --> {op} X\n")
    assert not [d for d in r.diagnostics if d.severity == "warning"]
    assert np.allclose(bbox(grammarkit.derive(r.grammar, lot=LOT)), box, atol=0.01)


def test_primitive_with_other_sides_is_a_located_approximation():
    r = imported("Lot --> primitiveCylinder(8, 1, 5) X\n")
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert len(warn) == 1 and (warn[0].span.line, warn[0].span.column) == (1, 9) and "16" in warn[0].message


def test_primitive_cube_with_negative_sizes_derives():
    # a public rule set writes primitiveCube(-w, -d, -h): taken by magnitude, not an s() error
    r = imported("attr w = 4\nLot --> primitiveCube(-w, -6, -2) X\n")
    assert np.allclose(bbox(grammarkit.derive(r.grammar, lot=LOT)), [[8, 7, 0], [12, 9, 6]], atol=0.01)


def test_shape_l_u_on_faces_of_a_volume_have_no_front_or_back_wing():
    # CGA's shapeL(f, l) is setback(comp(fe) { front = f | left = l }): edges are classified by
    # their outward normals in the scope's quadrants; on a face of a volume the scope's z is the
    # normal, so no edge is front or back (a roof face: only the left wing; a facade: the
    # right and left wings of shapeU)
    r = imported("Lot --> extrude(5) comp(f) { top: R | front: F }\n"
                 "R --> shapeL(3, 4) { shape: A | remainder: B }\n"
                 "F --> shapeU(1, 2, 3) { shape: C | remainder: D }\n")
    assert not [d for d in r.diagnostics if d.severity == "warning"]
    assert line(r, "R") == "R --> shapeL(0, 4) { shape: A. | remainder: B. }"
    parts = grammarkit.derive(r.grammar, lot=[(0, 0), (20, 0), (20, 12), (0, 12)], surfaces="cga").parts
    wings = sorted((p.name, round(p.origin[0], 3), round(p.size[0], 3)) for p in parts)
    assert wings == [("A", 0, 4), ("B", 4, 16), ("C", 0, 3), ("C", 18, 2), ("D", 3, 15)]


def test_street_and_object_face_selectors_on_a_lot_volume_are_the_scopes():
    # without street attributes CGA's street.* selectors fall back to object.*, and a lot's
    # object frame is its scope's: a located approximation, not a dropped branch
    r = imported("Lot --> extrude(5) comp(f) { street.front: A | object.top: T | all: B }\n")
    assert line(r, "Lot") == "Lot --> extrude(5) comp(f) { front: A. | top: T. | all: B. }"
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert [(d.span.line, d.span.column) for d in warn] == [(1, 30), (1, 48)]
    assert r.report.features()["comp-selector:street.front"] == 1
    names = sorted(p.name for p in grammarkit.derive(r.grammar, lot=LOT, surfaces="cga").parts)
    assert names == ["A", "B", "B", "B", "B", "T"]  # all: back, left, right, bottom


@pytest.mark.parametrize("roof", ["roofGable(45, 0, 0, false, 0)", "roofHip(45)", "roofPyramid(45)"])
def test_a_roof_on_a_top_face_is_scoped_y_up_as_a_lot_volume(roof):
    # Esri's Building_From_Footprint: `roofGable(45,0,0,false,0) s('1, Roof_Ht, '1)` scales the
    # roof to its height: CGA scopes a roof built on a horizontal face y up, as a lot's volume.
    # PyPRT on that package (Eave_Ht 10, Ridge_Ht 14, gable / hip / gambrel) gives a bbox top
    # of 14.0 m on the 20 x 12 and the L lot (the translation before this: 20.0 / 16.0 m)
    r = imported(f"Lot --> extrude(10) comp(f) {{ top: Roof | side: W }}\n"
                 f"Roof --> {roof} s('1, 4, '1) comp(f) {{ bottom: NIL | all: R }}\n")
    assert "s(scope.sx, scope.sy, 4)" in line(r, "Roof")
    from grammarkit.functions import lshape
    for lot in (LOT, [tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]):
        box = bbox(grammarkit.derive(r.grammar, lot=lot))
        assert abs(box[1][2] - 14.0) < 0.01


def test_extrude_along_an_axis_that_is_the_face_normal_is_exact():
    # face.normal is extrude's default, a planar face's vertex normals are its normal, and a
    # lot (flat in grammarkit) has the world's up as its normal; on a facade world.up is not
    r = translate_cga("Lot --> extrude(world.y, 5) comp(f) { top: T | front: F }\n"
                      "T --> extrude(face.normal, 2) Y\nF --> extrude(world.up, 1) X\n", filename="t.cga")
    warn = [d for d in r.diagnostics if d.severity == "warning"]
    assert r.ok and [(d.span.line, d.span.column) for d in warn] == [(3, 7)]
    assert "extrude(5)" in line(r, "Lot") and line(r, "T") == "T --> extrude(2) Y."
    assert np.allclose(bbox(grammarkit.derive(r.grammar, lot=LOT))[1], [20, 16, 7], atol=0.01)
