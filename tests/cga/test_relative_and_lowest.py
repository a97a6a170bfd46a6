"""`'` relative values inside s()/t() expressions and alignScopeToGeometry(..., world.lowest)."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import translate_cga

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def test_relative_values_inside_expressions():
    r = translate_cga("Lot --> extrude(6) comp(f) { front: F }\n"
                      "F --> split(y) { 2: s('1, '1 + 0.3, '1) t('-0.1 * 2, -0.3, 0) B | ~1: W }\n", filename="t.cga")
    assert r.ok and r.report.warned == 0
    assert "s(scope.sx, scope.sy + 0.3, scope.sz) t(-0.1 * scope.sx * 2, -0.3, 0)" in r.text
    m = grammarkit.derive(r.grammar, lot=LOT)
    (b,) = [p for p in m.parts if p.name == "B"]
    assert b.size[:2] == pytest.approx((20.0, 2.3))
    assert b.origin == pytest.approx((-4.0, 0.0, -0.3))  # moved 0.2 of its width left, 0.3 down


def test_align_scope_to_the_lowest_edge():
    r = translate_cga("Lot --> extrude(6) comp(f) { front: F }\n"
                      "F --> rotateScope(0, 0, 90) alignScopeToGeometry(zUp, 0, world.lowest) W\n", filename="t.cga")
    assert r.ok and 'alignScopeToGeometry("lowest")' in r.text
    m = grammarkit.derive(r.grammar, lot=LOT)
    (w,) = m.parts
    assert w.axes[0] == pytest.approx((1.0, 0.0, 0.0)) and w.size[:2] == pytest.approx((20.0, 6.0))
    with pytest.raises(grammarkit.errors.DerivationError, match="lowest"):
        grammarkit.derive('Lot --> alignScopeToGeometry("highest") X.\n')
