"""Topology rules from grammars, and the masked-decoding automaton (no torch needed)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammarkit.dsl import load
from grammarkit.tiling import rules_from_grammar
from grammarkit_string_vae.graphs import TypedGraph
from grammarkit_string_vae.masked import Automaton, complete
from grammarkit_string_vae.strings import Alphabet, decode, strings_of
from grammarkit_string_vae.topology import TopologyRules
from grammarkit_string_vae.vocab import EOS, Vocab

ROOT = Path(__file__).resolve().parents[2]
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"

RANGE_GRAMMAR = """grammar ranges
part Tower = box(2, 2, 4)
part Wall = box(4, 1, 2)
part Flag = box(0.2, 0.2, 1)
dock Tower -- Wall
dock Tower -- Flag
neighbors Tower: Wall in 1..3, Flag in 0..1
neighbors Wall: {Tower, Tower} | {Tower}
constraint connected
constraint count(Flag, 1, 2)
"""


@pytest.fixture(scope="module")
def castle():
    return load(CASTLE)


@pytest.fixture(scope="module")
def ranges(tmp_path_factory):
    p = tmp_path_factory.mktemp("g") / "ranges.grammar"
    p.write_text(RANGE_GRAMMAR)
    return load(p)


def _castle_ring(n_towers: int, gate_at: int | None = None) -> TypedGraph:
    types, edges = [], []
    for k in range(n_towers):
        types += ["Tower", "Wall", "Wall"]
    n = len(types)
    edges = [(i, (i + 1) % n) for i in range(n)]
    if gate_at is not None:
        types[gate_at] = "Gate"
    return TypedGraph.make(types, edges)


def test_castle_rules_accept_a_ring_and_locate_breaks(castle):
    rules = TopologyRules.from_grammar(castle)
    assert rules.deferred == ("grounded",)
    assert rules.is_valid(_castle_ring(4))
    bad = TypedGraph.make(["Tower", "Tower", "Wall"], [(0, 1), (1, 2), (2, 0)])
    found = rules.check(bad)
    assert any(v.rule == "pair" and v.edge == (0, 1) for v in found)
    assert any(v.rule == "neighbors" and v.node == 2 for v in found)


@st.composite
def small_graphs(draw, types):
    n = draw(st.integers(1, 9))
    tt = draw(st.lists(st.sampled_from(types), min_size=n, max_size=n))
    edges = {(draw(st.integers(0, v - 1)), v) for v in range(1, n)}
    for a, b in draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=n)):
        if a != b:
            edges.add((min(a, b), max(a, b)))
    return TypedGraph.make(tt, edges)


@pytest.fixture(scope="module")
def rule_pairs(castle, ranges):
    """Per grammar: its rules as read from the grammar (checked with Rules.check_neighbors) and
    as the decoder's boxes (read back from JSON). Made once: reading a grammar's rules is the
    expensive part, the property below is about the graphs."""
    out = []
    for grammar in (castle, ranges):
        rules = TopologyRules.from_grammar(grammar)
        out.append((rules, TopologyRules.from_json(rules.to_json())))
    return out


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_boxes_accept_exactly_what_the_grammar_rules_accept(rule_pairs, data):
    for rules, boxes in rule_pairs:
        g = data.draw(small_graphs(tuple(rules.types)))
        assert rules.is_valid(g) == boxes.is_valid(g), (g, rules.check(g), boxes.check(g))


def test_range_rules_and_count_constraint(ranges):
    rules = TopologyRules.from_grammar(ranges)
    ok = TypedGraph.make(["Tower", "Wall", "Tower", "Flag"], [(0, 1), (1, 2), (0, 3)])
    assert rules.is_valid(ok)
    no_flag = TypedGraph.make(["Tower", "Wall", "Tower"], [(0, 1), (1, 2)])
    assert [v.rule for v in rules.check(no_flag)] == ["constraint count"]


def _vocab(rules: TopologyRules, rings: int = 6) -> Vocab:
    return Vocab(Alphabet.for_types(rules.types), rings)


def _walk(auto: Automaton, rng: np.random.Generator) -> str:
    """Random decoding with the masks alone: random allowed tokens, a rules completion when
    stuck. Every string must come out valid."""
    state = auto.start()
    while not state.done:
        allowed = state.allowed()
        if not allowed:
            while True:  # back up until the rules search completes the string
                state.undo()
                plan = complete(state)
                if plan is not None:
                    for t in plan:
                        state.apply(t)
                    break
            break
        state.apply(int(rng.choice(allowed)))
    return state.graph_text()


@pytest.mark.parametrize("which", ["castle", "ranges"])
def test_masked_random_walks_are_always_valid_and_end_within_the_budget(which, castle, ranges):
    grammar = castle if which == "castle" else ranges
    rules = TopologyRules.from_grammar(grammar)
    vocab = _vocab(rules)
    auto = Automaton(rules, vocab, 40)
    rng = np.random.default_rng(3)
    for _ in range(12):  # a dozen walks: the property per walk is what counts; more only cost time
        text = _walk(auto, rng)
        parsed = decode(text, vocab.alphabet)
        assert rules.check(parsed.graph) == [], text
        assert len(vocab.encode(text)) + 1 <= 40


def _example_graphs(grammar) -> list[TypedGraph]:
    from grammarkit.tiling import load_examples, shape_graph

    out = []
    for asm in load_examples(grammar):
        sg = shape_graph(asm)
        order = {p.id: k for k, p in enumerate(asm.parts)}
        out.append(TypedGraph.make([p.type for p in asm.parts], [(order[u], order[v]) for u, v in sg.edges()]))
    return out


def test_every_string_of_a_valid_graph_passes_the_masks_with_a_tight_budget(castle):
    """The masks never rule out a token of a valid string (lowest-free ring labels, as the
    encoder writes them), even when the budget is exactly the string's length."""
    rules = TopologyRules.from_grammar(castle)
    alphabet = Alphabet.for_types(rules.types)
    vocab = Vocab(alphabet, 9)
    graphs = _example_graphs(castle) + [_castle_ring(3), _castle_ring(5)]
    for g in graphs:
        assert rules.is_valid(g)
        for text in strings_of(g, alphabet, 15, rng=np.random.default_rng(1)):
            ids = vocab.encode(text) + [EOS]
            state = Automaton(rules, vocab, len(ids)).start()
            for t in ids:
                assert t in state.allowed(), (text, state.length)
                state.apply(t)
            assert state.done


