"""Shape strings: encoding, decoding, both formats, located errors (no torch needed)."""
from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammarkit_string_vae.graphs import GraphSet, TypedGraph, histogram_distance
from grammarkit_string_vae.strings import (
    Alphabet, ShapeStringError, convert, decode, encode, strings_of, tokenize,
)

TYPES = ("Gate", "Tower", "Wall")
ALPHA = Alphabet.for_types(TYPES)


@st.composite
def connected_graphs(draw, max_nodes: int = 14, types: tuple[str, ...] = TYPES):
    n = draw(st.integers(1, max_nodes))
    node_types = draw(st.lists(st.sampled_from(types), min_size=n, max_size=n))
    edges = set()
    for v in range(1, n):  # a random spanning tree keeps it connected
        edges.add((draw(st.integers(0, v - 1)), v))
    extra = draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=2 * n))
    for a, b in extra:
        if a != b:
            edges.add((min(a, b), max(a, b)))
    return TypedGraph.make(node_types, edges)


def isomorphic(g: TypedGraph, h: TypedGraph) -> bool:
    s = GraphSet()
    s.add(g)
    return h in s


@settings(max_examples=200, deadline=None)
@given(connected_graphs(), st.integers(0, 2**32 - 1), st.sampled_from(["smiles", "string2shape"]))
def test_decode_of_any_string_is_isomorphic_to_the_graph(g, seed, fmt):
    alphabet = ALPHA if fmt == "smiles" else Alphabet.for_types(TYPES, "index")
    text = encode(g, alphabet, rng=np.random.default_rng(seed), fmt=fmt)
    parsed = decode(text, alphabet, fmt)
    assert isomorphic(g, parsed.graph)
    # and the string lists every node once and every edge once
    assert len(parsed.graph.types) == len(g.types)
    assert len(parsed.graph.edges) == len(g.edges)


@settings(max_examples=100, deadline=None)
@given(connected_graphs(), st.integers(0, 2**32 - 1))
def test_convert_between_formats_keeps_the_graph(g, seed):
    text = encode(g, ALPHA, rng=np.random.default_rng(seed))
    other = convert(text, ALPHA, source="smiles", target="string2shape")
    back = convert(other, Alphabet.for_types(TYPES, "index"), source="string2shape", target="smiles",
                   target_alphabet=ALPHA)
    assert isomorphic(decode(other, Alphabet.for_types(TYPES, "index"), "string2shape").graph, g)
    assert decode(back, ALPHA).graph == decode(text, ALPHA).graph  # same traversal, same node order


def test_the_paper_format_rules_brackets_and_ring_labels():
    # a square T-W-T-W with a tail: one cycle edge, one branch
    g = TypedGraph.make(["Tower", "Wall", "Tower", "Wall", "Gate"], [(0, 1), (1, 2), (2, 3), (3, 0), (2, 4)])
    text = encode(g, ALPHA, root=0)  # deterministic traversal: edge order
    assert text == "T1W" + "T(W1)G"
    parsed = decode(text, ALPHA)
    assert parsed.ring_edges == [(0, 3)]
    assert parsed.node_index == [0, 2, 3, 5, 8]


