"""`envelopePerEdge(direction, max_height, base_height, angle)` (grammarkit/split/ops/envelope.py):
CGA's `envelope(direction, maxHeight, baseHeights, angles)`, with the base height and angle
evaluated on every edge (`expr` parameters, handed over unevaluated by the split compiler) or
taken from arrays of one value per edge."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.errors import DerivationError

from .test_envelope import LOT, REL, glb_volume

# the lot's edges: 0 front (y = 0), 1 right (x = 20), 2 back (y = 16), 3 left (x = 0)
FRONT_45 = 20 * 16 * 15 - 20 * 10 ** 2 / 2  # front leaning in at 45 from 5 m, 15 m cap
LEFT_45 = 20 * 16 * 15 - 16 * 10 ** 2 / 2


def per_edge(args: str, lot=LOT):
    m = grammarkit.derive(f"Lot --> envelopePerEdge({args}) E.\n", lot=lot)
    return m, next(p for p in m.parts if p.name == "E")


def test_expression_per_edge_by_index_matches_the_side_form():
    m, e = per_edge("normal, 15, select(comp.index == 0, 5, 0), select(comp.index == 0, 45, 90)")
    assert e.size == pytest.approx((20.0, 16.0, 15.0))
    assert glb_volume(m) == pytest.approx(FRONT_45, rel=REL)
    m, _ = per_edge("normal, 15, select(comp.index == 3, 5, 0), select(comp.index == 3, 45, 90)")
    assert glb_volume(m) == pytest.approx(LEFT_45, rel=REL)


def test_comp_sel_is_the_edges_side():
    m, _ = per_edge('normal, 15, 5, select(comp.sel == "left", 45, 90)')
    assert glb_volume(m) == pytest.approx(LEFT_45, rel=REL)
    # every side: the hip of tests/split/test_envelope.py
    m, e = per_edge('normal, 15, 5, select(comp.sel == "front" || comp.sel == "back" || comp.sel == "left" '
                    '|| comp.sel == "right", 45, 90)')
    hip = 20 * 16 * 8 - (20 + 16) * 64 + 4 * 512 / 3
    assert e.size[2] == pytest.approx(13.0, abs=1e-6)
    assert glb_volume(m) == pytest.approx(20 * 16 * 5 + hip, rel=REL)


def test_edge_length_is_scope_sx():
    # only the long (20 m) edges lean in: front and back, a gable-like envelope
    m, _ = per_edge("normal, 15, 5, select(scope.sx > 18, 45, 90)")
    # both planes meet at 8 m above the base (D / 2): V = W D b + W D 8 / 2
    assert glb_volume(m) == pytest.approx(20 * 16 * 5 + 20 * 16 * 8 / 2, rel=REL)


def test_arrays_give_one_value_per_edge_in_face_edge_order():
    m, _ = per_edge("normal, 15, (5, 0, 0, 0), (45, 90, 90, 90)")
    assert glb_volume(m) == pytest.approx(FRONT_45, rel=REL)
    m, _ = per_edge("normal, 15, (0, 0, 0, 5), (90, 90, 90, 45)")
    assert glb_volume(m) == pytest.approx(LEFT_45, rel=REL)


def test_attr_array_and_python_api():
    src = "attr bases = (5, 0, 0, 0)\nLot --> envelopePerEdge(normal, 15, bases, (45, 90, 90, 90)) E.\n"
    m = grammarkit.derive(src, lot=LOT)
    assert glb_volume(m) == pytest.approx(FRONT_45, rel=REL)
    m = grammarkit.derive(src, lot=LOT, attrs={"bases": (0, 0, 0, 5)})
    assert m.parts[0].size[2] == pytest.approx(15.0)


def test_deterministic():
    a, _ = per_edge("normal, 12, 2 + comp.index, 30 + 10 * comp.index")
    b, _ = per_edge("normal, 12, 2 + comp.index, 30 + 10 * comp.index")
    assert glb_volume(a) == glb_volume(b)


def test_bad_per_edge_values_are_located_errors():
    for args, msg in (("normal, 15, (1, 2), 45", "array of 2 value"),
                      ("normal, 15, comp.index - 2, 45", "base height of edge 0 must be >= 0"),
                      ("normal, 15, 1, 40 * comp.index", r"angle of edge 3 must be in \[0, 90\]"),
                      ('normal, 15, "x", 45', "must be a finite number")):
        with pytest.raises(DerivationError, match=msg) as e:
            per_edge(args)
        assert e.value.span is not None and e.value.span.line == 1
    with pytest.raises(DerivationError, match="needs a face"):
        grammarkit.derive("Lot --> extrude(3) envelopePerEdge(normal, 15, 5, 45) E.\n", lot=LOT)


def test_setback_per_edge_takes_arrays_and_comp_sel():
    src = "Lot --> setbackPerEdge({d}) {{ all: S. | remainder: R. }}\n"
    m = grammarkit.derive(src.format(d="(2, 0, 0, 0)"), lot=LOT)
    r = next(p for p in m.parts if p.name == "R")
    assert r.size[:2] == pytest.approx((20.0, 14.0))
    m = grammarkit.derive(src.format(d='select(comp.sel == "left", 3, 0)'), lot=LOT)
    r = next(p for p in m.parts if p.name == "R")
    assert r.size[:2] == pytest.approx((17.0, 16.0))
