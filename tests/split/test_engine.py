"""The split engine end to end: semantics, seeds, snippets, limits, errors, tags, tree."""
from __future__ import annotations


import numpy as np
import pytest

from grammarkit.errors import DerivationError, GrammarError, LimitError
from grammarkit.geometry.convert import mesh_report
from grammarkit.split import Limits, derive

BOX = """
Lot --> footprint(rect(10, 6)) extrude(4) Mass
"""


def near(v):
    """Mesh measurements: added solids are grown by WELD (1 mm) so touching solids fuse."""
    return pytest.approx(v, rel=3e-3, abs=3e-3)


def ok(model):
    rep = mesh_report(model.mesh)
    assert rep.watertight and rep.manifold, rep
    return rep


def test_box_volume_and_leaf_name(G):
    m = derive(G(BOX))
    rep = ok(m)
    assert rep.volume == near(240.0)
    assert [p.name for p in m.parts] == ["Mass"]  # no rule for Mass: a leaf (with a warning)
    assert any("Mass" in w for w in m.warnings)


def test_comp_face_frames(G):
    g = G(BOX.replace("Mass", "Mass\nMass --> comp(f) { front: F. | back: B. | left: L. | right: R. | top: T. | bottom: D. }"))
    # the default: the consumed volume stays as the solid its six faces are views of
    solid = derive(g)
    assert ok(solid).volume == near(240.0) and len(solid.surface_faces) == 0
    assert set(solid.face_labels()) == {"F", "B", "L", "R", "T", "D"}
    m = derive(g, surfaces="cga")  # CityEngine's open faces
    by = {p.name: p for p in m.parts}
    assert set(by) == {"F", "B", "L", "R", "T", "D", "Mass"} - {"Mass"} or set(by) == {"F", "B", "L", "R", "T", "D"}
    # x along the face's first edge, z along the outward normal
    assert by["F"].axes[0] == pytest.approx((1, 0, 0)) and by["F"].axes[2] == pytest.approx((0, -1, 0))
    assert by["R"].axes[0] == pytest.approx((0, 1, 0)) and by["R"].axes[2] == pytest.approx((1, 0, 0))
    assert by["B"].axes[2] == pytest.approx((0, 1, 0)) and by["L"].axes[2] == pytest.approx((-1, 0, 0))
    assert by["T"].axes[2] == pytest.approx((0, 0, 1)) and by["T"].origin == pytest.approx((0, 0, 4))
    assert by["D"].axes[2] == pytest.approx((0, 0, -1))
    assert by["F"].size[:2] == pytest.approx((10, 4)) and by["R"].size[:2] == pytest.approx((6, 4))
    # comp(f) consumes the volume (CGA, surfaces="cga"): no solid, the six faces are the surface layer
    assert len(m.faces) == 0 and len(m.surface_faces) == 12
    surf = m.surface_mesh
    assert surf.area == pytest.approx(2 * (10 * 6 + 10 * 4 + 6 * 4))
    # ... and the faces, read as one surface, close the box with outward normals
    welded = surf.copy()
    welded.merge_vertices()
    assert welded.is_watertight and welded.volume == pytest.approx(240.0)
    # `volume:` keeps it: the solid is the box, the faces colour its surface
    kept = derive(G(BOX.replace("Mass", "Mass\nMass --> comp(f) { top: T. | side: S. | volume: Body. }")))
    assert ok(kept).volume == near(240.0) and len(kept.surface_faces) == 0
    assert {t.name for t in kept.tags if t.role == "body"} == {"Body"}


def test_side_selector_first_match_wins(G):
    g = G(BOX.replace("Mass", "Mass\nMass --> comp(f) { front: F. | side: S. | all: A. }"))
    names = sorted(p.name for p in derive(g).parts)
    assert names == ["A", "A", "F", "S", "S", "S"]


