"""comp selectors given as expressions (`comp(f) { inxe1 + 0 = A }`, from a public rule set):
folded where consts make them a face index; from attrs' defaults with a warning."""
from __future__ import annotations

import numpy as np

import grammarkit
from grammarkit.cga import translate_cga

RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]
TEXT = """const k = 1
attr a = 0
Lot --> extrude(3) comp(f) { k + 0 = Top | a + 2 = Side | all = NIL }
Top --> color("#ff0000") X.
Side --> color("#00ff00") X.
"""


def test_const_index_is_exact_and_attr_index_is_said():
    result = translate_cga(TEXT, filename="k.cga")
    assert result.ok
    assert "comp(f) { 1: Top | 2: Side | all: NIL }" in result.text
    warned = [d for d in result.diagnostics if d.severity == "warning"]
    # `1 =` selects one face: nothing merged, nothing said; the attr's index is said
    assert [(d.span.line, d.span.column) for d in warned if "attrs' default" in d.message] == [(3, 44)]
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT)
    top = [p for p in model.parts if p.color == "#ff0000"]
    assert len(top) == 1 and abs(top[0].origin[2] - 3.0) < 1e-6  # face 1: the top, at z = 3
    assert len([p for p in model.parts if p.color == "#00ff00"]) == 1


def test_a_selector_known_only_at_derive_time_is_dropped_with_a_warning():
    result = translate_cga("Lot --> extrude(3) comp(f) { rand(0, 3) = A | all = B }\n", filename="r.cga")
    (d,) = [d for d in result.diagnostics if "not supported" in d.message]
    assert d.span.column == 30 and np.isfinite(d.span.line)
