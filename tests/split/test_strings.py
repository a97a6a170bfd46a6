"""CGA's string and list functions (grammarkit/split/strings.py) in split grammars."""
from __future__ import annotations

import pytest

from grammarkit.split import derive
from grammarkit.split.strings import cga_str


@pytest.mark.parametrize("value, text", [(3, "3"), (3.0, "3"), (2.5, "2.5"), (-1.0, "-1"), (True, "true"),
                                         ("a", "a")])
def test_str_formats_numbers_like_cityengine(value, text):
    assert cga_str(value) == text


def report_of(G, expr):
    m = derive(G(f'Lot --> footprint(rect(4, 4)) report("k", {expr}) extrude(1) A.'))
    r = m.reports["k"]
    return r["sum"] if "sum" in r else next(iter(r["values"]))


@pytest.mark.parametrize("expr, want", [
    ('listSize("a;b;c;")', 3), ('listSize("")', 0), ('listItem("a;b;c;", 1)', "b"),
    ('listItem("a;b;c;", 5)', ""), ('listIndex("a;b;c;", "c")', 2), ('listIndex("a;b;", "x")', -1),
    ('listFirst("a;b;")', "a"), ('listLast("a;b;")', "b"), ('listRange("a;b;c;d;", 1, 3)', "b;c;"),
    ('find("abcabc", "c")', 2), ('find("abcabc", "c", 1)', 5), ('find("abc", "x")', -1),
    ('substring("hello", 1, 3)', "el"), ('len("hello")', 5), ('float("2.5") * 2', 5),
    ('"Floor " + str(3)', "Floor 3"), ('replace("a-b-c", "-", "+")', "a+b+c"),
])
def test_string_and_list_functions(G, expr, want):
    assert report_of(G, expr) == want


def test_index_must_be_whole(G):
    from grammarkit.errors import GrammarkitError

    # a constant argument is caught by the checker, a computed one while deriving
    with pytest.raises(GrammarkitError) as e:
        derive(G('Lot --> footprint(rect(4, 4)) report("k", listItem("a;b;", 0.5)) A.'))
    assert "whole number" in str(e.value) and e.value.span is not None
    with pytest.raises(GrammarkitError) as e:
        derive(G('Lot --> footprint(rect(4, 4)) report("k", listItem("a;b;", scope.sx / 8)) A.'))
    assert "whole number" in str(e.value) and e.value.span is not None
