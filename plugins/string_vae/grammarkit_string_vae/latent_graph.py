"""Latent graph search (Kalojanov et al. 2019, section 5.3) and the paper's Table 2 statistics.

Nodes are latent points that decode to valid strings. Each node is joined to its `k` nearest
neighbours (Euclidean distance in latent space) and to every node that decodes to an
equivalent (isomorphic) graph. Edge weights are the histogram similarity
E(c_x, c_y) = 1/(N_x + N_y) * sum over types |T_x - T_y|. Interpolating between two shapes is
the shortest path between their nodes.

The *naive* graph of Table 2 uses the same nodes but picks each node's `k` nearest
neighbours by string similarity E itself instead of latent distance (plus the equivalent
graphs). Many strings share a type histogram (E = 0), so their neighbours are each other and
the graph falls apart into clusters; the statistics show how much the latent space helps:
connected components, and the mean and largest accumulated weight of shortest paths between
random pairs of nodes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import networkx as nx
import numpy as np

from .graphs import TypedGraph, histogram_distance

__all__ = ["LatentGraph", "build_latent_graph", "path_statistics"]


@dataclass
class LatentGraph:
    graph: nx.Graph  # nodes 0..n-1 with attributes text, histogram; edges with weight
    kind: str  # "latent" or "naive"

    def shortest_path(self, a: int, b: int) -> list[int]:
        return nx.dijkstra_path(self.graph, a, b, weight="weight")


def _class_ids(graphs: Sequence[TypedGraph]) -> list[int]:
    """Isomorphism-class index of every graph."""
    from .graphs import GraphSet

    reps: list[tuple[GraphSet, int]] = []
    keyed: dict[tuple, list[tuple[GraphSet, int]]] = {}
    out = []
    for g in graphs:
        key = (tuple(sorted(g.histogram().items())), len(g.edges), g.wl_hash())
        bucket = keyed.setdefault(key, [])
        for s, cid in bucket:
            if g in s:
                out.append(cid)
                break
        else:
            s = GraphSet()
            s.add(g)
            cid = len(reps)
            reps.append((s, cid))
            bucket.append((s, cid))
            out.append(cid)
    return out


def build_latent_graph(z: np.ndarray, graphs: Sequence[TypedGraph], texts: Sequence[str], *, k: int = 4,
                       kind: str = "latent") -> LatentGraph:
    """The search graph over valid latent points `z` (n, d) with their decoded `graphs`."""
    n = len(graphs)
    hists = [g.histogram() for g in graphs]
    classes = _class_ids(graphs)
    G = nx.Graph()
    for i in range(n):
        G.add_node(i, text=texts[i], histogram=hists[i], cls=classes[i])

    def add(i: int, j: int) -> None:
        if i != j and not G.has_edge(i, j):
            G.add_edge(i, j, weight=histogram_distance(hists[i], hists[j]))

    if kind == "latent":
        from scipy.spatial import cKDTree

        tree = cKDTree(np.asarray(z, dtype=np.float64))
        kk = min(k + 1, n)
        _, nb = tree.query(np.asarray(z, dtype=np.float64), k=kk)
        for i in range(n):
            for j in np.atleast_1d(nb[i]):
                add(i, int(j))
    elif kind == "naive":
        types = sorted({t for h in hists for t in h})
        H = np.array([[h.get(t, 0) for t in types] for h in hists], dtype=np.float64)
        N = H.sum(axis=1)
        for i in range(n):
            d = np.abs(H - H[i]).sum(axis=1) / np.maximum(N + N[i], 1)
            d[i] = np.inf
            for j in np.argsort(d, kind="stable")[:k]:  # ties (same histogram) by index
                add(i, int(j))
    else:
        raise ValueError(f"kind must be latent or naive, got {kind!r}")
    by_class: dict[int, list[int]] = {}
    for i, c in enumerate(classes):
        by_class.setdefault(c, []).append(i)
    for members in by_class.values():
        for a in range(len(members)):
            for b in range(a + 1, len(members)):
                add(members[a], members[b])
    return LatentGraph(G, kind)


def path_statistics(lg: LatentGraph, *, pairs: int = 200, seed: int = 0) -> dict:
    """Connected components and shortest-path weights between random node pairs (pairs in
    different components have no path and are counted apart)."""
    G = lg.graph
    n = G.number_of_nodes()
    comps = nx.number_connected_components(G) if n else 0
    rng = np.random.default_rng(seed)
    weights: list[float] = []
    hops: list[int] = []
    unconnected = 0
    for _ in range(pairs if n > 1 else 0):
        a, b = (int(x) for x in rng.choice(n, size=2, replace=False))
        try:
            length, path = nx.single_source_dijkstra(G, a, b, weight="weight")
        except nx.NetworkXNoPath:
            unconnected += 1
            continue
        weights.append(float(length))
        hops.append(len(path) - 1)
    return {"kind": lg.kind, "nodes": n, "edges": G.number_of_edges(), "components": comps,
            "pairs": pairs, "unconnected_pairs": unconnected,
            "mean_path_weight": float(np.mean(weights)) if weights else None,
            "max_path_weight": float(np.max(weights)) if weights else None,
            "mean_path_edges": float(np.mean(hops)) if hops else None}