def test_the_masks_refuse_what_breaks_the_grammar(castle):
    rules = TopologyRules.from_grammar(castle)
    vocab = _vocab(rules)
    auto = Automaton(rules, vocab, 60)
    state = auto.start()
    for t in vocab.encode("T1W"):
        state.apply(t)
    allowed = {vocab.tokens[t] for t in state.allowed()}
    # after T1W: a Wall may not close ring 1 on its own parent Tower (repeated edge), EOS is
    # not allowed (ring open, Wall needs a second neighbour), Tower-Tower is never allowed
    assert "<eos>" not in allowed
    assert "1" not in allowed
    assert {"W", "T", "G"} & allowed
    state.apply(vocab.letter_id(vocab.alphabet.types.index("Tower")))
    allowed = {vocab.tokens[t] for t in state.allowed()}
    assert "T" not in allowed  # Tower -- Tower has no dock


def test_completion_closes_rings_and_branches(castle):
    rules = TopologyRules.from_grammar(castle)
    vocab = _vocab(rules)
    auto = Automaton(rules, vocab, 40)
    state = auto.start()
    for t in vocab.encode("T1WWT(WW"):
        state.apply(t)
    plan = complete(state)
    assert plan is not None and plan[-1] == EOS
    for t in plan:
        state.apply(t)
    assert rules.is_valid(decode(state.graph_text(), vocab.alphabet).graph)


def test_grammar_rules_object_is_the_tiling_one(castle):
    rules = TopologyRules.from_grammar(castle)
    assert rules.rules.neighbor_multisets == rules_from_grammar(castle).neighbor_multisets
