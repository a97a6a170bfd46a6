"""rotateScope on a lot, then the face operations (issue 26: the swiss houses of a public rule
set turn their lots by `rotateScope(rint(rand(0,4))*90, 0, 0)` before `innerRectangle` and
`shapeL`). A CGA lot's scope is y-up (grammarkit/cga/frames.py): a turn about its y (the
lot's normal) keeps the lot in the scope's xz plane, and so does a half turn about its x or
z (the scope turned over; CGA keeps the geometry and its normal); a quarter turn about x or z
puts it in the scope's xy plane. All stay faces for the face operations, whose edge selectors
classify the edges in the turned scope's quadrants, as CGA's."""
from __future__ import annotations

import pytest

import grammarkit
from _cga_helpers import LOT, bbox, imported  # noqa: E402  (tests/cga/conftest.py)

HOUSE = ("Lot --> rotateScope({turn}) innerRectangle(edge) {{ shape = L | remainder = NIL }}\n"
         "L --> shapeL(4, 5) {{ shape : House | remainder : NIL }}\n"
         "House --> alignScopeToAxes() extrude(6) Mass.\n")


@pytest.mark.parametrize("turn", ["0, 90, 0", "0, 180, 0", "180, 0, 0", "0, 0, 180", "360, 0, 0"])
def test_turns_that_keep_the_lot_in_its_plane_leave_a_face(turn):
    r = imported(HOUSE.format(turn=turn))
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert m.mesh.is_watertight
    lo, hi = bbox(m)
    assert lo[2] == pytest.approx(0.0, abs=0.01) and hi[2] == pytest.approx(6.0, abs=0.01)
    # an L of a 4 m front wing and a 5 m left wing, however the scope is turned
    assert m.mesh.volume in (pytest.approx((20 * 4 + 5 * 12) * 6, rel=0.01),
                             pytest.approx((16 * 4 + 5 * 16) * 6, rel=0.01))


def test_the_swiss_houses_random_turn():
    r = imported(HOUSE.format(turn="rint(rand(0,4))*90, 0, 0"))
    volumes = set()
    for seed in range(12):
        m = grammarkit.derive(r.grammar, lot=LOT, seed=seed)
        assert m.mesh.is_watertight and bbox(m)[1][2] == pytest.approx(6.0, abs=0.01)
        volumes.add(round(m.mesh.volume / 10) * 10)
    # half turns (0, 180, 360): the L of both wings; quarter turns (90, 270): the lot lies in
    # CGA's scope xy plane, where its edges face left/right and top/bottom, none the front,
    # so shapeL sets back the left edge only: the 5 m wing along it
    assert volumes == {(20 * 4 + 5 * 12) * 6, 5 * 16 * 6}
