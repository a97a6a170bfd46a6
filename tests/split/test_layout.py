"""Split layout semantics (CGA): absolute/relative/floating sizes, repeats, clipping."""
from __future__ import annotations

import pytest

from grammarkit.errors import LimitError
from grammarkit.split.compile import Slot
from grammarkit.split.engine import Limits
from grammarkit.split.ops import layout


class Ctx:
    limits = Limits(max_repeat=100)


class S:
    rule_name = "R"  # what operations may read of a shape (grammarkit.hookspecs.ShapeView)


def abs_(v, name="A"):
    return Slot("abs", size=lambda s: v, body=name)


def rel(v, name="A"):
    return Slot("rel", size=lambda s: v, body=name)


def flt(v, name="A"):
    return Slot("float", size=lambda s: v, body=name)


def rep(*items):
    return Slot("repeat", items=tuple(items))


def sizes(items, length):
    return [(slot.body, round(start, 6), round(size, 6)) for slot, start, size in layout(Ctx, S, tuple(items), length)]


def test_repeat_best_fit_rounds_count():
    out = sizes([rep(flt(2.1))], 10)
    assert [s for _, _, s in out] == [2.0] * 5
    assert [st for _, st, _ in out] == [0.0, 2.0, 4.0, 6.0, 8.0]


def test_absolute_parts_clipped_and_later_dropped():
    out = sizes([abs_(3, "a"), abs_(3, "b"), abs_(3, "c"), abs_(3, "d")], 7)
    assert out == [("a", 0.0, 3.0), ("b", 3.0, 3.0), ("c", 6.0, 1.0)]


def test_zero_and_negative_sizes_skipped():
    out = sizes([abs_(0, "z"), abs_(2, "a"), abs_(-1, "n"), flt(1, "f")], 5)
    assert out == [("a", 0.0, 2.0), ("f", 2.0, 3.0)]


def test_floating_parts_share_rest_by_weight():
    out = sizes([abs_(2, "a"), flt(1, "b"), flt(3, "c")], 10)
    assert out == [("a", 0.0, 2.0), ("b", 2.0, 2.0), ("c", 4.0, 6.0)]


def test_relative_sizes_are_fractions_of_whole():
    out = sizes([rel(0.3, "a"), flt(1, "b"), rel(0.3, "c")], 10)
    assert out == [("a", 0.0, 3.0), ("b", 3.0, 4.0), ("c", 7.0, 3.0)]


def test_repeat_between_fixed_ends():
    out = sizes([abs_(1, "e"), rep(flt(2, "r")), abs_(1, "e")], 10)
    assert [n for n, _, _ in out] == ["e", "r", "r", "r", "r", "e"]
    assert [s for _, _, s in out] == [1.0, 2.0, 2.0, 2.0, 2.0, 1.0]


def test_floor_pattern_window_wall_repeat():
    # split(x) { ~1: Wall | { 1.2: Window | ~1.5: Wall }* } on 12: n = round((12-1)/2.7) = 4
    out = sizes([flt(1, "w"), rep(abs_(1.2, "win"), flt(1.5, "w"))], 12)
    assert [n for n, _, _ in out].count("win") == 4
    assert all(s == 1.2 for n, _, s in out if n == "win")
    assert abs(sum(s for _, _, s in out) - 12) < 1e-5


def test_absolute_only_repeat_takes_as_many_as_fit():
    out = sizes([rep(abs_(2, "a"))], 7)
    assert [s for _, _, s in out] == [2.0, 2.0, 2.0]


def test_nested_repeat_groups():
    out = sizes([rep(abs_(0.2, "sep"), rep(flt(1, "x")))], 6.2)
    names = [n for n, _, _ in out]
    assert names.count("sep") >= 1 and names.count("x") >= names.count("sep")
    assert abs(sum(s for _, _, s in out) - 6.2) < 1e-6


def test_repeat_limit_raises_limit_error():
    with pytest.raises(LimitError, match="repeat limit"):
        layout(Ctx, S, (rep(flt(0.01)),), 100.0)
