"""Cycle-consistent decoding of edge categories (beyond the paper): categories whose placements
close every cycle of the graph without collisions, the votes as priors."""
from __future__ import annotations

import numpy as np
import pytest

from grammarkit.dsl import load
from grammarkit.tiling import load_examples, local_frame, shape_graph, validate
from grammarkit_string_vae.categories import PartLibrary, edge_labels, learn_categories, variant_key
from grammarkit_string_vae.consistent import ConsistentDecoder, instantiate_consistent, placement_order
from grammarkit_string_vae.graphs import TypedGraph
from grammarkit_string_vae.instantiate import Instantiator

from .conftest import ROOT


@pytest.fixture(scope="module")
def castle():
    """(grammar, [(graph, true labels u -> v for u < v)] of the castle examples, categories)."""
    g = load(ROOT / "grammars/tiling/castle/castle.grammar")
    graphs, frames, variants = [], [], []
    for asm in load_examples(g):
        sg = shape_graph(asm)
        order = {p.id: k for k, p in enumerate(asm.parts)}
        graphs.append(TypedGraph.make([p.type for p in asm.parts], [(order[u], order[v]) for u, v in sg.edges()]))
        frames.append([local_frame(p).ravel().tolist() for p in asm.parts])
        variants.append([variant_key(p) for p in asm.parts])
    cats = learn_categories(graphs, frames, PartLibrary(g), variants=variants)
    truth = [{e: edge_labels(gr, fr, cats, va)[e] for e in gr.edges} for gr, fr, va in zip(graphs, frames, variants)]
    return g, list(zip(graphs, truth)), cats


def corrupted_votes(graph, truth, cats, every: int = 3) -> dict:
    """Votes (log-probability-like scores) that prefer a wrong category on every `every`-th
    edge that has a choice, and the true one elsewhere."""
    C = len(cats)
    votes, k = {}, 0
    for e in graph.edges:
        cand = cats.pair_categories(graph.types[e[0]], graph.types[e[1]])
        s = np.full(C, -1e9)
        s[cand] = -2.0
        s[truth[e]] = -0.1
        if len(cand) > 1:
            if k % every == 0:
                wrong = next(c for c in cand if c != truth[e])
                s[wrong], s[truth[e]] = -0.2, -1.0
            k += 1
        votes[e] = s
    return votes


def test_the_true_categories_are_consistent_and_build_the_example(castle):
    g, examples, cats = castle
    inst = Instantiator(g, cats)
    dec = ConsistentDecoder(inst, beam=4)
    for graph, truth in examples:
        votes = {e: np.where(np.arange(len(cats)) == truth[e], 0.0, -1e9) for e in graph.edges}
        res = dec.decode(graph, votes)
        assert res.consistent and res.categories == truth
        built = instantiate_consistent(inst, dec, graph, votes)
        assert built.ok and validate(g, built.assembly).ok
        assert all(p.mesh.is_watertight for p in built.assembly.parts)
        again = instantiate_consistent(inst, ConsistentDecoder(inst, beam=4), graph, votes)  # deterministic
        assert all(np.array_equal(a.mesh.vertices, b.mesh.vertices)
                   for a, b in zip(built.assembly.parts, again.assembly.parts))


def test_consistent_decoding_recovers_the_categories_from_corrupted_votes(castle):
    g, examples, cats = castle
    inst = Instantiator(g, cats)
    dec = ConsistentDecoder(inst, beam=16)
    for graph, truth in examples:
        votes = corrupted_votes(graph, truth, cats)
        voted = {e: int(np.argmax(v)) for e, v in votes.items()}
        wrong = sum(voted[e] != truth[e] for e in graph.edges)
        assert wrong >= 2  # the votes alone get these edges wrong
        res = dec.decode(graph, votes)
        assert res.consistent and res.reason is None
        assert res.categories == truth  # the cycles put every edge right
        again = dec.decode(graph, votes)  # deterministic
        assert again.categories == res.categories and again.score == res.score


def test_a_graph_that_cannot_close_is_reported_with_the_part_and_cycle(castle):
    g, _examples, cats = castle
    inst = Instantiator(g, cats)
    dec = ConsistentDecoder(inst, beam=8, widen=2)
    ring = TypedGraph.make(["Tower", "Wall", "Wall"] * 2, [(i, (i + 1) % 6) for i in range(6)])
    votes = {e: np.zeros(len(cats)) for e in ring.edges}
    res = dec.decode(ring, votes)
    assert not res.consistent and not res.frames
    assert "no consistent placement of part" in res.reason
    built = instantiate_consistent(inst, dec, ring, votes)
    assert not built.ok and built.assembly is None and built.reason == res.reason


def test_placement_order_closes_the_shortest_cycle_first():
    # a 4-cycle 0-1-2-3 and a 6-cycle through 0 and 2, and a tail 7-8 off part 5
    g = TypedGraph.make(["T"] * 9, [(0, 1), (1, 2), (2, 3), (3, 0), (2, 4), (4, 5), (5, 6), (6, 0), (5, 7), (7, 8)])
    order = placement_order(g)
    assert sorted(y for y, _ in order) == list(range(9))
    first = {y for y, _ in order[:4]}
    assert first == {0, 1, 2, 3}  # the 4-cycle through the root (a part of degree 3) closes first
    seen = set()
    for y, x in order:  # every part after the root hangs from a placed neighbour
        assert x == -1 and not seen or x in seen and (min(x, y), max(x, y)) in g.edges
        seen.add(y)
    assert [y for y, _ in order[-2:]] == [7, 8]  # the tail, on no cycle, comes last


def test_the_shipped_predictor_with_consistent_decoding_labels_the_examples(castle):
    pytest.importorskip("torch")
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.modelfile import WEIGHTS, ModelFileError

    if not (WEIGHTS / "castle.edges").exists():
        pytest.skip("no shipped weights in this checkout")
    g, examples, _cats = castle
    em = load_edge_model("builtin:castle", g)
    assert em.meta["training"]["config"]["epochs"] == 40 and em.model.config.bidirectional  # the script's defaults
    inst = Instantiator(g, em.categories)
    dec = ConsistentDecoder(inst)
    for asm, (graph, _truth) in zip(load_examples(g), examples):
        frames = [local_frame(p).ravel().tolist() for p in asm.parts]
        labels = edge_labels(graph, frames, em.categories, [variant_key(p) for p in asm.parts])
        votes = {e: v for e, (_k, v) in em.predict(graph, strings=8, seed=0, voting="logprob").items()}
        res = dec.decode(graph, votes)
        assert res.consistent
        assert all(res.categories[e] == labels[e] for e in graph.edges)  # every edge of the example right
        built = instantiate_consistent(inst, dec, graph, votes)
        assert built.ok and validate(g, built.assembly).ok
    with pytest.raises(ModelFileError, match="no shipped .edges model"):
        load_edge_model("builtin:nonesuch")