def test_split_index_total_and_params(G):
    g = G("""
Lot --> footprint(rect(12, 4)) split(x) { { ~3: Bay(split.index, split.total) }* }
Bay(i, n) --> extrude(1 + i) color("#00ff00") Bay.
""")
    m = derive(g)
    hs = [p.size[2] for p in m.parts]
    assert hs == [1, 2, 3, 4]
    ok(m)


def test_offset_inside_border_and_recess(G):
    g = G("""
Lot --> footprint(rect(10, 10)) extrude(5) comp(f) { front: Win | all: NIL | volume: Body. }
Win --> offset(-1) { inside: recess(0.5) Glass. | border: Frame. }
""")
    m = derive(g)
    names = sorted(p.name for p in m.parts)
    assert names == ["Body", "Frame", "Glass"]
    glass = next(p for p in m.parts if p.name == "Glass")
    assert glass.size[:2] == pytest.approx((8, 3))
    assert glass.origin[1] == pytest.approx(0.5)  # moved to the bottom of the recess (into +y)
    rep = ok(m)
    assert rep.volume == near(500 - 8 * 3 * 0.5)


def test_extrude_negative_goes_against_the_normal(G):
    # CGA: extrude(-d) makes the volume below the face
    m = derive(G("Lot --> footprint(rect(4, 4)) extrude(-1) A."))
    assert ok(m).volume == pytest.approx(16.0, rel=5e-3)
    assert m.mesh.bounds[0][2] == near(-1.0) and m.mesh.bounds[1][2] == near(0.0)
    # a window reveal the CGA way: a negative extrusion into the wall, its sides as surfaces
    g = G("Lot --> footprint(rect(4, 4)) extrude(3) comp(f) { front: Win | volume: Mass. }\n"
          "Win --> split(x) { 1: NIL | 2: extrude(-0.5) comp(f) { side: Reveal. } | ~1: NIL }")
    m = derive(g, surfaces="cga")  # CGA's open faces
    reveal = [t for t in m.surface_tags.tolist() if m.tags[t].name == "Reveal"]
    assert len(reveal) == 8  # four sides, two triangles each
    assert m.surface_vertices[:, 1].max() == pytest.approx(0.5)  # 0.5 into the wall (+y)
    # extrude(0): a volume without thickness, left out of the solid with a warning
    slab = derive(G("Lot --> footprint(rect(4, 4)) [ extrude(0) Flat. ] extrude(1) Box."))
    # the default: the flat volume's footprint is a 1 cm slab (below the lot: behind its front)
    assert ok(slab).volume == pytest.approx(16.0 * 1.01, rel=5e-3)
    m = derive(G("Lot --> footprint(rect(4, 4)) [ extrude(0) Flat. ] extrude(1) Box."), surfaces="cga")
    assert any("no thickness" in w for w in m.warnings) and ok(m).volume == pytest.approx(16.0, rel=5e-3)
    # ... and its footprint is in the surface layer (what CityEngine shows of a flat volume)
    assert [m.tags[t].name for t in m.surface_tags.tolist()] == ["Flat", "Flat"]
    assert m.surface_mesh.area == pytest.approx(16.0)


def test_division_by_zero_has_span(G):
    g = G("attr w = 0 @range(0, 5)\nLot --> footprint(rect(4, 4)) extrude(1 / w) A.")
    with pytest.raises(DerivationError, match="division by zero") as e:
        derive(g)
    assert e.value.span.line == 2 and e.value.span.column > 1


def test_depth_limit_names_rule(G):
    g = G("Lot --> footprint(rect(4, 4)) A\nA --> t(0, 0, 1) A")
    with pytest.raises(LimitError) as e:
        derive(g, limits=Limits(max_depth=20))
    assert "'A'" in str(e.value) and e.value.span.line == 2


def test_shape_and_triangle_limits(G):
    g = G("Lot --> footprint(rect(40, 4)) extrude(2) split(x) { { ~0.5: B. }* }")
    with pytest.raises(LimitError, match="shape limit"):
        derive(g, limits=Limits(max_shapes=20))
    with pytest.raises(LimitError, match="triangle limit"):
        derive(g, limits=Limits(max_triangles=100))


