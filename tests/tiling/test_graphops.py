"""grammarkit.tiling.graphops: index-based graph steps on synthetic graphs (no geometry)."""
from typing import Sequence

import networkx as nx
import numpy as np
import pytest

from grammarkit.tiling import (
    adjacency_from_edges, cut_layers, distance_matrix, histogram_key, induced_edges, kept_region,
    match_boundary, random_connected_subgraph, replace_subgraph,
)


def grid_adj(w, h):
    g = nx.convert_node_labels_to_integers(nx.grid_2d_graph(w, h), ordering="sorted")
    return adjacency_from_edges(len(g), g.edges()), g


def test_random_bfs_subgraphs_are_connected_sized_and_seeded():
    adj, g = grid_adj(6, 5)
    sizes = set()
    for s in range(60):
        k = 3 + s % 10
        nodes = random_connected_subgraph(adj, k, np.random.default_rng(s))
        assert len(nodes) == k == len(set(nodes))  # a 30-node grid always has room
        assert nx.is_connected(g.subgraph(nodes))
        again = random_connected_subgraph(adj, k, np.random.default_rng(s))
        assert nodes == again
        sizes.add(frozenset(nodes))
    assert len(sizes) > 50  # randomised: different seeds give different subgraphs


def test_random_bfs_stops_at_the_component():
    adj = adjacency_from_edges(6, [(0, 1), (1, 2), (3, 4), (4, 5)])
    nodes = random_connected_subgraph(adj, 5, np.random.default_rng(0), start=0)
    assert sorted(nodes) == [0, 1, 2]


def test_cut_layers_on_a_path():
    adj = adjacency_from_edges(7, [(i, i + 1) for i in range(6)])
    cut = cut_layers(adj, [3, 2, 4, 1, 5])
    assert set(cut.outer) == {1, 5} and set(cut.inner) == {2, 4} and cut.interior == (3,)
    assert set(cut.boundary) == {1, 2, 4, 5} and set(cut.inserted) == {2, 3, 4}
    # every boundary edge of the inserted piece ends in `outer`
    ins = set(cut.inserted)
    for v in ins:
        for nb in adj[v]:
            assert nb in ins or nb in cut.outer


def test_histogram_key_counts_types():
    assert histogram_key("ABA") == (("A", 2), ("B", 1))
    assert histogram_key([]) == ()


def test_induced_edges_renumbers_the_kept_nodes():
    edges = [(0, 1), (1, 2), (2, 3), (3, 0), (1, 3)]
    assert induced_edges(edges, [3, 1, 2]) == {(0, 1), (1, 2), (0, 2)}
    assert induced_edges(edges, [0, 2]) == set()


def test_replace_subgraph_copies_a_piece_into_the_hole():
    # host: path 0-1-2-3-4; cut out 2; copy donor path a-b (nodes 0, 1 of a 3-path 0-1-2) in,
    # linking host 1 to donor 0 and host 3 to donor 1: a path of 6 nodes
    kept, edges = replace_subgraph(5, [(0, 1), (1, 2), (2, 3), (3, 4)], [2],
                                   [(0, 1), (1, 2)], [0, 1], [(1, 0), (3, 1)])
    assert kept == [0, 1, 3, 4]
    g = nx.Graph(edges)
    assert sorted(g.nodes) == list(range(6)) and len(edges) == 5
    assert nx.is_isomorphic(g, nx.path_graph(6))
    with pytest.raises(ValueError):
        replace_subgraph(5, [(0, 1)], [2], [(0, 1)], [0], [(2, 0)])  # host node 2 was removed


def rot_z(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]])


def by_type(types):
    out = {}
    for i, t in enumerate(types):
        out.setdefault(t, []).append(i)
    return {t: np.array(v) for t, v in out.items()}


def test_match_boundary_finds_the_rigidly_moved_copy_among_distractors():
    rng = np.random.default_rng(3)
    src = rng.uniform(0, 10, (8, 3))
    src_types = list("ABABCCAB")
    # recipient: the same 8 points rotated + translated, shuffled, plus 12 distractors
    moved = src @ rot_z(37).T + np.array([5.0, -2.0, 1.0])
    distract = rng.uniform(-20, 30, (12, 3))
    perm = rng.permutation(20)
    dst = np.vstack([moved, distract])[perm]
    dst_types = (src_types + list("ABCABCABCABC"))
    dst_types = [dst_types[i] for i in perm]
    inv = np.argsort(perm)  # src node i is dst node inv[i]
    boundary = [0, 1, 2, 3, 4, 5]
    found = match_boundary(src_types, distance_matrix(src), boundary, by_type(dst_types),
                           distance_matrix(dst), np.full(20, 1.0), 0.01, np.random.default_rng(0))
    assert found == [int(inv[i]) for i in boundary]


def test_match_boundary_checks_types_and_every_pairwise_distance():
    src = np.array([[0, 0, 0], [4, 0, 0], [0, 3, 0]], float)
    dist = distance_matrix(src)
    # same types, one distance off by 0.5 (> 0.1 * size 1): no match
    dst = np.array([[0, 0, 0], [4, 0, 0], [0, 3.5, 0]], float)
    assert match_boundary("ABC", dist, [0, 1, 2], by_type("ABC"), distance_matrix(dst),
                          np.ones(3), 0.1, np.random.default_rng(0)) is None
    # within tolerance: match
    dst2 = np.array([[0, 0, 0], [4, 0, 0], [0, 3.05, 0]], float)
    assert match_boundary("ABC", dist, [0, 1, 2], by_type("ABC"), distance_matrix(dst2),
                          np.ones(3), 0.1, np.random.default_rng(0)) == [0, 1, 2]
    # right distances, wrong types: no match
    assert match_boundary("ABC", dist, [0, 1, 2], by_type("ACB"), distance_matrix(src),
                          np.ones(3), 0.1, np.random.default_rng(0)) is None


