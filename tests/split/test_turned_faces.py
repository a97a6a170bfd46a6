"""A scope turn that leaves a face in a plane of the scope leaves it a face for the face
operations (issue 26, found on the swiss houses' `rotateScope(rint(rand(0,4))*90, 0, 0)` on
their lots): a turn about the face's normal keeps it a face; a half turn about an axis in its
plane turns the scope over (CGA keeps the geometry, so the face's normal is then the scope's
-z), a quarter turn puts it in the scope's xz plane; shapeL/U/O, setbacks, innerRectangle,
offset and splitArea run on it in the turned scope, with that scope's edge selectors, and the
faces they make keep the geometry's normal (grammarkit/split/turned.py)."""
from __future__ import annotations

import pytest
import trimesh

import grammarkit
from grammarkit.errors import DerivationError

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]


def derive(text: str, **kw):
    return grammarkit.derive(text, lot=LOT, **kw)


@pytest.mark.parametrize("turn, wing_y, wing_x", [("", 2.0, 2.0), ("rotateScope(180, 0, 0)", 10.0, 2.0),
                                                  ("rotateScope(0, 180, 0)", 2.0, 18.0)])
def test_shapeL_after_a_half_turn_in_the_plane_uses_the_turned_scope(turn, wing_y, wing_x):
    m = derive(f"Lot --> {turn} shapeL(4, 5) {{ shape: A | remainder: NIL }}\n"
               "A --> alignScopeToAxes() extrude(3) W.\n")
    assert m.mesh.is_watertight
    assert m.mesh.volume == pytest.approx((20 * 4 + 5 * 8) * 3, rel=0.01)
    lo, hi = m.mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=0.01) and hi[2] == pytest.approx(3.0, abs=0.01)
    # the wings lie along the scope's front (-y) and left (-x) edges: a half turn about x
    # reverses the scope's y (the front wing moves to the world's y = 12 edge), one about y
    # its x (the left wing moves to x = 20)
    inside = m.mesh.contains([[10.0, wing_y, 1.5], [10.0, 12.0 - wing_y, 1.5],
                              [wing_x, 6.0, 1.5], [20.0 - wing_x, 6.0, 1.5]]).tolist()
    assert inside == [True, False, True, False]


def test_faces_made_from_a_turned_face_keep_the_geometrys_normal(tmp_path):
    # no alignScopeToAxes: the wing still extrudes up (the face looks up, as in CGA), and so
    # does the turned lot itself
    for text in ("Lot --> rotateScope(180, 0, 0) shapeL(4, 5) { shape: extrude(3) W. | remainder: NIL }\n",
                 "Lot --> rotateScope(180, 0, 0) extrude(3) W.\n"):
        m = derive(text)
        lo, hi = m.mesh.bounds
        assert lo[2] == pytest.approx(0.0, abs=0.01) and hi[2] == pytest.approx(3.0, abs=0.01), text
        back = trimesh.load(m.save(tmp_path / "m.glb"), force="mesh")
        assert back.is_watertight
    # innerRectangle, setback and offset work on it; what they make are faces once aligned
    for op in ("innerRectangle(edge) { shape: A | remainder: NIL }",
               "setback(2) { front: NIL | remainder: A }", "offset(-1) { inside: A | border: NIL }"):
        m = derive(f"Lot --> rotateScope(180, 0, 0) {op}\nA --> alignScopeToAxes() extrude(2) W.\n")
        assert m.mesh.is_watertight and m.mesh.bounds[1][2] == pytest.approx(2.0, abs=0.01), op
    # in the default mode and CityEngine's, the turned face ends as its geometry
    for mode in ("solid", "cga"):
        m = derive("Lot --> rotateScope(180, 0, 0) setback(2) { front: F. | remainder: R. }\n", surfaces=mode)
        assert sorted({p.name for p in m.parts}) == ["F", "R"]


@pytest.mark.parametrize("turn", ["rotateScope(90, 0, 0)", "rotateScope(270, 0, 0)", "rotateScope(-90, 0, 0)"])
def test_a_quarter_turn_in_the_plane_leaves_a_face_in_the_scopes_xz_plane(turn):
    # the lot now lies in the scope's xz plane: its edges face the scope's +-x (left, right)
    # and +-z (top, bottom), none its front or back, so shapeL sets back the left edge only
    # (CGA's edge selectors classify the edges' outward normals into the scope's quadrants)
    m = derive(f"Lot --> {turn} shapeL(4, 5) {{ shape: A | remainder: NIL }}\n"
               "A --> alignScopeToAxes() extrude(3) W.\n")
    assert m.mesh.is_watertight
    assert m.mesh.volume == pytest.approx(5 * 12 * 3, rel=0.01)
    assert m.mesh.contains([[2.0, 6.0, 1.5], [10.0, 2.0, 1.5]]).tolist() == [True, False]
    m = derive(f"Lot --> {turn} setback(1) {{ top: T. | bottom: B. | remainder: R. }}\n")
    assert sorted({p.name for p in m.parts}) == ["B", "R", "T"]  # the back and front edges


def test_a_face_turned_out_of_every_scope_plane_says_what_it_became():
    with pytest.raises(DerivationError, match="open surface: a face turned out of its scope's xy plane"):
        derive("Lot --> rotateScope(30, 0, 0) shapeL(4, 5) { shape: A. | remainder: NIL }\n")
