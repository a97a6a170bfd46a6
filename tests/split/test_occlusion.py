"""CGA's occlusion queries inside(), overlaps(), touches() and label() (grammarkit/split/occlusion.py):
against the terminals and labelled shapes derived so far, never against the shape's ancestors."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.errors import GrammarError

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]
BASE = ('Lot --> split(x) { 10: extrude(5) label("wall") W. | ~1: Probe }\n'
        "Probe --> {probe} report(\"r\", {query}) NIL\n")


def ask(probe: str, query: str) -> bool:
    m = grammarkit.derive(BASE.replace("{probe}", probe).replace("{query}", query), lot=LOT)
    return bool(m.reports["r"]["sum"])


@pytest.mark.parametrize("probe, expected", [
    ("t(-2, 0, 0) s(4, 4, 0) extrude(2)", {"overlaps": True, "touches": False, "inside": False}),
    ("s(1, 4, 0) extrude(2)", {"overlaps": False, "touches": True, "inside": False}),  # shares a face
    ("t(-4, 1, 1) s(2, 2, 0) extrude(2)", {"overlaps": True, "touches": False, "inside": True}),
    ("t(2, 0, 0) s(1, 4, 0) extrude(2)", {"overlaps": False, "touches": False, "inside": False}),
    ("t(-4, 1, 2) s(2, 2, 0)", {"overlaps": True, "touches": False, "inside": True}),  # a face in it
])
def test_queries_against_a_labelled_volume(probe, expected):
    for query, want in expected.items():
        assert ask(probe, f'{query}("intra", "wall")') is want, query
        assert ask(probe, f"{query}()") is want, query  # the terminal W is an occluder too


def test_labels_filter_and_inter_finds_nothing():
    assert not ask("t(-4, 1, 1) s(2, 2, 0) extrude(2)", 'inside("intra", "roof")')
    assert not ask("t(-4, 1, 1) s(2, 2, 0) extrude(2)", 'inside("inter")')
    assert ask("t(-4, 1, 1) s(2, 2, 0) extrude(2)", 'inside("all")')


def test_ancestors_are_not_occluders_and_later_shapes_are_not_seen():
    # the probe lies inside its own labelled parent: not an occluder of it
    m = grammarkit.derive('Lot --> extrude(5) label("mass") split(x) { ~1: report("r", inside("intra", "mass")) '
                          "Part. }\n", lot=LOT)
    assert m.reports["r"]["sum"] == 0
    # a query sees what was derived before it, not what comes after (depth-first order)
    m = grammarkit.derive('Lot --> split(x) { ~1: extrude(2) report("first", overlaps()) A. '
                          '| ~1: t(-5, 0, 0) extrude(2) report("second", overlaps()) B. }\n', lot=LOT)
    assert m.reports["first"]["sum"] == 0 and m.reports["second"]["sum"] == 1


def test_queries_drive_case_rules():
    m = grammarkit.derive('Lot --> split(x) { 10: extrude(5) label("wall") W. | ~1: split(x) { { 2: P }* } }\n'
                          'P --> t(-1, 0, 0) extrude(2) Q\n'
                          'Q --> case overlaps("intra", "wall"): Hit. else: Free.\n', lot=LOT)
    names = [p.name for p in m.parts]
    assert names.count("Hit") == 1 and names.count("Free") == 4


def test_bad_arguments_are_located():
    with pytest.raises(GrammarError, match="target") as e:
        grammarkit.derive('Lot --> extrude(1) Q\nQ --> case inside("everywhere"): A. else: B.\n')
    assert e.value.span.line == 2
    with pytest.raises(GrammarError, match="literal strings"):
        grammarkit.derive("Lot --> extrude(1) Q\nQ --> case inside(3): A. else: B.\n")
    assert grammarkit.check('Lot --> extrude(1) label("m") Q\nQ --> case touches(): A. else: B.\n') == []


def test_grammars_without_queries_keep_no_occluders():
    from grammarkit.split import compile as compile_grammar

    assert compile_grammar(grammarkit.parse("Lot --> extrude(3) X.\n")).uses_occlusion is False
    assert compile_grammar(grammarkit.parse("Lot --> Q\nQ --> case inside(): A. else: B.\n")).uses_occlusion
