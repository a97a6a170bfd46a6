"""Typed graphs (a shape graph without geometry), isomorphism classes and histogram similarity.

A `TypedGraph` is what a shape string encodes: one node per part with its type, undirected
edges between touching parts. `GraphSet` keeps isomorphism classes (Weisfeiler-Lehman hash as
the bucket, networkx's VF2 inside a bucket) for dedupe, novelty and uniqueness.
`histogram_distance` is Kalojanov et al.'s similarity E (section 5.3).
"""
from __future__ import annotations

import hashlib
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

import networkx as nx

__all__ = ["GraphSet", "TypedGraph", "histogram_distance"]


@dataclass(frozen=True)
class TypedGraph:
    """Node types (node i has type types[i]) and undirected edges (i < j, sorted, no repeats)."""

    types: tuple[str, ...]
    edges: tuple[tuple[int, int], ...]

    @classmethod
    def make(cls, types: Sequence[str], edges: Iterable[Sequence[int]]) -> "TypedGraph":
        norm = sorted({(min(int(a), int(b)), max(int(a), int(b))) for a, b in edges})
        n = len(types)
        for a, b in norm:
            if a == b:
                raise ValueError(f"edge ({a}, {b}) is a loop")
            if not (0 <= a < n and 0 <= b < n):
                raise ValueError(f"edge ({a}, {b}) names a node outside 0..{n - 1}")
        return cls(tuple(str(t) for t in types), tuple(norm))

    @classmethod
    def from_networkx(cls, graph: nx.Graph, type_attr: str = "type") -> "TypedGraph":
        nodes = list(graph.nodes())
        index = {n: i for i, n in enumerate(nodes)}
        return cls.make([graph.nodes[n][type_attr] for n in nodes],
                        [(index[u], index[v]) for u, v in graph.edges()])

    @classmethod
    def from_json(cls, data: Mapping) -> "TypedGraph":
        """From `{"types": [...], "edges": [[i, j], ...]}` or the graph sampler's manifest
        form `{"nodes": [{"id", "type"}], "edges": [[id, id], ...]}`."""
        if "types" in data:
            return cls.make(data["types"], data.get("edges", ()))
        nodes = data["nodes"]
        index = {n["id"]: i for i, n in enumerate(nodes)}
        return cls.make([n["type"] for n in nodes], [(index[a], index[b]) for a, b in data["edges"]])

    def to_json(self) -> dict:
        return {"types": list(self.types), "edges": [list(e) for e in self.edges]}

    def to_networkx(self) -> nx.Graph:
        g = nx.Graph()
        for i, t in enumerate(self.types):
            g.add_node(i, type=t)
        g.add_edges_from(self.edges)
        return g

    def __len__(self) -> int:
        return len(self.types)

    @property
    def cycle_rank(self) -> int:
        """Independent cycles (edges beyond a spanning forest): the ring closures of a string."""
        return len(self.edges) - len(self.types) + nx.number_connected_components(self.to_networkx())

    def histogram(self) -> dict[str, int]:
        return dict(sorted(Counter(self.types).items()))

    def adjacency(self) -> list[list[int]]:
        adj: list[list[int]] = [[] for _ in self.types]
        for a, b in self.edges:
            adj[a].append(b)
            adj[b].append(a)
        return adj

    def wl_hash(self, iterations: int = 4) -> str:
        """A Weisfeiler-Lehman hash of the typed graph (isomorphic graphs hash alike): node
        labels start as types and are refined `iterations` times by the sorted labels of the
        neighbours; the hash is the sorted multiset of all labels seen. The same refinement as
        networkx's `weisfeiler_lehman_graph_hash`, on adjacency lists (about 20 times faster;
        a derive run hashes every training graph once)."""
        adj = self.adjacency()
        labels = [_digest(t) for t in self.types]
        seen = sorted(labels)
        for _ in range(iterations):
            labels = [_digest(labels[i] + "|" + ",".join(sorted(labels[j] for j in adj[i])))
                      for i in range(len(labels))]
            seen += sorted(labels)
        return _digest(";".join(seen))


def _digest(text: str) -> str:
    return hashlib.blake2b(text.encode(), digest_size=8).hexdigest()


def _node_match(a: dict, b: dict) -> bool:
    return a["type"] == b["type"]


@dataclass
class GraphSet:
    """Isomorphism classes of typed graphs. `add` returns True for a graph not seen before."""

    _buckets: dict[tuple, list[TypedGraph]] = field(default_factory=dict)
    _count: int = 0

    _labels: dict = field(default_factory=dict)  # WL signature -> small int, shared by the set's graphs

    def _key(self, g: TypedGraph) -> tuple:
        """The bucket: type counts, edge count and the Weisfeiler-Lehman refinement's label
        multisets (8 rounds; long rings need more than networkx's default 3), with labels
        interned per set as small ints (equal signatures get equal labels, so isomorphic graphs
        get equal keys; about 10 times cheaper than hashing strings)."""
        table = self._labels
        adj = g.adjacency()
        labels = [table.setdefault(t, len(table)) for t in g.types]
        key: list = [tuple(sorted(Counter(g.types).items())), len(g.edges), tuple(sorted(labels))]
        for _ in range(8):
            labels = [table.setdefault((labels[i], tuple(sorted(labels[j] for j in adj[i]))), len(table))
                      for i in range(len(labels))]
            key.append(tuple(sorted(labels)))
        return tuple(key)

    def find(self, g: TypedGraph) -> bool:
        bucket = self._buckets.get(self._key(g))
        if not bucket:
            return False
        h = g.to_networkx()
        return any(nx.is_isomorphic(h, other.to_networkx(), node_match=_node_match) for other in bucket)

    __contains__ = find

    def add(self, g: TypedGraph) -> bool:
        key = self._key(g)
        bucket = self._buckets.setdefault(key, [])
        if bucket:
            h = g.to_networkx()
            if any(nx.is_isomorphic(h, other.to_networkx(), node_match=_node_match) for other in bucket):
                return False
        bucket.append(g)
        self._count += 1
        return True

    def __len__(self) -> int:
        return self._count


def histogram_distance(x: Mapping[str, int], y: Mapping[str, int]) -> float:
    """E(c_x, c_y) = 1/(N_x + N_y) * sum over types T of |T_x - T_y| (0: same type counts,
    1: no type in common). N = parts in the shape, T_x = parts of type T in shape x."""
    total = sum(x.values()) + sum(y.values())
    if total == 0:
        return 0.0
    return sum(abs(x.get(t, 0) - y.get(t, 0)) for t in set(x) | set(y)) / total