def test_determinism_and_seed_sensitivity(G):
    g = G("""
Lot --> footprint(rect(20, 4)) split(x) { { ~2: Bay }* }
Bay --> 50%: extrude(rand(1, 5)) A. | else: extrude(1) B.
""")
    a, b = derive(g, seed=7), derive(g, seed=7)
    assert np.array_equal(a.vertices, b.vertices)
    assert [p.name for p in a.parts] == [p.name for p in b.parts]
    c = derive(g, seed=8)
    assert [(p.name, p.size) for p in a.parts] != [(p.name, p.size) for p in c.parts]


def test_editing_one_subtree_does_not_reroll_others(G):
    text = """
Lot --> footprint(rect(20, 10)) split(y) { ~1: Left | ~1: Right }
Left --> split(x) { { ~2: L }* }
L --> extrude(rand(1, 9)) L.
Right --> split(x) { { ~2: R }* }
R --> extrude(rand(1, 9)) R.
"""
    a = derive(G(text), seed=3)
    b = derive(G(text.replace("R --> extrude(rand(1, 9)) R.", "R --> extrude(rand(2, 4) * 2) R.")), seed=3)
    la = [p.size for p in a.parts if p.name == "L"]
    lb = [p.size for p in b.parts if p.name == "L"]
    assert la == lb and len(la) == 10
    assert [p.size for p in a.parts if p.name == "R"] != [p.size for p in b.parts if p.name == "R"]


def test_choice_over_100_percent_is_error(G):
    g = G("Lot --> footprint(rect(4, 4)) X(80)\nX(p) --> p%: extrude(1) A. | p%: extrude(2) B.")
    with pytest.raises(DerivationError, match="add up to 160"):
        derive(g)


def test_stochastic_frequencies_follow_percentages(G):
    g = G("""
Lot --> footprint(rect(400, 1)) split(x) { { ~1: C }* }
C --> 30%: extrude(1) A. | else: extrude(2) B.
""")
    m = derive(g, seed=1)
    frac = sum(p.name == "A" for p in m.parts) / len(m.parts)
    assert 0.22 < frac < 0.38


def test_push_pop_and_transforms(G):
    g = G("""
Lot --> footprint(rect(4, 4)) extrude(2) Body
Body --> [ t(1, 1, 2) s(1, 1, 3) Chimney. ] Box.
""")
    m = derive(g)
    ch = next(p for p in m.parts if p.name == "Chimney")
    assert ch.origin == pytest.approx((1, 1, 2)) and ch.size == pytest.approx((1, 1, 3))
    assert ok(m).volume == near(32 + 3)


def test_rotation_and_center(G):
    g = G("""
Lot --> footprint(rect(4, 2)) extrude(1) A
A --> s(2, 2, 1) center(xy) r(0, 0, 90) B.
""")
    m = derive(g)
    b = m.parts[0]
    assert b.axes[0] == pytest.approx((0, 1, 0))
    assert b.origin[:2] == pytest.approx((1, 0))
    ok(m)


@pytest.mark.parametrize("roof, expect_h", [
    ("roofGable(45, ridge=x)", 3.0), ("roofGable(45, ridge=y)", 5.0),
    ("roofHip(45)", 3.0), ("roofPyramid(45)", 3.0), ("roofShed(45)", 6.0),
    ("roofMansard(60, 1, 20)", None),
])
def test_roofs(G, roof, expect_h):
    g = G(f"Lot --> footprint(rect(10, 6)) extrude(3) comp(f) {{ top: {roof} R. | all: NIL }}")
    m = derive(g)
    ok(m)
    r = next(p for p in m.parts if p.name == "R")
    if expect_h is not None:
        assert r.size[2] == pytest.approx(expect_h, abs=1e-6)
    assert m.mesh.bounds[1][2] > 3.0


