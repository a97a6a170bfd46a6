"""The library as the recognizer sees it: parameters, anchors, defaults, hash."""
from __future__ import annotations

import pytest

from grammarkit.errors import GrammarError
from grammarkit_sketch.library import load_library

from .conftest import LIBRARY


def test_types_params_and_anchor_kinds(library):
    assert library.types == ["Mass", "Roof", "Facade", "Floor", "Window", "Ledge"]
    assert library.anchor_kinds == {"Mass": "ground", "Roof": "top", "Facade": "face",
                                    "Floor": "face", "Window": "face", "Ledge": "face"}
    hip = library.snippets["roof_hip"]
    assert [(p.name, p.lo, p.hi, p.default) for p in hip.params] == [
        ("roof_deg", 15.0, 50.0, 30.0), ("roof_over", 0.0, 1.0, 0.3)]
    # enum attrs (colours) are not parameters: a line drawing does not show them
    assert library.snippets["mass_rowhouse"].param_names == ("mass_h",)
    assert library.default_for("Roof") == "roof_gable"
    p = hip.params[0]
    assert p.value(p.normalise(37.0)) == pytest.approx(37.0)
    assert p.value(1.7) == 50.0  # clamped into the range


def test_check_type_is_case_insensitive_and_lists_types(library):
    assert library.check_type("roof") == "Roof"
    with pytest.raises(GrammarError, match="Mass, Roof, Facade, Floor, Window, Ledge"):
        library.check_type("Chimney")


def test_hash_ignores_comments_but_not_ranges(tmp_path):
    text = LIBRARY.read_text()
    base = load_library(LIBRARY).hash
    (tmp_path / "parts").symlink_to(LIBRARY.parent / "parts")
    commented = tmp_path / "a.grammar"
    commented.write_text(text.replace("# Parisian mansard", "# A mansard roof, Paris style"))
    assert load_library(commented).hash == base
    changed = tmp_path / "b.grammar"
    changed.write_text(text.replace("attr roof_deg = 30 @range(15, 50)", "attr roof_deg = 30 @range(15, 52)"))
    assert load_library(changed).hash != base


def test_ranges_must_be_numbers(tmp_path):
    bad = tmp_path / "bad.grammar"
    bad.write_text("grammar bad\nsnippet s : Roof {\n  attr a = 1 @range(0, 1)\n  attr b = a @range(0, 2)\n"
                   "  Start --> roofHip(30) Roof.\n}\n")
    with pytest.raises(GrammarError, match="'b' needs a number value"):
        load_library(bad)


def test_missing_library_file():
    with pytest.raises(GrammarError, match="library file not found"):
        load_library("no/such/library.grammar")
