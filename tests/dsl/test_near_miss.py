"""Issue 32 item 4: a successor that is a near miss of a rule is a located error with a
did-you-mean; other unknown names stay CGA's leaf with a warning. Issue 31: integer literals
Python refuses to convert are located errors."""
from __future__ import annotations

import pytest

from grammarkit.dsl import check
from grammarkit.dsl.suggest import NearMisses, edit_distance
from grammarkit.errors import GrammarError

TEXT = """grammar t
Lot --> extrude(3) comp(f) { side: Facde | top: Roof. }
Facade --> split(y) { 3: Flor(split.index) }
Floor(i) --> W.
"""


def _errors(text: str, filename: str = "t.grammar"):
    return [d for d in check(text, filename=filename) if d.severity == "error"]


def test_misspelt_successor_is_a_located_error_with_did_you_mean():
    errors = _errors(TEXT)
    facde = next(d for d in errors if "Facde" in d.message)
    assert facde.message == "unknown rule 'Facde'; did you mean 'Facade'?"
    assert facde.code == "unknown-rule"
    assert (facde.span.file, facde.span.line, facde.span.column) == ("t.grammar", 2, 36)
    assert "Facde." in facde.hint  # how to make a leaf on purpose


def test_misspelt_rule_call_points_at_the_rule_not_an_operation():
    flor = next(d for d in _errors(TEXT) if "Flor" in d.message)
    assert "did you mean the rule 'Floor'" in flor.message
    assert "color" not in flor.message + (flor.hint or "")
    assert (flor.span.line, flor.span.column) == (3, 26)


def test_the_caret_is_printed_by_check(tmp_path):
    from click.testing import CliRunner

    from grammarkit.cli import main

    path = tmp_path / "t.grammar"
    path.write_text(TEXT)
    out = CliRunner().invoke(main, ["check", str(path)]).output
    assert f"{path}:2:36: error: unknown rule 'Facde'; did you mean 'Facade'?" in out
    assert "                                   ^~~~~" in out


@pytest.mark.parametrize("name, rule", [("facade", "Facade"), ("FACADE", "Facade"), ("Facadee", "Facade"),
                                        ("Fcde", "Facade"), ("Mas", "Mass")])
def test_near_misses_are_errors(name, rule):
    text = f"Lot --> extrude(3) Mass {name}\nMass --> M.\nFacade --> F.\n"
    (d,) = [d for d in _errors(text) if name in d.message]
    assert d.message == f"unknown rule '{name}'; did you mean '{rule}'?"


@pytest.mark.parametrize("name", ["Glazing", "Balcony", "Xyz", "A"])
def test_other_unknown_names_stay_leaves_with_a_warning(name):
    text = f"Lot --> extrude(3) Mass {name}\nMass --> M.\nFacade --> F.\n"
    diags = check(text)
    assert not [d for d in diags if d.severity == "error"], diags
    (w,) = [d for d in diags if d.code == "undefined-successor"]
    assert f"no rule '{name}'" in w.message


def test_snippet_rules_and_anchors_count_as_rules():
    text = ("snippet s : Roof {\n  Start --> Tile.\n}\nuse s as Roof\n"
            "Lot --> extrude(3) comp(f) { top: Rooof | side: W. }\n")
    (d,) = _errors(text)
    assert d.message == "unknown rule 'Rooof'; did you mean 'Roof'?"


def test_imported_cga_keeps_leaf_warnings(tmp_path):
    from grammarkit.cga import translate_cga

    cga = tmp_path / "a.cga"
    cga.write_text("version \"2019.0\"\nLot --> extrude(3) Walls\nWall --> color(\"#ff0000\")\n"
                   "Lot2 --> extrude(2) Door\n")
    result = translate_cga(cga)
    # the importer writes CGA's leaves as terminals, so the imported grammar checks clean
    assert result.ok and "Door." in result.text, result.diagnostics
    # the same names written as plain successors in grammarkit: a leaf with a warning, except
    # the near miss of a rule
    diags = check("Lot --> extrude(3) Walls\nWall --> color(\"#ff0000\")\nLot2 --> extrude(2) Door\n")
    assert [d.code for d in diags if d.severity == "error"] == ["unknown-rule"]
    assert any(d.code == "undefined-successor" and "'Door'" in d.message for d in diags), diags


def test_edit_distance_and_index():
    assert edit_distance("kitten", "sitting") == 3  # beyond the limit: limit + 1
    assert edit_distance("Facde", "Facade") == 1
    assert edit_distance("ab", "ba") == 2
    finder = NearMisses([f"Rule{i}" for i in range(20000)] + ["Facade"])
    assert finder("Facdae") == ["Facade"]
    assert finder("Rule19999") == []  # known
    assert finder("Rul1999")[:1] == ["Rule1999"]


# -- issue 31: integer literals beyond Python's int-string limit ---------------------------------
def test_huge_count_in_neighbors_is_a_located_error():
    big = "9" * 5000
    text = f"grammar t\npart A = box(1, 1, 1)\nneighbors A: A in {big}\n"
    errors = _errors(text)
    assert errors and errors[0].code == "bad-number" and "too large" in errors[0].message
    assert (errors[0].span.line, errors[0].span.column) == (3, 19)
    text = f"grammar t\npart A = box(1, 1, 1)\nneighbors A: A in 0..{big}\n"
    assert _errors(text)[0].span.line == 3


@pytest.mark.parametrize("literal", ["9" * 5000, "0" * 4999 + "1", "1" + "0" * 5000 + ".5", "1e" + "9" * 5000])
def test_huge_number_literals_never_raise(literal):
    text = f"grammar t\nattr a = {literal}\nLot --> extrude(a) A.\n"
    check(text)  # never a traceback, whatever the verdict
    with pytest.raises(GrammarError) if _errors(text) else _nothing():
        from grammarkit.dsl import load

        load(text)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_leading_zeros_are_not_too_large():
    text = "grammar t\npart A = box(1, 1, 1)\nneighbors A: A in " + "0" * 5000 + "3\n"
    assert not _errors(text)


@pytest.mark.parametrize("text", ["Lot --> extrude(3) A B\nA --> X.\n",            # one letter: a leaf
                                  "Lot --> extrude(3) R12\nR13 --> X.\nR1 --> R13\n"])  # numbered rules
def test_short_and_renumbered_names_stay_cga_leaves(text):
    assert not _errors(text)