def test_roof_overhang_and_bad_angle(G):
    m = derive(G("Lot --> footprint(rect(10, 6)) extrude(3) comp(f) { top: roofHip(30, overhang=0.5) R. | all: NIL }"))
    assert m.mesh.bounds[0][:2] == near((-0.5, -0.5))
    with pytest.raises(DerivationError, match="angle"):
        derive(G("Lot --> footprint(rect(10, 6)) extrude(3) comp(f) { top: roofHip(95) R. | all: NIL }"))


def test_hip_roof_on_l_footprint_is_skeleton_like(G):
    g = G("Lot --> footprint(lshape(20, 16, 6, 6)) extrude(3) comp(f) { top: roofHip(45) R. | all: NIL }")
    m = derive(g)
    ok(m)
    # both wings are 6 wide: the ridge height is 3 everywhere, and the roof covers the L exactly
    assert m.mesh.bounds[1][2] == near(6.0)
    assert len(m.manifold.decompose()) == 1


def test_polygon_footprint_split_and_comp(G):
    g = G("""
Lot --> footprint(polygon(0, 0, 10, 0, 10, 4, 6, 4, 6, 8, 0, 8)) extrude(3) Mass
Mass --> split(x) { ~1: P | ~1: P }
P --> comp(f) { side: F. | top: T. | bottom: NIL | volume: P. }
""")
    m = derive(g)
    rep = ok(m)
    assert rep.volume == near((10 * 4 + 6 * 4) * 3)
    tops = [p for p in m.parts if p.name == "T"]
    assert len(tops) == 2


def test_bad_footprint_is_clear(G):
    with pytest.raises(DerivationError, match="not simple"):
        derive(G("Lot --> footprint(polygon(0, 0, 4, 0, 4, 4, 2, -1, 0, 4)) extrude(1) A."))


def test_insert_part_mesh_fitted_to_scope(G, tmp_path):
    from pathlib import Path

    from grammarkit.dsl import load

    part = Path(__file__).resolve().parents[2] / "grammars" / "parts" / "chimney.glb"
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "c.glb").write_bytes(part.read_bytes())
    gfile = tmp_path / "ins.grammar"
    gfile.write_text('Lot --> footprint(rect(4, 4)) extrude(1) [ t(1, 1, 1) s(2, 1, 3) i("parts/c.glb") C. ] B.\n')
    m = derive(load(gfile))
    ok(m)
    c = next(p for p in m.parts if p.name == "C")
    assert c.size == pytest.approx((2, 1, 3))
    assert m.mesh.bounds[1][2] == near(4.0)
    gfile.write_text('Lot --> footprint(rect(4, 4)) extrude(1) i("parts/missing.glb") C.\n')
    with pytest.raises(DerivationError, match="not found"):
        derive(load(gfile))


def test_snippets_use_default_and_private_rules(G):
    g = G("""
snippet tower : Mass {
  attr h = 5 @range(2, 9)
  Start --> extrude(h) comp(f) { top: Roof | side: Wall | bottom: NIL | volume: Body. }
  Wall --> color("#ff0000") Wall.
}
snippet flat : Roof {
  Start --> color("#00ff00") Flat.
}
snippet peaked : Roof {
  attr deg = 30 @range(10, 50)
  Start --> roofPyramid(deg) Peak.
}
Lot --> footprint(rect(6, 6)) Mass
use tower as Mass
default flat for Roof
variants Roof { flat: 50% | peaked: 50% }
""")
    m = derive(g)
    ok(m)
    assert m.bindings == {"Mass": "tower", "Roof": "flat"}
    assert {p.name for p in m.parts} == {"Wall", "Flat", "Body"}
    wall = next(p for p in m.parts if p.name == "Wall")
    assert wall.rule == "Wall" and wall.object_type == "Mass" and wall.color == "#ff0000"
    assert m.attrs == {"Mass.h": 5}
    assert derive(g, attrs={"h": 8}).mesh.bounds[1][2] == near(8)
    with pytest.raises(GrammarError, match="outside its range"):
        derive(g, attrs={"h": 10})
    # swap the Roof snippet, as variations do
    m2 = derive(g, choices={"Roof": "peaked"})
    assert "Peak" in {p.name for p in m2.parts} and "Roof.deg" in m2.attrs


