"""The exponential reference the tests and the benchmark compare `search` with: every
connected subgraph pair (networkx VF2) as symmetries, their operations, and random ordered
graphs to compare on."""
from __future__ import annotations

import itertools
from typing import Iterable, Sequence

import numpy as np

from .operations import operations_from_symmetry
from .search import Operation, OrderedGraph, Symmetry, _compatible

def _connected_subsets(nbrs: Sequence[Sequence[int]], limit: int | None = None) -> Iterable[frozenset]:
    """Every connected node set (each once), by extension from its smallest node."""
    n = len(nbrs)
    seen: set = set()
    for s in range(n):
        stack = [frozenset([s])]
        while stack:
            cur = stack.pop()
            if cur in seen:
                continue
            seen.add(cur)
            yield cur
            if limit is not None and len(cur) >= limit:
                continue
            for v in cur:
                for w in nbrs[v]:
                    if w > s and w not in cur:
                        stack.append(cur | {w})


def brute_force_symmetries(D: OrderedGraph, H: OrderedGraph | None = None, *,
                           max_subsets: int = 2_000_000) -> list[Symmetry]:
    """The closed symmetries by exhaustive search: every connected node set A of D, every
    induced subgraph of H isomorphic to D[A] with compatible nodes (networkx VF2), kept when
    the correspondence of edge positions is one rotation per node and the map is closed.
    Exponential: for small graphs (tests, benchmark baseline)."""
    import networkx as nx
    from networkx.algorithms import isomorphism as iso

    same = H is None or H is D
    H = D if H is None else H
    gh = nx.Graph()
    for v in range(len(H)):
        gh.add_node(v, c=(H.types[v], len(H.nbrs[v])))
    gh.add_edges_from(H.edges)
    gd = nx.Graph()
    for v in range(len(D)):
        gd.add_node(v, c=(D.types[v], len(D.nbrs[v])))
    gd.add_edges_from(D.edges)
    found: dict = {}
    count = 0
    for A in _connected_subsets(D.nbrs):
        count += 1
        if count > max_subsets:
            raise RuntimeError("brute force: too many connected subsets")
        sub = gd.subgraph(A)
        gm = iso.GraphMatcher(gh, sub, node_match=lambda x, y: x["c"] == y["c"])
        for m in gm.subgraph_isomorphisms_iter():  # host node -> donor node, induced
            f = {a: b for b, a in m.items()}
            sig = {}
            ok = True
            for a, b in f.items():
                d = len(D.nbrs[a])
                rots = None
                for i, w in enumerate(D.nbrs[a]):
                    if w in f:
                        r = (H.pos[b][f[w]] - i) % d
                        if rots is None:
                            rots = r
                        elif rots != r:
                            ok = False
                            break
                if not ok:
                    break
                if rots is None:  # a single node: every rotation is a separate symmetry
                    sig[a] = None
                else:
                    sig[a] = tuple((i + rots) % d for i in range(d))
            if not ok:
                continue
            free = [a for a in f if sig[a] is None]
            rot_sets = [range(max(len(D.nbrs[a]), 1)) for a in free]
            for rots in itertools.product(*rot_sets):
                s2 = dict(sig)
                for a, r in zip(free, rots):
                    d = len(D.nbrs[a])
                    s2[a] = tuple((i + r) % d for i in range(d)) if d else ()
                if not _closed(D, H, f, s2):
                    continue
                pairs = tuple(sorted(f.items()))
                sym = Symmetry(pairs, tuple(s2[a] for a, _ in pairs))
                if same and all(x == y for x, y in pairs) and all(
                        s == tuple(range(len(s))) for s in sym.sigma):
                    continue
                found.setdefault(sym.key, sym)
    return list(found.values())


def _closed(D: OrderedGraph, H: OrderedGraph, f: dict, sig: dict) -> bool:
    inv = {b: a for a, b in f.items()}
    for a, b in f.items():
        for i, w in enumerate(D.nbrs[a]):
            w2 = H.nbrs[b][sig[a][i]]
            if w not in f and w2 not in inv and not _compatible(D, H, w, w2):
                continue
            if f.get(w) != w2 or inv.get(w2) != w:
                return False
            if sig[w][D.pos[w][a]] != H.pos[w2][b]:
                return False
    return True


def brute_force_operations(D: OrderedGraph, H: OrderedGraph | None = None) -> list[Operation]:
    same = H is None or H is D
    H = D if H is None else H
    ops: dict = {}
    for sym in brute_force_symmetries(D, H):
        for op in operations_from_symmetry(D, H, sym, same):
            ops.setdefault(op.key, op)
    return sorted(ops.values(), key=lambda o: (o.removed_side.size() + o.copied_side.size(), o.key))


def random_ordered_graph(n: int, n_types: int, rng: np.random.Generator, extra_edges: int = 3) -> OrderedGraph:
    """A random connected graph (a random tree plus extra edges) with random cyclic orders."""
    edges = {(int(rng.integers(v)), v) for v in range(1, n)}
    for _ in range(extra_edges):
        a, b = sorted(rng.choice(n, 2, replace=False).tolist())
        edges.add((a, b))
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for a, b in sorted(edges):
        nbrs[a].append(b)
        nbrs[b].append(a)
    for row in nbrs:
        rng.shuffle(row)
    types = [chr(65 + int(t)) for t in rng.integers(0, n_types, n)]
    return OrderedGraph(types, [list(map(int, r)) for r in nbrs])
