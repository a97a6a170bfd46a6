"""grammarkit.derive / grammarkit.split.variations with bad arguments raise GrammarkitError
subclasses that say what is wrong, never KeyError/TypeError/AttributeError/ValueError."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.errors import GrammarkitError, ShapeError
from grammarkit.split import Limits, variations

from _qa_helpers import SMALL  # noqa: E402  (tests/qa on sys.path: see conftest.py)


@pytest.mark.parametrize("kwargs,words", [
    ({"attrs": [1, 2]}, "mapping"),
    ({"attrs": {None: 1}}, "names"),
    ({"attrs": {"h": True}}, "is a number"),
    ({"attrs": {"h": [1]}}, "is a number"),
    ({"attrs": {"h": float("nan")}}, "finite"),
    ({"attrs": {"style": 3}}, "is a string"),
    ({"attrs": {"win": 1}}, "boolean"),
    ({"seed": "abc"}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"seed": None}, "seed"),
    ({"start": 3}, "start"),
    ({"choices": ["a"]}, "mapping"),
    ({"choices": {"Nope": "x"}}, "snippet"),
    ({"lot": 5}, "lot"),
    ({"lot": "abc"}, "lot"),
    ({"lot": [(0, 0), (1, 0)]}, "3 distinct points"),
    ({"lot": [(0, 0), (float("nan"), 0), (1, 1)]}, "non-finite"),
    ({"lot": [(0, 0), (1, 1), (1, 0), (0, 1)]}, "lot"),
    ({"lot": [(0, 0, 0), (1, 0, 0), (1, 1, 0)]}, "(x, y) pairs"),
    ({"limits": {"max_depth": 3}}, "Limits"),
])
def test_derive_bad_arguments(kwargs, words):
    with pytest.raises(GrammarkitError, match=None) as info:
        grammarkit.derive(SMALL, **kwargs)
    assert words in str(info.value)


def test_bad_lot_is_a_shape_error():
    with pytest.raises(ShapeError):
        grammarkit.derive(SMALL, lot=[(0, 0), (1, 0)])


@pytest.mark.parametrize("field", ["max_depth", "max_shapes", "max_repeat", "max_triangles"])
@pytest.mark.parametrize("value", [0, -1, 2.5, "10"])
def test_limits_must_be_positive_integers(field, value):
    with pytest.raises(GrammarkitError, match=field):
        Limits(**{field: value})


LIB = """grammar snip
snippet roof_flat : Roof {
  Start --> Roof.
}
snippet roof_hip : Roof {
  Start --> roofHip(30) Roof.
}
snippet win_a : Window {
  Start --> Glass.
}
Lot --> footprint(rect(8, 6)) extrude(6) comp(f) { top: Roof | side: Wall. | bottom: NIL }
use roof_flat as Roof
"""


def test_choices_must_name_an_anchor_and_a_snippet_of_its_type():
    assert grammarkit.derive(LIB, choices={"Roof": "roof_hip"}).triangle_count > 0
    with pytest.raises(GrammarkitError, match="not an anchor"):
        grammarkit.derive(LIB, choices={"Nope": "roof_hip"})
    with pytest.raises(GrammarkitError, match="object type"):
        grammarkit.derive(LIB, choices={"Roof": "win_a"})
    with pytest.raises(GrammarkitError, match="unknown snippet"):
        grammarkit.derive(LIB, choices={"Roof": "nope"})


@pytest.mark.parametrize("kwargs", [{"n": "a"}, {"n": -1}, {"n": 1, "start": -2}, {"n": 1, "seed": "x"},
                                    {"n": 1, "attrs": [1]}])
def test_variations_bad_arguments(kwargs):
    n = kwargs.pop("n")
    with pytest.raises(GrammarkitError):
        list(variations(SMALL, n, **kwargs))
