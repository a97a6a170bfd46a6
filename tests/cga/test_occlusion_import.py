"""CGA label() and inside()/overlaps()/touches() -> grammarkit, deriving as CGA's would."""
from __future__ import annotations

import grammarkit
from grammarkit.cga import translate_cga

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def test_labels_and_queries_translate_and_derive():
    r = translate_cga('Lot --> split(x) { 10: extrude(5) label("wall") W | ~1: split(x) { 2: P }* }\n'
                      'P --> t(-1, 0, 0) extrude(2) Q\n'
                      'Q --> case touches(intra, "wall") || overlaps(intra, "wall") || inside(all, "wall"): Hit.\n'
                      '      else: Free.\n', filename="t.cga")
    assert r.ok and r.report.warned == 0
    assert 'label("wall")' in r.text
    assert 'touches("intra", "wall") || overlaps("intra", "wall") || inside("all", "wall")' in r.text
    m = grammarkit.derive(r.grammar, lot=LOT)
    names = [p.name for p in m.parts]
    assert names.count("Hit") == 1 and names.count("Free") == 4


def test_queries_without_arguments_and_bad_targets():
    r = translate_cga("Lot --> extrude(2) Q\nQ --> case inside(): A. else: B.\n"
                      "R --> case inside(nowhere): A. else: B.\n", filename="t.cga")
    assert r.ok
    assert "case inside(): A." in r.text
    assert {c.feature for c in r.report.constructs if c.status == "dropped"} == {"fn:inside"}
