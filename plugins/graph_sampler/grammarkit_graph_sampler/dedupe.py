"""Which variants count as new: node-type histograms (the paper) or graph isomorphism.

`histogram` (default, as Kalojanov et al. 2019): a variant is new when its multiset of part
types has not been seen. It is conservative: different graphs with the same type counts are
dropped. `isomorphism`: new when no kept shape's typed graph is isomorphic to it; the
Weisfeiler-Lehman hash buckets candidates and networkx's VF2 decides within a bucket.
"""
from __future__ import annotations

from typing import Sequence

import networkx as nx

from grammarkit.tiling import histogram_key

MODES = ("histogram", "isomorphism")


def typed_graph(types: Sequence[str], edges) -> nx.Graph:
    g = nx.Graph()
    for i, t in enumerate(types):
        g.add_node(i, type=t)
    g.add_edges_from(edges)
    return g


class Deduper:
    """Remembers the shapes kept so far; `add` returns True for a new one."""

    def __init__(self, mode: str = "histogram"):
        if mode not in MODES:
            raise ValueError(f"dedupe must be one of {', '.join(MODES)}, not {mode!r}")
        self.mode = mode
        self.histograms: set = set()
        self._buckets: dict[tuple, list[nx.Graph]] = {}

    def key(self, types: Sequence[str], edges) -> tuple:
        if self.mode == "histogram":
            return histogram_key(types)
        g = typed_graph(types, edges)
        return (histogram_key(types), nx.weisfeiler_lehman_graph_hash(g, node_attr="type"))

    def is_new(self, types: Sequence[str], edges) -> bool:
        return self._check(types, edges, add=False)

    def add(self, types: Sequence[str], edges) -> bool:
        return self._check(types, edges, add=True)

    def _check(self, types, edges, *, add: bool) -> bool:
        if self.mode == "histogram":
            key = histogram_key(types)
            if key in self.histograms:
                return False
            if add:
                self.histograms.add(key)
            return True
        g = typed_graph(types, edges)
        key = (histogram_key(types), nx.weisfeiler_lehman_graph_hash(g, node_attr="type"))
        match = nx.algorithms.isomorphism.categorical_node_match("type", None)
        bucket = self._buckets.get(key, [])
        if any(nx.is_isomorphic(g, other, node_match=match) for other in bucket):
            return False
        if add:
            self._buckets.setdefault(key, []).append(g)
            self.histograms.add(key[0])
        return True
