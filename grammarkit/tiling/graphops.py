"""Index-based shape-graph operations shared by the back ends that edit shape graphs.

A graph here is an adjacency list over node indices 0..n-1 (`adjacency_from_edges`): the
hot loops of the graph sampler and the substructure search run on these, and plain lists are
several times faster than networkx views. Nothing here looks at geometry except
`match_boundary`, which reads centroid distances given as arrays.

- `adjacency_from_edges(n, edges)`: sorted adjacency lists.
- `induced_edges(edges, nodes)` / `replace_subgraph(...)`: subgraph cut and replacement:
  which edges survive among kept nodes, renumbered, and the graph after a piece of another
  graph is copied into the hole.
- `random_connected_subgraph`: randomised breadth-first growth from a random seed node
  (Kalojanov et al. 2019, section 4).
- `cut_layers`: split a node set into the layer that stays with the *other* shape (`outer`:
  nodes with a neighbour outside the set), the layer that carries the cut edges on the inserted
  side (`inner`), and the interior. The boundary edges of the inserted piece `inner + interior`
  all run from `inner` to `outer`, so `inner + outer` are the "boundary nodes" to match.
- `match_boundary`: a randomised backtracking search (with forward checking) for nodes of a
  recipient with the same types and all pairwise centroid distances equal within a tolerance
  (the necessary condition for a rigid docking); it stops at the first match.
- `kept_region`: the recipient's nodes reachable from the matched outer layer without
  crossing the matched inner layer (the part of the recipient that survives).
- `histogram_key`: the node-type histogram as a hashable key (deduplication).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

__all__ = [
    "Adjacency", "Cut", "adjacency_from_edges", "cut_layers", "distance_matrix", "histogram_key",
    "induced_edges", "kept_region", "match_boundary", "random_connected_subgraph", "replace_subgraph",
]

Adjacency = Sequence[Sequence[int]]


def adjacency_from_edges(n: int, edges) -> list[list[int]]:
    """Sorted neighbour lists of an undirected graph on nodes 0..n-1."""
    adj: list[list[int]] = [[] for _ in range(n)]
    for a, b in edges:
        adj[a].append(b)
        adj[b].append(a)
    for row in adj:
        row.sort()
    return adj


def induced_edges(edges: Iterable[tuple[int, int]], nodes: Sequence[int]) -> set[tuple[int, int]]:
    """Edges with both ends in `nodes`, renumbered to positions in `nodes` (i < j).

    This is the cut of a subgraph: `nodes` are the nodes that stay, in their new order."""
    remap = {int(old): new for new, old in enumerate(nodes)}
    out = set()
    for u, v in edges:
        a, b = remap.get(int(u)), remap.get(int(v))
        if a is not None and b is not None:
            out.add((a, b) if a < b else (b, a))
    return out


def replace_subgraph(host_n: int, host_edges: Iterable[tuple[int, int]], removed: Iterable[int],
                     donor_edges: Iterable[tuple[int, int]], inserted: Sequence[int],
                     links: Iterable[tuple[int, int]]) -> tuple[list[int], list[tuple[int, int]]]:
    """The host graph with the nodes `removed` cut out and the donor's nodes `inserted` copied in.

    The result numbers the host's kept nodes first (ascending, as `kept` lists them), then the
    inserted donor nodes in the order given. Its edges: the host's edges among kept nodes, the
    donor's edges among inserted nodes, and `links` ((host node, donor node) pairs: the cut
    edges that reconnect the copy with the rest). Returns (kept, edges sorted, i < j).
    """
    gone = {int(v) for v in removed}
    kept = [v for v in range(host_n) if v not in gone]
    k = len(kept)
    edges = induced_edges(host_edges, kept)
    edges |= {(a + k, b + k) for a, b in induced_edges(donor_edges, inserted)}
    host_pos = {old: new for new, old in enumerate(kept)}
    donor_pos = {int(old): k + new for new, old in enumerate(inserted)}
    for h, d in links:
        if int(h) not in host_pos or int(d) not in donor_pos:
            raise ValueError(f"link ({h}, {d}): the host node must be kept and the donor node inserted")
        a, b = host_pos[int(h)], donor_pos[int(d)]
        edges.add((a, b) if a < b else (b, a))
    return kept, sorted(edges)


def random_connected_subgraph(adj: Adjacency, size: int, rng: np.random.Generator, *,
                              start: int | None = None, keep_prob: float = 0.5) -> list[int]:
    """A connected node set of at most `size` nodes, grown breadth-first from `start`.

    Each newly seen neighbour joins with probability `keep_prob`; a neighbour skipped in one
    round is offered again in the next, so the growth reaches `size` unless the component is
    smaller (at most `size` rounds). Nodes are returned in the order they joined (BFS order).
    """
    n = len(adj)
    if n == 0 or size <= 0:
        return []
    first = int(rng.integers(n)) if start is None else int(start)
    chosen = [first]
    inside = {first}
    for _ in range(size):
        if len(chosen) >= size:
            break
        before = len(chosen)
        for node in chosen[:before]:
            for nb in adj[node]:
                if nb in inside or len(chosen) >= size:
                    continue
                if rng.random() < keep_prob:
                    chosen.append(nb)
                    inside.add(nb)
        if len(chosen) == before and all(nb in inside for node in chosen for nb in adj[node]):
            break  # the whole component is in
    return chosen


@dataclass(frozen=True)
class Cut:
    """A sampled node set split into layers (all tuples keep the sampling order)."""

    nodes: tuple[int, ...]
    outer: tuple[int, ...]  # have a neighbour outside `nodes`: replaced by the recipient's
    inner: tuple[int, ...]  # not outer, adjacent to outer: inserted, carry the cut edges
    interior: tuple[int, ...]  # the rest: inserted

    @property
    def inserted(self) -> tuple[int, ...]:
        return self.inner + self.interior

    @property
    def boundary(self) -> tuple[int, ...]:
        """Endpoints of the boundary edges: matched against the recipient."""
        return self.inner + self.outer


def cut_layers(adj: Adjacency, nodes: Sequence[int]) -> Cut:
    """`nodes` split into outer, inner and interior layers (see the module docstring)."""
    inside = set(nodes)
    outer = [v for v in nodes if any(nb not in inside for nb in adj[v])]
    outer_set = set(outer)
    inner = [v for v in nodes if v not in outer_set and any(nb in outer_set for nb in adj[v])]
    inner_set = set(inner)
    interior = [v for v in nodes if v not in outer_set and v not in inner_set]
    return Cut(tuple(nodes), tuple(outer), tuple(inner), tuple(interior))


def distance_matrix(points: np.ndarray) -> np.ndarray:
    """(n, n) Euclidean distances between the rows of `points`."""
    pts = np.asarray(points, dtype=float)
    diff = pts[:, None, :] - pts[None, :, :]
    return np.sqrt((diff * diff).sum(axis=-1))


# long: one backtracking search (candidates per boundary node, pairwise-distance pruning,
# step budget) whose loop state is shared; splitting it would pass that state around
def match_boundary(src_types: Sequence[str], src_dist: np.ndarray, boundary: Sequence[int],
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
    #
    # Representation (speed; the search is the sampler's hottest loop): all domains are laid
    # out one after another (level l owns positions starts[l]..starts[l+1]); the live
    # candidates are one Python int used as a bit set over those positions. The pairwise test
    # of a position against all later positions is one numpy pass, made the first time that
    # candidate is tried and packed into an int, so forward checking is a single `&` plus one
    # test per later level. Candidate order, step counting and the test itself are those of
    # the plain recursive search (a test compares both), so the first match is the same.
    bnd = list(boundary)
    target = src_dist[np.ix_(bnd, bnd)]
    lens = [len(d) for d in doms]
    starts = [0]
    for n_ in lens:
        starts.append(starts[-1] + n_)
    cat = np.concatenate(doms)
    cat_list = cat.tolist()
    lab = np.repeat(np.arange(m), lens)
    tol_cat = tolerance * dst_sizes[cat]
    seg_masks = [((1 << lens[j]) - 1) << starts[j] for j in range(m)]
    want = target[lab]  # want[q, l] = d(boundary[level of q], boundary[l])
    rows: dict[int, int] = {}

    def row(p: int, level: int) -> int:
        """Bit set of the later positions q still possible once position p is assigned."""
        r = rows.get(p)
        if r is None:
            q0 = starts[level + 1]
            x, c = cat_list[p], cat[q0:]
            ok = (np.abs(dst_dist[c, x] - want[q0:, level])
                  <= np.maximum(tol_cat[q0:], tol_cat[p]))
            ok &= c != x
            r = rows[p] = int.from_bytes(np.packbits(ok, bitorder="little").tobytes(), "little") << q0
        return r

    steps = 0

    def search(level: int, alive: int) -> list[int] | None:
        nonlocal steps
        s0 = starts[level]
        cands = (alive & seg_masks[level]) >> s0
        last = level == m - 1
        later = seg_masks[level + 1:]
        while cands:
            low = cands & -cands
            i = low.bit_length() - 1
            cands ^= low
            steps += 1
            if steps > max_steps:
                return None
            if last:
                return [cat_list[s0 + i]]
            new = alive & row(s0 + i, level)
            dead = False
            for mask in later:
                if not new & mask:
                    dead = True  # some later boundary node would have no candidate
                    break
            if dead:
                continue
            found = search(level + 1, new)
            if found is not None:
                return [cat_list[s0 + i]] + found
            if steps > max_steps:
                return None
        return None

    return search(0, (1 << starts[-1]) - 1)


def kept_region(adj: Adjacency, outer: Sequence[int], inner: Sequence[int]) -> list[int]:
    """Nodes reachable from `outer` without entering `inner` (sorted)."""
    blocked = set(inner)
    seen = set(outer)
    stack = list(outer)
    while stack:
        v = stack.pop()
        for nb in adj[v]:
            if nb in seen or nb in blocked:
                continue
            seen.add(nb)
            stack.append(nb)
    return sorted(seen)


def histogram_key(types: Sequence[str]) -> tuple[tuple[str, int], ...]:
    """((type, count), ...) sorted by type: equal for graphs with the same type histogram."""
    counts: dict[str, int] = {}
    for t in types:
        counts[t] = counts.get(t, 0) + 1
    return tuple(sorted(counts.items()))