def test_pattern_sugar(G):
    g = G("""
Lot --> footprint(rect(10.3, 2)) Bay
Bay --> repeat(x, 2, 0.3) (W P)* W
W --> extrude(1) W.
P --> extrude(2) P.
""")
    m = derive(g)
    names = [p.name for p in sorted(m.parts, key=lambda p: p.origin[0])]
    assert names == ["W", "P", "W", "P", "W", "P", "W", "P", "W"]
    assert all(p.size[0] == pytest.approx(0.3) for p in m.parts if p.name == "P")
    ok(m)


def test_colors_reach_mesh_faces_and_tree(G):
    g = G("""
Lot --> footprint(rect(10, 10)) extrude(6) color("#808080") comp(f) { front: Facade | top: roofGable(30) color("#aa0000") Roof. | all: NIL | volume: Body. }
Facade --> color("#00aa00") split(x) { ~1: Wall. | 2: Window | ~1: Wall. }
Window --> split(y) { 1: Wall. | 2: recess(0.3) color("#0000aa") Glass. | ~1: Wall. }
""")
    m = derive(g, seed=5)
    ok(m)
    colors = {tuple(c[:3]) for c in m.mesh.visual.face_colors}
    assert {(0xAA, 0, 0), (0, 0xAA, 0), (0, 0, 0xAA), (0x80, 0x80, 0x80)} <= colors
    t = m.tree_dict()
    assert t["nodes"][0]["rule"] == "Lot" and t["nodes"][0]["line"] == 2
    glass = [n for n in t["nodes"] if n["terminal"] == "Glass"]
    assert glass and glass[0]["line"] == 4 and isinstance(glass[0]["seed"], int)
    scene = m.to_scene()
    assert len(scene.geometry) == 1


def test_solids_inside_a_recess_survive_the_cut(G):
    g = G("""
Lot --> footprint(rect(6, 6)) extrude(4) comp(f) { front: Win | all: NIL | volume: Body. }
Win --> offset(-1) { inside: recess(0.5) split(x) { ~1: Glass. | 0.2: extrude(0.3) Mullion. | ~1: Glass. } | border: Wall. }
""")
    m = derive(g)
    rep = ok(m)
    hole = 4 * 2 * 0.5
    mullion = 0.2 * 2 * 0.3
    assert rep.volume == near(144 - hole + mullion)
    assert any(t.name == "Mullion" for t in m.tags)


def test_a_start_rule_with_parameters_is_a_located_error(G):
    from grammarkit.errors import GrammarError

    with pytest.raises(GrammarError) as e:
        derive(G("Lot(h) --> extrude(h) A.\nB --> Lot(2)"))
    assert "start rule 'Lot' takes parameters (h)" in str(e.value)
    assert e.value.span.line == 1 and e.value.diagnostics[0].code == "axiom-params"
    assert derive(G("Lot(h) --> extrude(h) A.\nB --> Lot(2)"), start="B").mesh.is_watertight


def test_set_changes_an_attr_for_the_shape_and_its_descendants(G):
    m = derive(G("""
attr h = 3
attr w = 2
Lot --> footprint(rect(10, 4)) split(x) { ~1: set(h, 6) A | ~1: A | ~1: set(h, h + 1) set(w, w * 2) A }
A --> extrude(h) s(w, scope.sy, scope.sz) X.
"""))
    # siblings do not see each other's set(); later reads in the same shape see the new value
    assert [p.size for p in m.parts] == [(2, 4, 6), (2, 4, 3), (4, 4, 4)]
    # a split whose sizes read a set() attr is laid out per shape, not cached per derivation
    m = derive(G("""
attr f = 1
Lot --> footprint(rect(4, 4)) split(y) { ~1: set(f, 2) R | ~1: R }
R --> split(x) { f: extrude(1) A. | ~1: extrude(1) B. }
"""))
    assert sorted(p.size[0] for p in m.parts if p.name == "A") == [1, 2]


