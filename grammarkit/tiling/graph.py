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

__all__ = ["shape_graph"]


def shape_graph(assembly: Assembly, tolerance: float | None = None) -> nx.Graph:
    """networkx Graph of `assembly`.

    Nodes: part ids, with attributes `type` (str), `centroid` (np.ndarray (3,), area-weighted
    surface centroid: moves rigidly with the part), `lo`/`hi` (bounding box), `index` (position
    in `assembly.parts`), `box` (the mesh is exactly its axis-aligned box). Edges: `gap`
    (surface distance, <= tolerance), `kind` ("touch" or, for box parts that interpenetrate
    deeper than the tolerance, "overlap"). Graph attributes:
    `tolerance`, `scale` (bounding-box diagonal), `name`.
    """
    if not isinstance(assembly, Assembly):
        raise ShapeError(f"shape_graph: expected an Assembly (see read_assembly), got {type(assembly).__name__}")
    tolerance = check_tolerance(tolerance, f"shape_graph({assembly.name or 'assembly'})")
    parts = assembly.parts
    geom = prepare(parts)
    if tolerance is None:
        tolerance = default_tolerance(geom)
    g = nx.Graph()
    scale = float(np.linalg.norm(geom.hi.max(axis=0) - geom.lo.min(axis=0))) if parts else 0.0
    g.graph.update(tolerance=float(tolerance), scale=scale, name=assembly.name)
    for i, p in enumerate(parts):
        g.add_node(p.id, type=p.type, centroid=geom.centroid[i].copy(), lo=geom.lo[i].copy(),
                   hi=geom.hi[i].copy(), index=i, box=bool(geom.boxy[i]))
    if len(g) != len(parts):
        from collections import Counter

        dup = [k for k, v in Counter(p.id for p in parts).items() if v > 1]
        raise ShapeError(f"assembly {assembly.name!r}: duplicate part ids {dup[:5]}")
    ids = [p.id for p in parts]
    a, b, gap, depth = contact_arrays(parts, tolerance, geom=geom, pairs=candidate_pairs(geom, tolerance))
    tol = float(tolerance)
    g.add_edges_from(
        (ids[x], ids[y], {"gap": gp, "kind": "touch"} if d < 0
         else {"gap": gp, "kind": "overlap" if d > tol else "touch", "depth": d})
        for x, y, gp, d in zip(a.tolist(), b.tolist(), gap.tolist(), depth.tolist()))
    return g
