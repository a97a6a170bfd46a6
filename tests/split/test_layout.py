"""Split layout semantics (CGA): absolute/relative/floating sizes, repeats, clipping."""
from __future__ import annotations

import pytest

from grammarkit.errors import LimitError
from grammarkit.split.compile import Slot
from grammarkit.split.engine import Limits
from grammarkit.split.ops import layout


class Ctx:
    limits = Limits(max_repeat=100)
    warnings: list = []

    @classmethod
    def warn(cls, message):
        cls.warnings.append(message)


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
    Ctx.warnings.clear()
    out = sizes([abs_(0, "z"), abs_(2, "a"), abs_(-1, "n"), flt(1, "f")], 5)
    # CGA: a negative size makes no part and takes no room (the rest is laid out without it)
    assert out == [("a", 0.0, 2.0), ("f", 2.0, 3.0)]
    assert len(Ctx.warnings) == 1 and "split size -1 is negative" in Ctx.warnings[0]


def test_repeat_runs_zero_times_when_fixed_parts_fill_the_space():
    # CGA: { ~w: Window | d: Wall }* | ~w: Window on 1.5 w: the group fits 0 times -> one window
    w, d = 2.0, 0.3
    out = sizes([rep(flt(w, "win"), abs_(d, "wall")), flt(w, "win")], 1.5 * w)
    assert out == [("win", 0.0, 3.0)]
    # on 3 w: round((6 - 2) / 2.3) = 2 repetitions, then the tail window
    out = sizes([rep(flt(w, "win"), abs_(d, "wall")), flt(w, "win")], 3 * w)
    assert [n for n, _, _ in out] == ["win", "wall", "win", "wall", "win"]
    assert abs(sum(s for _, _, s in out) - 6.0) < 1e-9


def test_repeat_zero_times_between_fixed_ends():
    # the fixed ends take everything: the group is not made at all (max(1, ...) made one)
    out = sizes([abs_(2, "e"), rep(flt(2, "r")), abs_(2, "e")], 4.5)
    assert [n for n, _, _ in out] == ["e", "e"]
    # a rigid group that does not fit once is not made either
    out = sizes([abs_(1, "e"), rep(abs_(3, "r"))], 3.5)
    assert [n for n, _, _ in out] == ["e"]


def test_a_block_of_only_a_repeat_makes_at_least_one_part():
    assert sizes([rep(flt(2, "r"))], 0.9) == [("r", 0.0, 0.9)]
    assert sizes([rep(abs_(2, "r"))], 0.9) == [("r", 0.0, 0.9)]


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


def test_zero_time_repeat_end_to_end(G):
    # the example: on 3 m, { ~2: Window | 0.3: Wall }* | ~2: Window is ONE window (CGA),
    # not two; on 4.3 m the group fits once
    from grammarkit.split import derive

    def count(width):
        m = derive(G(f"Lot --> footprint(rect({width}, 3)) split(x) "
                     "{ { ~2: extrude(1) Window. | 0.3: extrude(1) Wall. }* | ~2: extrude(1) Window. }"))
        names = [p.name for p in m.parts]
        return names.count("Window"), names.count("Wall")
    assert count(3) == (1, 0)
    assert count(4.3) == (2, 1)
    # a repeat nested in a repeat: the outer group sits beside a fixed part that nearly fills
    # the space, so it runs zero times (nothing of it is made) ...
    m = derive(G("Lot --> footprint(rect(4, 3)) split(x) { 3.5: extrude(1) E. | { { ~2: extrude(1) R. }* }* }"))
    assert sorted(p.name for p in m.parts) == ["E"]
    # ... while a block of nothing but the nested groups makes one (clipped) inner part
    m = derive(G("Lot --> footprint(rect(0.5, 3)) split(x) { { { ~2: extrude(1) R. }* }* }"))
    assert [p.size[0] for p in m.parts] == [pytest.approx(0.5)]
