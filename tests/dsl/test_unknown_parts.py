"""A missing `part` line is one error per type, at its first use, not one per occurrence."""
from grammarkit.dsl import check

TEXT = """grammar c
neighbors Tower: {Wall, Wall} | {Wall, Gate}
dock Tower -- Wall
example tiny { Tower at (0, 0, 0); Wall at (2.4, 0, 0) rot (0, 0, 90) }
"""


def test_each_unknown_part_type_is_reported_once_at_its_first_use():
    errors = [d for d in check(TEXT) if d.code == "unknown-part"]
    by_type = {d.message.split("'")[1]: d for d in errors}
    assert sorted(by_type) == ["Gate", "Tower", "Wall"] and len(errors) == 3
    assert by_type["Wall"].span.line == 2 and "(and 4 more uses)" in by_type["Wall"].message
    assert "part Wall = box(w, d, h)" in by_type["Wall"].hint
    assert "more use" not in by_type["Gate"].message


def test_declared_parts_are_not_reported():
    text = "part Tower = box(2, 2, 6)\npart Wall = box(4, 1, 3)\npart Gate = box(3, 1, 4)\n" + TEXT.split("\n", 1)[1]
    assert not [d for d in check(text) if d.code == "unknown-part"]
