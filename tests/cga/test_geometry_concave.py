"""CGA's geometry.isConcave: true when the shape has a concave face (a notch or a hole), on a
face, a footprint prism, a solid and an inserted open mesh."""
from __future__ import annotations

import numpy as np
import pytest
from _cga_helpers import imported

from grammarkit.dsl import load
from grammarkit.functions import lshape
from grammarkit.split import derive
from grammarkit.split.geometry_queries import _concave_faces_of_mesh

RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]
LSHAPE = [tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]
CGA = ('Lot --> report("lot", geometry.isConcave) extrude(3) Mass\n'
       'Mass --> report("mass", geometry.isConcave) comp(f) { top: Top | side: Side }\n'
       'Top --> report("top", geometry.isConcave) X.\n'
       'Side --> report("side", geometry.isConcave) Y.\n')


def _flags(lot) -> dict:
    r = imported(CGA)
    assert r.ok, [d.message for d in r.diagnostics]
    reports = derive(load(r.text), lot=lot).reports
    return {k: (v["min"], v["max"]) for k, v in reports.items()}


def test_a_rectangle_and_its_box_are_convex():
    assert _flags(RECT) == {k: (0.0, 0.0) for k in ("lot", "mass", "top", "side")}


def test_an_l_lot_its_prism_and_its_top_are_concave_its_walls_are_not():
    assert _flags(LSHAPE) == {"lot": (1.0, 1.0), "mass": (1.0, 1.0), "top": (1.0, 1.0),
                              "side": (0.0, 0.0)}


def test_a_face_with_a_hole_is_concave():
    r = imported('Lot --> offset(-2) { inside: NIL | border: Ring }\n'
                 'Ring --> report("ring", geometry.isConcave) X.\n')
    assert r.ok
    assert derive(load(r.text), lot=RECT).reports["ring"]["max"] == 1.0


def test_solids_are_judged_face_by_face():
    r = imported('Lot --> extrude(3) i("builtin:cube") report("cube", geometry.isConcave) X.\n')
    assert derive(load(r.text), lot=RECT).reports["cube"]["max"] == 0.0


SQUARE = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], float)


@pytest.mark.parametrize("V, F, concave", [
    (SQUARE, np.array([(0, 1, 2), (0, 2, 3)]), False),  # one square face of two triangles
    # an L of three unit squares, one plane, edge-connected: one concave face
    (np.array([(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0), (0, 2, 0), (1, 2, 0)], float),
     np.array([(0, 1, 4), (0, 4, 3), (1, 2, 5), (1, 5, 4), (3, 4, 7), (3, 7, 6)]), True),
    # two separate squares in one plane are two convex faces, not one concave one
    (np.vstack([SQUARE, SQUARE + (3, 0, 0)]), np.array([(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]), False),
])
def test_mesh_faces(V, F, concave):
    assert _concave_faces_of_mesh(V, F) is concave
