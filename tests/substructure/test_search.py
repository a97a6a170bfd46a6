"""The enumeration equals the brute-force search (all connected subgraph pairs, VF2) on small
graphs, random and cut from the tiling examples; the paper's hash does not change results."""
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from grammarkit.tiling import read_assembly
from grammarkit_substructure.brute_force import (
    brute_force_operations, brute_force_symmetries, random_ordered_graph,
)
from grammarkit_substructure.operations import find_operations
from grammarkit_substructure.search import OrderedGraph, find_symmetries
from grammarkit_substructure.shape import Shape

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "grammars" / "tiling").glob("*/*.glb"))


def _same(g: OrderedGraph):
    fs = {s.key for s in find_symmetries(g)}
    bs = {s.key for s in brute_force_symmetries(g)}
    fo = {o.key for o in find_operations(g)}
    bo = {o.key for o in brute_force_operations(g)}
    return fs, bs, fo, bo


@pytest.mark.parametrize("seed", range(40))
def test_random_graphs_match_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 13))
    g = random_ordered_graph(n, int(rng.integers(1, 4)), rng, extra_edges=int(rng.integers(0, 4)))
    fs, bs, fo, bo = _same(g)
    assert fs == bs
    assert fo == bo


def _pieces_of_examples():
    out = []
    for path in EXAMPLES[:4]:
        shape = Shape.from_assembly(read_assembly(path))
        g = nx.Graph(shape.edges)
        for start in (0, len(shape) // 2):
            nodes = list(nx.bfs_tree(g, start))[:12]
            keep = {v: k for k, v in enumerate(sorted(nodes))}
            nbrs = [[keep[w] for w in shape.graph.nbrs[v] if w in keep] for v in sorted(nodes)]
            out.append(pytest.param(OrderedGraph([shape.types[v] for v in sorted(nodes)], nbrs),
                                    id=f"{path.stem}-{start}"))
    return out


@pytest.mark.parametrize("graph", _pieces_of_examples())
def test_pieces_of_the_examples_match_brute_force(graph):
    fs, bs, fo, bo = _same(graph)
    assert fs == bs and fo == bo


def test_a_chain_has_recursive_grow_and_shrink_rules():
    # T - W - W - W - W - T on a line: shifting the walls gives grow and shrink operations
    types = ["T", "W", "W", "W", "W", "T"]
    nbrs = [[1], [0, 2], [1, 3], [2, 4], [3, 5], [4]]
    ops = find_operations(OrderedGraph(types, nbrs))
    kinds = {o.recursive for o in ops}
    assert {"grow", "shrink"} <= kinds
    grow = next(o for o in ops if o.recursive == "grow")
    assert set(grow.removed) < set(grow.copied)
    # every reconnection joins the types of an observed edge
    for o in ops:
        for a, w, b, w2 in o.pairs:
            assert types[a] == types[b] and w in nbrs[a]


def test_operations_are_normalised_no_boundary_pair_of_equal_types_is_left_out():
    # Removing a node pair of equal types from both sides would give an equivalent operation:
    # the symmetry is closed, so every cut pair has incompatible nodes across it.
    rng = np.random.default_rng(5)
    g = random_ordered_graph(10, 2, rng, extra_edges=2)
    for o in find_operations(g):
        for a, w, b, w2 in o.pairs:
            assert not (g.types[w] == g.types[w2] and len(g.nbrs[w]) == len(g.nbrs[w2]))


def test_dummy_edges_tolerate_an_ordering_defect():
    # two identical stars A(B, C, D) with the order of C and D swapped around the second hub
    types = ["A", "B", "C", "D", "E", "A", "B", "C", "D", "E"]
    nbrs = [[1, 2, 3], [0, 4], [0], [0], [1], [6, 8, 7], [5, 9], [5], [5], [6]]
    g = OrderedGraph(types, nbrs)
    big0 = max((len(s.pairs) for s in find_symmetries(g) if (0, 5) in s.pairs), default=0)
    big1 = max((len(s.pairs) for s in find_symmetries(g, q=1) if (0, 5) in s.pairs), default=0)
    assert big1 > big0
    assert all(s.violations <= 1 for s in find_symmetries(g, q=1))


def test_disconnected_graphs_match_brute_force_and_keep_other_components_out():
    # two copies of a small typed graph side by side, not touching
    types = ["T", "W", "W", "T", "W"] * 2
    nbrs = [[1], [0, 2], [1, 3], [2, 4], [3],
            [6], [5, 7], [6, 8], [7, 9], [8]]
    g = OrderedGraph(types, nbrs)
    fs, bs, fo, bo = _same(g)
    assert fs == bs and fo == bo
    for op in find_operations(g):
        a = op.pairs[0][0]
        comp = set(range(5)) if a < 5 else set(range(5, 10))
        assert set(op.copied) <= comp


def test_operations_are_ordinary_frozen_values():
    # find_operations builds its Operations without the dataclass constructor (for speed):
    # they must compare, hash and refuse assignment like constructed ones
    import dataclasses

    from grammarkit_substructure.search import Operation

    rng = np.random.default_rng(3)
    g = random_ordered_graph(9, 2, rng, extra_edges=2)
    ops = find_operations(g)
    assert ops
    for o in ops:
        built = Operation(o.pairs, o.removed_side, o.copied_side, o.recursive, o.symmetry_size, o.violations)
        assert o == built and hash(o) == hash(built) and repr(o) == repr(built)
    with pytest.raises(dataclasses.FrozenInstanceError):
        ops[0].recursive = "grow"
