"""Parts inside a CGA window opening, clear of every other part, leave the final union
(grammarkit/split/union.py): a closed body of their own, FREE_CLEARANCE clear of the reveal,
tags kept; the same building otherwise (bounding box, watertight, consistently wound)."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import grammarkit
from grammarkit.split import union

GRAMMAR = """
Lot --> extrude(6) comp(f) { side: Facade | top: Roof. | bottom: NIL }
Facade --> split(x) { ~1: Wall. | 1.2: split(y) { 1: Wall. | 1.5: Window | ~1: Wall. } | ~1: Wall. }
Window --> Opening t(0, 0, -0.3) s(scope.sx, scope.sy, 0.15) i("builtin:cube") Pane.
Opening --> extrude(-0.3) comp(f) { top: NIL | side: reverseNormals() Reveal. }
"""


def _derive(free: bool):
    saved = union.FREE_PARTS
    union.FREE_PARTS = free
    try:
        return grammarkit.derive(GRAMMAR, lot=[(0, 0), (4, 0), (4, 3), (0, 3)])
    finally:
        union.FREE_PARTS = saved


def _welded(model):
    return trimesh.Trimesh(np.asarray(model.mesh.vertices), np.asarray(model.mesh.faces))


def test_a_window_in_its_opening_is_a_body_of_its_own():
    free, united = _derive(True), _derive(False)
    a, b = _welded(free), _welded(united)
    assert a.is_watertight and a.is_winding_consistent and b.is_watertight
    assert a.body_count == 5 and b.body_count == 1  # four windows apart from the mass, or united
    assert np.allclose(a.bounds, b.bounds, atol=1e-6)
    labels = free.face_labels()
    assert labels.count("Pane") == 4 * 12  # each window a box of 12 triangles, its tag kept
    panes = [body for body in a.split(only_watertight=False) if len(body.faces) == 12]
    assert len(panes) == 4
    c = 2 * union.FREE_CLEARANCE  # shrunk by FREE_CLEARANCE on every side
    assert sorted(panes[0].extents) == pytest.approx(sorted([1.2 - c, 0.15 - c, 1.5 - c]), abs=1e-5)


def test_a_part_touching_another_stays_in_the_union():
    text = GRAMMAR.replace("Pane.", "Pane. Sill", 1) + \
        "Sill --> s(scope.sx, scope.sy, 0.05) t(0, 0, -0.05) i(\"builtin:cube\") Sill.\n"
    saved = union.FREE_PARTS
    try:
        union.FREE_PARTS = True
        m = grammarkit.derive(text, lot=[(0, 0), (4, 0), (4, 3), (0, 3)])
    finally:
        union.FREE_PARTS = saved
    w = _welded(m)
    assert w.is_watertight and w.is_winding_consistent
    assert w.body_count == 1  # the pane's box meets the sill's: both united with the mass
