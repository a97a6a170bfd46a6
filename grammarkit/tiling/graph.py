"""Shape graphs (Kalojanov 2019 section 3): one node per part, an edge per contact.

The graph is always recomputed from the geometry, so interpenetrating or misplaced parts show
up as edges that the rules do not allow (or as missing ones).
"""
from __future__ import annotations

import networkx as nx
import numpy as np

from .assembly import Assembly
from ..errors import ShapeError
from .contacts import candidate_pairs, check_tolerance, contact_arrays, default_tolerance, prepare

__all__ = ["NODE_ARRAYS", "EdgeData", "NodeData", "node_arrays", "shape_graph"]

# node attributes that are rows of one (n, 3) array per graph (graph attribute "node_arrays")
NODE_ARRAYS = ("centroid", "lo", "hi")


class NodeData(dict):
    """A shape-graph node's attributes. `type`, `index` and `box` are stored; `centroid`, `lo`
    and `hi` are read-only rows of the graph's (n, 3) arrays (`graph.graph["node_arrays"]`),
    made on access. One small numpy array per node and attribute cost about 165 MB at 100,000
    parts (issue 33); the rows read as before (`data["centroid"]`, `.get`, `in`, iteration,
    `dict(data)`, `copy()`, pickling)."""

    __slots__ = ("_rows",)

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._rows: dict | None = None

    def _lazy(self) -> tuple[str, ...]:
        return NODE_ARRAYS if self._rows is not None else ()

    def __missing__(self, key):
        if self._rows is not None and key in self._rows:
            return self._rows[key][dict.__getitem__(self, "index")]
        raise KeyError(key)

    def get(self, key, default=None):
        try:
            return self[key]
        except KeyError:
            return default

    def __contains__(self, key) -> bool:
        return dict.__contains__(self, key) or key in self._lazy()

    def __iter__(self):
        yield from dict.__iter__(self)
        yield from (k for k in self._lazy() if not dict.__contains__(self, k))

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def keys(self):  # noqa: ANN201 - a list: no live view of the rows
        return list(self)

    def items(self):  # noqa: ANN201
        return [(k, self[k]) for k in self]

    def values(self):  # noqa: ANN201
        return [self[k] for k in self]

    def copy(self) -> dict:
        """A plain dict with copies of the rows (what networkx's Graph.copy keeps)."""
        return {k: (v.copy() if k in NODE_ARRAYS else v) for k, v in self.items()}

    def __reduce__(self):
        return (dict, (self.copy(),))

    def __eq__(self, other) -> bool:  # noqa: ANN001
        return isinstance(other, dict) and list(self) == list(other) and all(
            np.array_equal(self[k], other[k]) if k in NODE_ARRAYS else self[k] == other[k] for k in self)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return repr(dict(self.items()))


class _ShapeGraph(nx.Graph):
    """An nx.Graph whose nodes' attributes are `NodeData` bound to its node arrays."""

    def node_attr_dict_factory(self) -> NodeData:  # type: ignore[override]
        d = NodeData()
        d._rows = self.graph.get("node_arrays")
        return d

    def __reduce__(self):
        # pickles (worker processes) as a plain nx.Graph with the rows copied into the nodes
        g = nx.Graph()
        g.graph.update((k, v) for k, v in self.graph.items() if k != "node_arrays")
        g.add_nodes_from((n, d.copy()) for n, d in self._node.items())
        g.add_edges_from(self.edges(data=True))
        return g.__reduce__()


def node_arrays(graph: nx.Graph) -> dict[str, np.ndarray] | None:
    """{"centroid", "lo", "hi": (n, 3) arrays, row = the node's `index`} of a `shape_graph`,
    or None for a graph built otherwise."""
    arrays = graph.graph.get("node_arrays")
    return arrays if isinstance(arrays, dict) else None