def test_set_of_a_const_or_unknown_name_is_a_located_error(G):
    from grammarkit.errors import GrammarError

    for text, what in (("const c = 1\nLot --> set(c, 2) X.", "is a const"),
                       ("Lot --> set(nope, 2) X.", "is not an attr")):
        with pytest.raises(GrammarError) as e:
            derive(G(text))
        assert what in str(e.value) and e.value.span is not None


def test_select_and_pick_evaluate_only_the_chosen_value(G):
    # select(x == 0, 0, 1 / x) must not divide by zero (CGA's case expressions are lazy)
    m = derive(G("const z = 0\nattr k = 2\n"
                 "Lot --> footprint(rect(4, 4)) extrude(3 + select(z == 0, 0, 1 / z) + select(k > 1, 1, 1 / z)) A."))
    assert m.mesh.bounds[1][2] == pytest.approx(4, abs=0.01)
    # pick(u, p1, v1, ..., other): percentages accumulate; u at or past their sum gives other
    for u, want in ((0, 1), (29.9, 1), (30, 2), (49.9, 2), (50, 3), (99, 3)):
        m = derive(G(f"Lot --> footprint(rect(4, 4)) extrude(pick({u}, 30, 1, 20, 2, 3)) A."))
        assert m.mesh.bounds[1][2] == pytest.approx(want, abs=0.01), u


def test_scope_operations_turn_the_scope_not_the_geometry(G):
    # alignScopeToGeometry(i): x along edge i of the outline; the footprint stays in place
    m = derive(G("Lot --> footprint(rect(10, 4)) alignScopeToGeometry(1) extrude(2) A."))
    a = m.parts[0]
    assert a.axes[0] == pytest.approx((0, 1, 0)) and a.size == pytest.approx((4, 10, 2))
    assert ok(m).volume == near(80.0) and m.mesh.bounds[1][:2] == pytest.approx((10, 4), abs=2e-3)
    assert derive(G('Lot --> footprint(polygon(0, 0, 3, 0, 3, 8, 0, 8)) alignScopeToGeometry("longest") '
                    "A.")).parts[0].axes[0] == pytest.approx((0, 1, 0))
    # rotateScope turns the scope about z: a split then runs along the turned x axis
    m = derive(G("Lot --> footprint(rect(10, 4)) rotateScope(0, 0, 90) split(x) { 1: extrude(1) A. | ~1: extrude(2) B. }"))
    a = next(p for p in m.parts if p.name == "A")
    assert a.size == pytest.approx((1, 10, 1))  # the first metre along world y
    assert ok(m).volume == near(1 * 10 * 1 + 3 * 10 * 2)
    # alignScopeToAxes brings x back to the world x axis
    m = derive(G("Lot --> footprint(rect(10, 4)) rotateScope(0, 0, 30) alignScopeToAxes() A."))
    assert m.parts[0].axes[0] == pytest.approx((1, 0, 0)) and m.parts[0].size[:2] == pytest.approx((10, 4))
    # a general solid turns with its scope; the model is unchanged
    m = derive(G("Lot --> footprint(rect(10, 4)) roofHip(30) rotateScope(0, 0, 90) A."))
    assert m.parts[0].size[:2] == pytest.approx((4, 10)) and ok(m).watertight


def test_rotate_scope_about_x_turns_the_scope_out_of_the_face(G):
    # rotateScope turns about any axis now (tests/split/test_scope_ops_engine.py); a bad
    # argument is still a located error
    m = derive(G("Lot --> footprint(rect(10, 4)) rotateScope(90, 0, 0) A."))
    assert m.parts[0].axes[1] == pytest.approx((0, 0, 1)) and m.parts[0].size == pytest.approx((10, 0, 4))
    with pytest.raises(DerivationError) as e:
        derive(G('Lot --> footprint(rect(10, 4)) mirrorScope(true, false, false) A.'))
    assert "left-handed" in str(e.value) and e.value.span.line == 1