def test_ring_labels_are_reused_lowest_first_and_string2shape_numbers_are_not():
    # two separate triangles joined by an edge: the second ring reuses label 1
    g = TypedGraph.make(["Wall"] * 6, [(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (4, 5), (5, 3)])
    text = encode(g, ALPHA, root=0)
    assert text.count("1") == 4 and "2" not in text
    s2s = convert(text, ALPHA, target="string2shape")
    assert "0" in s2s and "1" in s2s  # two cycle numbers


def test_string2shape_several_numbers_after_one_node_use_percent():
    g = TypedGraph.make(["Tower", "Wall", "Wall", "Wall"], [(0, 1), (1, 2), (2, 3), (0, 2), (0, 3)])
    s2s = encode(g, Alphabet.for_types(TYPES, "index"), root=0, fmt="string2shape")
    assert "%" in s2s
    assert isomorphic(decode(s2s, Alphabet.for_types(TYPES, "index"), "string2shape").graph, g)


def test_many_different_strings_per_graph():
    # a ring of 12 with two gates hanging off (a symmetric ring alone has only 3 strings)
    g = TypedGraph.make(["Tower", "Wall", "Wall"] * 4 + ["Gate", "Gate"],
                        [(i, (i + 1) % 12) for i in range(12)] + [(0, 12), (4, 13)])
    found = strings_of(g, ALPHA, 10, rng=np.random.default_rng(0))
    assert len(found) == 10 and len(set(found)) == 10
    assert all(isomorphic(decode(s, ALPHA).graph, g) for s in found)
    # a two-node graph has only two strings
    assert sorted(strings_of(TypedGraph.make(["Tower", "Wall"], [(0, 1)]), ALPHA, 10,
                             rng=np.random.default_rng(0))) == ["TW", "WT"]


def test_initials_alphabet():
    assert ALPHA.describe() == "G=Gate, T=Tower, W=Wall"
    a = Alphabet.for_types(["Entry", "Exit", "Pillar", "Ramp", "Turn"])
    assert a.letters == ("E", "X", "P", "R", "T")
    assert Alphabet.for_types(TYPES, "index").letters == ("A", "B", "C")
    assert Alphabet.from_json(ALPHA.to_json()) == ALPHA


@pytest.mark.parametrize("text, index, words", [
    ("TW(W1)Q", 6, "unknown character 'Q'"),
    ("TW W", 2, "unknown character whitespace"),
    ("TW)W", 2, "closes no branch"),
    ("TW()W", 3, "empty branch"),
    ("T((W)W)", 2, "must start with a part letter"),
    ("(TW)", 0, "needs a part letter before it"),
    ("1TW", 0, "needs a part letter before it"),
    ("TW(W)1", 5, "must follow its part's letter"),
    ("TW(W1", 2, "never closed"),
    ("TW1W", 2, "opened here but never closed"),
    ("T11", 2, "closes on the part that opened it"),
    ("T1W1", 3, "repeats the edge"),
    ("T%1W", 1, "two-digit ring label"),
    ("T0W0", 1, "ring label 0"),
])
def test_malformed_strings_point_at_the_character(text, index, words):
    with pytest.raises(ShapeStringError) as info:
        decode(text, ALPHA)
    err = info.value
    assert err.index == index, err.format()
    assert words in str(err)
    shown = err.format()
    assert f"<string>:1:{index + 1}:" in shown
    caret_line = shown.splitlines()[2]
    assert caret_line.index("^") - 4 == index


def test_empty_string_is_an_error():
    with pytest.raises(ShapeStringError, match="empty"):
        decode("   ", ALPHA)


def test_string2shape_errors():
    a = Alphabet.for_types(TYPES, "index")
    with pytest.raises(ShapeStringError, match="separates"):
        decode("A%1B1", a, "string2shape")
    with pytest.raises(ShapeStringError, match="more than twice"):
        decode("A0BC0A0", a, "string2shape")


def test_tokens_of_two_digit_ring_labels():
    toks = tokenize("T%12W%12", ALPHA)
    assert [t.kind for t in toks] == ["node", "ring", "node", "ring"]
    assert toks[1].value == 12


def test_histogram_distance_is_the_papers_E():
    assert histogram_distance({"A": 2, "B": 1}, {"A": 2, "B": 1}) == 0
    assert histogram_distance({"A": 2}, {"B": 2}) == 1
    assert histogram_distance({"A": 3, "B": 1}, {"A": 1, "B": 1}) == pytest.approx(2 / 6)


def test_graph_set_is_isomorphism_not_identity():
    a = TypedGraph.make(["Tower", "Wall", "Wall"], [(0, 1), (0, 2)])
    b = TypedGraph.make(["Wall", "Tower", "Wall"], [(1, 0), (1, 2)])
    c = TypedGraph.make(["Wall", "Tower", "Wall"], [(0, 2), (1, 2)])
    s = GraphSet()
    assert s.add(a) and not s.add(b) and s.add(c)
    assert len(s) == 2
    assert nx.is_connected(c.to_networkx())