def test_match_boundary_is_injective_and_randomised():
    # a ring of 12 equal nodes: every rotation of the ring matches; the random offset picks one
    ang = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.stack([np.cos(ang), np.sin(ang), 0 * ang], axis=1) * 5
    types = ["T"] * 12
    dist = distance_matrix(ring)
    seen = set()
    for s in range(20):
        found = match_boundary(types, dist, [0, 1, 2], by_type(types), dist, np.ones(12), 0.01,
                               np.random.default_rng(s))
        assert found is not None and len(set(found)) == 3
        d = dist[np.ix_(found, found)]
        assert np.allclose(d, dist[np.ix_([0, 1, 2], [0, 1, 2])], atol=0.01)
        seen.add(tuple(found))
    assert len(seen) > 3


def test_kept_region_does_not_cross_the_inner_layer():
    adj = adjacency_from_edges(7, [(i, i + 1) for i in range(6)])
    assert kept_region(adj, [1, 5], [2, 4]) == [0, 1, 5, 6]


# The plain recursive search the bit-set `match_boundary` replaced (kept verbatim as the
# reference): the fast version must try the same candidates in the same order and count steps
# the same way, so it returns the same first match (or the same None) for the same rng.
def _reference_match_boundary(src_types: Sequence[str], src_dist: np.ndarray, boundary: Sequence[int],
                   dst_by_type: dict[str, np.ndarray], dst_dist: np.ndarray, dst_sizes: np.ndarray,
                   tolerance: float, rng: np.random.Generator, *, max_steps: int = 2000,
                   ) -> list[int] | None:
    """Nodes of the recipient matching `boundary` by type and all pairwise distances, or None.

    The pair (a, b) of boundary nodes matches (a', b') when
    |d(a, b) - d(a', b')| <= tolerance * max(size(a'), size(b')) (sizes of the recipient's
    parts). Depth-first search over the boundary nodes in order; candidates of each type are
    tried in a cyclic order from a random offset (the randomisation), and every assignment
    filters the candidates of all later nodes at once (forward checking), so a dead end is
    seen as soon as some later node has no candidate left. Returns the first complete,
    injective assignment, or None when there is none or after `max_steps` assignments.
    """
    m = len(boundary)
    if m == 0:
        return None
    doms: list[np.ndarray] = []
    for v in boundary:
        cands = dst_by_type.get(src_types[v])
        if cands is None or len(cands) == 0:
            return None
        off = int(rng.integers(len(cands)))
        doms.append(np.concatenate([cands[off:], cands[:off]]))
    # Boundary order as given (BFS order of the sample): consecutive nodes are near each other,
    # so each assignment prunes the next candidates hard. (Rarest-type-first was tried: it hits
    # the step limit more often and finds fewer matches on the castle.)
    order = list(range(m))
    doms = [doms[j] for j in order]
    bnd = [boundary[j] for j in order]
    target = src_dist[np.ix_(bnd, bnd)]
    steps = 0

    def search(level: int, domains: list[np.ndarray]) -> list[int] | None:
        nonlocal steps
        rest = domains[1:]
        if rest:
            lens = [len(d) for d in rest]
            cat = np.concatenate(rest)
            lab = np.repeat(np.arange(len(rest)), lens)
            want = target[level + 1 + lab, level]
            tol_cat = tolerance * dst_sizes[cat]
        for x in domains[0].tolist():
            steps += 1
            if steps > max_steps:
                return None
            if not rest:
                return [x]
            ok = np.abs(dst_dist[cat, x] - want) <= np.maximum(tol_cat, tolerance * dst_sizes[x])
            ok &= cat != x
            counts = np.bincount(lab[ok], minlength=len(rest))
            if counts.min() == 0:
                continue  # some later boundary node would have no candidate
            kept = cat[ok]
            ends = np.cumsum(counts).tolist()
            found = search(level + 1, [kept[a:b] for a, b in zip([0] + ends[:-1], ends)])
            if found is not None:
                return [x] + found
            if steps > max_steps:
                return None
        return None

    found = search(0, doms)
    if found is None:
        return None
    result = [0] * m
    for j, x in zip(order, found):
        result[j] = x
    return result


@pytest.mark.parametrize("case", range(60))
def test_match_boundary_equals_the_reference_search(case):
    rng = np.random.default_rng(case)
    n = int(rng.integers(8, 40))
    types = [str(t) for t in rng.integers(0, 3, n)]
    pts = rng.integers(0, 4, (n, 3)).astype(float)  # a lattice: many equal distances
    dist = distance_matrix(pts)
    sizes = rng.uniform(0.5, 1.5, n)
    dom = by_type(types)
    src_types = [str(t) for t in rng.integers(0, 3, 12)]
    src = rng.integers(0, 4, (12, 3)).astype(float)
    boundary = [int(v) for v in rng.permutation(12)[:int(rng.integers(1, 9))]]
    tol = float(rng.choice([0.01, 0.2, 0.6]))
    steps = int(rng.choice([5, 50, 2000]))
    for s_types, s_dist in ((src_types, distance_matrix(src)), (types, dist)):
        b = boundary if s_types is src_types else [int(v) for v in rng.permutation(n)[:len(boundary)]]
        seed = int(rng.integers(1 << 30))
        fast = match_boundary(s_types, s_dist, b, dom, dist, sizes, tol,
                              np.random.default_rng(seed), max_steps=steps)
        slow = _reference_match_boundary(s_types, s_dist, b, dom, dist, sizes, tol,
                                         np.random.default_rng(seed), max_steps=steps)
        assert fast == slow