def shape_graph(assembly: Assembly, tolerance: float | None = None) -> nx.Graph:
    """networkx Graph of `assembly`.

    Nodes: part ids, with attributes `type` (str), `centroid` (np.ndarray (3,), area-weighted
    surface centroid: moves rigidly with the part), `lo`/`hi` (bounding box), `index` (position
    in `assembly.parts`), `box` (the mesh is exactly its axis-aligned box). Edges: `gap`
    (surface distance, <= tolerance), `kind` ("touch" or, for box parts that interpenetrate
    deeper than the tolerance, "overlap"). Graph attributes:
    `tolerance`, `scale` (bounding-box diagonal), `name`, `node_arrays` (the nodes' centroid,
    lo and hi as (n, 3) read-only arrays in part order: the node attributes are their rows).
    """
    if not isinstance(assembly, Assembly):
        raise ShapeError(f"shape_graph: expected an Assembly (see read_assembly), got {type(assembly).__name__}")
    tolerance = check_tolerance(tolerance, f"shape_graph({assembly.name or 'assembly'})")
    parts = assembly.parts
    if len({p.id for p in parts}) != len(parts):
        from collections import Counter

        dup = [k for k, v in Counter(p.id for p in parts).items() if v > 1]
        raise ShapeError(f"assembly {assembly.name!r}: duplicate part ids {dup[:5]}")
    geom = prepare(parts)
    if tolerance is None:
        tolerance = default_tolerance(geom)
    # the contacts first, then the graph's Python objects: the geometry's temporaries (prepare,
    # the R-tree, the narrow phase) are freed before the 100,000 node and adjacency dicts are
    # made, which then reuse their memory instead of growing the heap past it (issue 33)
    a, b, gap, depth = contact_arrays(parts, tolerance, geom=geom, pairs=candidate_pairs(geom, tolerance))
    scale = float(np.linalg.norm(geom.hi.max(axis=0) - geom.lo.min(axis=0))) if parts else 0.0
    # the graph keeps geom's own arrays (read-only from here; geom itself goes)
    arrays = {"centroid": geom.centroid, "lo": geom.lo, "hi": geom.hi}
    for arr in arrays.values():
        arr.flags.writeable = False
    boxy = geom.boxy.tolist()
    del geom
    g = _ShapeGraph()
    g.graph.update(tolerance=float(tolerance), scale=scale, name=assembly.name, node_arrays=arrays)
    g.add_nodes_from((p.id, {"type": p.type, "index": i, "box": boxy[i]}) for i, p in enumerate(parts))
    del boxy
    ids = [p.id for p in parts]
    tol = float(tolerance)
    # Edges with equal attributes share one read-only EdgeData (most contacts of a tiling are
    # gap 0.0, "touch"): a dict per edge was about 60 MB at 100,000 box parts (issue 33). The
    # adjacency is filled as nx.Graph.add_edges_from fills it (networkx documents `_adj`, the
    # dict of dicts, for subclasses), without the copy add_edges_from makes of each dict.
    # The contacts are read in chunks of EDGE_CHUNK: `tolist()` of all four arrays at once made
    # a Python object per value of 150,000 contacts (about 20 MB, the peak of a validate).
    shared: dict[tuple, EdgeData] = {}
    adj = g._adj
    for start in range(0, len(a), EDGE_CHUNK):
        end = start + EDGE_CHUNK
        for x, y, gp, d in zip(a[start:end].tolist(), b[start:end].tolist(), gap[start:end].tolist(),
                               depth[start:end].tolist()):
            key = (gp, d) if d >= 0 else (gp,)
            data = shared.get(key)
            if data is None:
                data = shared[key] = EdgeData(
                    {"gap": gp, "kind": "touch"} if d < 0 else {"gap": gp, "kind": "overlap" if d > tol else "touch",
                                                               "depth": d})
            u, v = ids[x], ids[y]
            adj[u][v] = data
            adj[v][u] = data
    return g


EDGE_CHUNK = 8192  # contacts turned into Python objects at a time by shape_graph


def drop_views(graph: nx.Graph) -> None:
    """Forget the graph's cached views (`edges`, `degree`, `nodes`, `adj`). `edges` and
    `degree` refer back to the graph, so a graph that has used them is a reference cycle and
    is only freed by a full garbage collection, which may come several graphs later: a
    validate that built its own 100,000-part graph dropped it this way (about 55 MB of nodes and
    adjacency dicts freed as it returns, not during the next validate; issue 33). The views
    are made again on the next access."""
    for name in ("edges", "degree", "nodes", "adj"):
        graph.__dict__.pop(name, None)


class EdgeData(dict):
    """A shape-graph edge's attributes (`gap`, `kind`, `depth`), shared by every edge with the
    same values and therefore read-only: edit a copy (`nx.Graph(graph)` or `graph.copy()` give
    plain dicts)."""

    __slots__ = ()

    def _read_only(self, *args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise TypeError("shape-graph edge attributes are shared between edges and read-only; "
                        "edit a copy of the graph (graph.copy())")

    __setitem__ = __delitem__ = update = setdefault = pop = popitem = clear = _read_only  # type: ignore[assignment]

    def copy(self) -> dict:
        return dict(self)

    def __reduce__(self):
        return (dict, (dict(self),))
