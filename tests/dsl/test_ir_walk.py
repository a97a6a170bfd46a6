"""grammarkit.ir.walk: every item and sequence of a rule body, in source order, without
recursion; the checker's reachability uses it."""
from __future__ import annotations

import grammarkit
from grammarkit.ir import (
    Case, OpCall, Push, Seq, Successor, Terminal, block_branches, child_seqs, successor_names, walk,
    walk_seqs,
)

BODY = ("Lot --> extrude(3) comp(f) { side: split(y) { { 1: A | ~1: [ t(0, 0, 1) B ] }* } "
        "| top: (case 1 > 0: C else: D) E. }\n")


def _body():
    return grammarkit.parse(BODY).rules[0].body


def test_walk_visits_every_item_in_source_order():
    kinds = [(type(i).__name__, getattr(i, "name", "")) for i in walk(_body())]
    assert kinds == [("OpCall", "extrude"), ("OpCall", "comp"), ("OpCall", "split"), ("Successor", "A"),
                     ("Push", ""), ("OpCall", "t"), ("Successor", "B"), ("Case", ""),
                     ("Successor", "C"), ("Successor", "D"), ("Terminal", "E")]


def test_sequences_branches_and_successor_names():
    body = _body()
    assert [len(s.items) for s in walk_seqs(body)] == [2, 1, 1, 1, 2, 2, 1, 1]
    comp = [i for i in walk(body) if isinstance(i, OpCall) and i.name == "comp"][0]
    assert [b.body.items[0].__class__ for b in block_branches(comp.block)] == [OpCall, Case]
    assert list(successor_names(body)) == ["A", "B", "C", "D"]
    push = next(i for i in walk(body) if isinstance(i, Push))
    assert child_seqs(push) == [push.body] and child_seqs(Terminal(name="x")) == []
    assert isinstance(next(i for i in walk(body) if isinstance(i, Case)).arms[0].body, Seq)


def test_deep_nesting_does_not_recurse():
    seq = Seq(items=(Successor(name="Leaf"),))
    for _ in range(5000):  # far deeper than Python's recursion limit
        seq = Seq(items=(Push(body=seq),))
    assert list(successor_names(seq)) == ["Leaf"]
    assert sum(1 for _ in walk_seqs(seq)) == 5001


def test_the_checker_reaches_rules_through_nested_blocks():
    text = ("Lot --> extrude(3) comp(f) { side: split(y) { { 1: [ Deep ] }* } | top: T. }\n"
            "Deep --> D.\nLost --> L.\n")
    unreachable = [d.message for d in grammarkit.check(text) if d.code == "unreachable"]
    assert unreachable == ["rule 'Lost' is never used (unreachable from the start rule 'Lot')"]
