"""CGA's convexify (grammarkit/split/convexify.py): Hertel-Mehlhorn convex pieces that tile
the face, the max_length rule, holes, comp(f) of the pieces, and the CGA import."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.errors import DerivationError
from grammarkit.split.ops.convexify import convex_pieces

ELL = ((0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (8.0, 8.0), (8.0, 16.0), (0.0, 16.0))
YOU = ((0, 0), (30, 0), (30, 20), (20, 20), (20, 8), (10, 8), (10, 20), (0, 20))


def area(p) -> float:
    return 0.5 * sum(p[i][0] * p[(i + 1) % len(p)][1] - p[(i + 1) % len(p)][0] * p[i][1] for i in range(len(p)))


def convex(p) -> bool:
    n = len(p)
    return all((p[i][0] - p[i - 1][0]) * (p[(i + 1) % n][1] - p[i][1])
               - (p[i][1] - p[i - 1][1]) * (p[(i + 1) % n][0] - p[i][0]) >= -1e-9 for i in range(n))


@pytest.mark.parametrize("contours, n, total", [
    ((ELL,), 2, 224.0),                      # an L: one reflex vertex, two pieces
    ((YOU,), 3, 30 * 20 - 10 * 12),          # a U: two reflex vertices, three pieces
    ((((0, 0), (10, 0), (10, 10), (0, 10)), ((3, 3), (3, 7), (7, 7), (7, 3))), 4, 84.0),  # a hole
])
def test_pieces_are_convex_and_tile_the_face(contours, n, total):
    pieces = convex_pieces(contours)
    assert len(pieces) == n
    assert all(convex(p) and area(p) > 0 for p in pieces)
    assert sum(area(p) for p in pieces) == pytest.approx(total)


def test_max_length_keeps_only_shorter_split_lines():
    assert len(convex_pieces((ELL,), 5.0)) == 1  # every diagonal of the L is longer: it stays concave
    assert len(convex_pieces((ELL,), 100.0)) == 2
    assert len(convex_pieces((((0, 0), (4, 0), (4, 4), (0, 4)),))) == 1  # convex: unchanged


def test_comp_hands_out_each_piece_and_the_model_is_watertight():
    m = grammarkit.derive("Lot --> convexify() comp(f) { all: extrude(3) P. }\n", lot=list(ELL))
    assert len([p for p in m.parts if p.name == "P"]) == 2
    assert m.mesh.is_watertight and m.manifold.volume() == pytest.approx(224 * 3, rel=1e-2)
    # without comp the face is still one shape
    m = grammarkit.derive("Lot --> convexify() F.\n", lot=list(ELL))
    assert len(m.parts) == 1


def test_bad_input():
    with pytest.raises(DerivationError, match="maximum length"):
        grammarkit.derive("Lot --> convexify(-1) F.\n", lot=list(ELL))
    m = grammarkit.derive("Lot --> extrude(3) convexify() V.\n", lot=list(ELL))
    assert any("convexify() of a volume" in w for w in m.warnings)


def test_cga_convexify_is_translated():
    r = translate_cga("Lot --> [ convexify comp(f){ all: A } ] convexify(4) comp(f) { all: B }\n", filename="t.cga")
    assert r.ok and "convexify() comp(f)" in r.text and "convexify(4) comp(f)" in r.text
    assert all(c.status == "translated" for c in r.report.constructs)
