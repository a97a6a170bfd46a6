"""The built-in global constraints of tiling grammars, registered like any plugin's.

Each `check(graph, args, context)` gets the shape graph (nodes with `type`, `centroid`, `lo`,
`hi`; graph attribute `tolerance`), the evaluated arguments by parameter name, and a context
dict (`assembly` may be absent: the checks need only the graph). It returns violation messages
naming the parts involved; an empty list means the constraint holds.

- `connected`: the shape graph is one connected component.
- `grounded` (Liu 2015 "support"): every part is connected through contacts to a part that
  touches the ground plane z = min over all parts (within the contact tolerance).
- `path(from=A, to=B, downhill=false)` (Liu 2015 "path"): every A part reaches some B part
  through contacts; with `downhill=true` every step must not climb (centroid z may not rise by
  more than the tolerance), as a ball track needs.
- `count(T, lo, hi)`: the number of T parts is within lo..hi (hi may be omitted).
"""
from __future__ import annotations

from collections import deque
from typing import Any

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # networkx is imported by the checks that need it: plugin loading stays light
    import networkx as nx

from ..hookspecs import hookimpl
from ..registry import ConstraintSpec, Param

__all__ = ["check_connected", "check_count", "check_grounded", "check_path", "grammarkit_constraints"]

_MAX_LISTED = 8


def _ids(nodes) -> str:  # noqa: ANN001
    nodes = sorted(nodes, key=str)
    more = f" and {len(nodes) - _MAX_LISTED} more" if len(nodes) > _MAX_LISTED else ""
    return ", ".join(str(n) for n in nodes[:_MAX_LISTED]) + more


def check_connected(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    import networkx as nx

    if graph.number_of_nodes() == 0:
        return []
    comps = sorted(nx.connected_components(graph), key=lambda c: (-len(c), min(map(str, c))))
    if len(comps) == 1:
        return []
    return [f"the shape falls apart into {len(comps)} pieces; parts not connected to the largest "
            f"piece: {_ids(set().union(*comps[1:]))}"]


def check_grounded(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    import networkx as nx

    if graph.number_of_nodes() == 0:
        return []
    tol = float(graph.graph.get("tolerance", 1e-6))
    zmin = {n: float(d["lo"][2]) for n, d in graph.nodes(data=True)}
    ground = min(zmin.values())
    floating = []
    for comp in nx.connected_components(graph):
        if not any(zmin[n] <= ground + tol for n in comp):
            floating.extend(comp)
    if not floating:
        return []
    return [f"{len(floating)} part(s) are not supported (no chain of contacts to a part on the "
            f"ground z={ground:.4g}): {_ids(floating)}"]


def check_path(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    import networkx as nx

    src, dst = str(args["from"]), str(args["to"])
    downhill = bool(args.get("downhill") or False)
    tol = float(graph.graph.get("tolerance", 1e-6))
    types = nx.get_node_attributes(graph, "type")
    targets = {n for n, t in types.items() if t == dst}
    starts = sorted((n for n, t in types.items() if t == src), key=str)
    if not starts:
        return []
    if not targets:
        return [f"no {dst} part for the {len(starts)} {src} part(s) to reach: {_ids(starts)}"]
    # search backwards from all exits at once: a start is fine when it was reached
    z = {n: float(d["centroid"][2]) for n, d in graph.nodes(data=True)}
    reached = set(targets)
    queue = deque(targets)
    while queue:
        v = queue.popleft()
        for u in graph.neighbors(v):
            # the forward step is u -> v; downhill forbids climbing from u to v
            if u in reached or (downhill and z[v] > z[u] + tol):
                continue
            reached.add(u)
            queue.append(u)
    stuck = [n for n in starts if n not in reached]
    if not stuck:
        return []
    how = "a downhill path" if downhill else "a path"
    return [f"{len(stuck)} {src} part(s) have no {how} to a {dst} part: {_ids(stuck)}"]


def check_count(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    t = str(args["type"])
    lo = args.get("lo")
    hi = args.get("hi")
    n = sum(1 for _, d in graph.nodes(data=True) if d.get("type") == t)
    lo_ok = lo is None or n >= float(lo)
    hi_ok = hi is None or n <= float(hi)
    if lo_ok and hi_ok:
        return []
    rng = f"{'' if lo is None else int(lo)}..{'' if hi is None else int(hi)}"
    return [f"{n} {t} part(s), allowed {rng}"]


@hookimpl
def grammarkit_constraints():  # noqa: ANN201
    return [
        ConstraintSpec("connected", (), "the shape graph is one connected piece", check_connected),
        ConstraintSpec("grounded", (),
                       "every part is supported: connected through contacts to a part on the ground "
                       "plane (z = lowest point of the shape)", check_grounded),
        ConstraintSpec(
            "path",
            (Param("from", "string", doc="entry part type"), Param("to", "string", doc="exit part type"),
             Param("downhill", "any", required=False, default=False,
                   doc="every step must not climb (ball tracks)")),
            "every entry-type part reaches an exit-type part through contacts", check_path),
        ConstraintSpec(
            "count",
            (Param("type", "string"), Param("lo", "number", required=False, default=0),
             Param("hi", "number", required=False, default=None)),
            "the number of parts of a type lies within lo..hi", check_count),
    ]