def test_reports_are_collected_into_the_model_metadata(G, tmp_path):
    m = derive(G('Lot --> footprint(rect(10, 4)) report("lot area", scope.sx * scope.sy) '
                 "split(x) { ~1: F | ~1: F | ~1: H }\n"
                 'F --> report("use", "shop") report("floors", 2) extrude(3) F.\n'
                 'H --> report("use", "flat") report("floors", 5) extrude(3) H.\n'))
    assert m.reports == {"lot area": {"n": 1, "sum": 40.0, "mean": 40.0, "min": 40.0, "max": 40.0},
                         "use": {"n": 3, "values": {"flat": 1, "shop": 2}},
                         "floors": {"n": 3, "sum": 9.0, "mean": 3.0, "min": 2.0, "max": 5.0}}
    assert m.tree_dict()["reports"] == m.reports
    import json
    import struct

    data = m.save(tmp_path / "r.glb").read_bytes()
    doc = json.loads(data[20:20 + struct.unpack("<I", data[12:16])[0]])
    assert any((n.get("extras") or {}).get("reports") == m.reports for n in doc["nodes"])
    assert derive(G("Lot --> footprint(rect(4, 4)) extrude(1) A.")).reports == {}


def test_geometry_queries(G):
    m = derive(G('Lot --> footprint(lshape(10, 8, 4, 4)) report("a", geometry.area) '
                 'report("n", geometry.nVertices) report("r", geometry.isRectangular) '
                 '[ extrude(2) report("v", geometry.volume) report("A", geometry.area) '
                 'report("nv", geometry.nVertices) X. ] '
                 'split(x) { 4: report("r4", geometry.isRectangular) NIL | ~1: NIL }'))
    got = {k: v["sum"] for k, v in m.reports.items()}
    assert got == {"a": 56, "n": 6, "r": 0, "v": 112, "A": 2 * 56 + 36 * 2, "nv": 12, "r4": 1}
    # a general solid: its mesh
    m = derive(G('Lot --> footprint(rect(4, 4)) roofPyramid(45) report("v", geometry.volume) X.'))
    assert m.reports["v"]["sum"] == pytest.approx(4 * 4 * 2 / 3, rel=0.02)


def test_geometry_in_attr_values_reads_the_lot(G):
    # as CGA, attrs and consts that read the shape are evaluated on the initial shape (the lot,
    # 10 x 10 by default), once, before the start rule's first operation
    m = derive(G("const a = geometry.area\nLot --> footprint(rect(4, 4)) extrude(1 + a) X."))
    assert m.mesh.bounds[1][2] == pytest.approx(101, abs=0.01)


def test_reverse_normals_turns_a_face_around(G):
    m = derive(G("Lot --> footprint(rect(4, 2)) reverseNormals() X."), surfaces="cga")
    assert m.parts[0].axes[2] == pytest.approx((0, 0, -1))
    assert (m.surface_mesh.face_normals[:, 2] < -0.99).all()  # the surface looks down now
    # the outline stays in place: an L extruded after turning grows downwards
    m = derive(G("Lot --> footprint(lshape(4, 4, 2, 2)) reverseNormals() extrude(1) X."))
    assert ok(m).volume == pytest.approx(12.0, rel=5e-3) and m.mesh.bounds[0][2] == pytest.approx(-1.0, abs=2e-3)
    assert m.mesh.bounds[1][:2] == pytest.approx((4, 4), abs=2e-3)
    # a closed volume keeps its outside, with a warning
    m = derive(G("Lot --> footprint(rect(4, 2)) extrude(1) reverseNormals() X."))
    assert ok(m).watertight and any("keeps its outside" in w for w in m.warnings)
