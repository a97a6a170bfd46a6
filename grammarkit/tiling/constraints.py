"""The built-in global constraints of tiling grammars, registered like any plugin's.

Each `check(graph, args, context)` gets the shape graph (nodes with `type`, `centroid`, `lo`,
`hi`; graph attribute `tolerance`), the evaluated arguments by parameter name, and a context
dict (`assembly` may be absent: the checks need only the graph). It returns violation messages
naming the parts involved; an empty list means the constraint holds.

- `connected`: the shape graph is one connected component.
- `grounded(ground=None, sideways=false)` (Liu 2015 "support"): every part is carried down to
  the ground plane through contacts from below (contact normals along the up axis), and no part
  reaches below it; `ground` is the plane's height along the up axis (default: the grammar's
  examples' lowest point, else the shape's own); `sideways=true` also lets support pass
  through side contacts (never downwards). See `grammarkit.tiling.support`.
- `path(from=A, to=B, downhill=false)` (Liu 2015 "path"): there is at least one A part, and
  every A part reaches some B part through contacts; with `downhill=true` every step must not
  climb (centroid height may not rise by more than the tolerance), as a ball track needs.
- `count(T, lo, hi)`: the number of T parts is within lo..hi (hi may be omitted).
- `deformable(T)`: T parts may be deformed copies of their prototype (validate's rigid-copy
  check skips them; `grammarkit.tiling.rigid`).
- `filled(T, "site")`: every T part has a neighbour at that site wherever the site opens inside
  the shape's outline (holes; `grammarkit.tiling.holes`).
"""
from __future__ import annotations

from collections import deque
from typing import Any

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # networkx is imported by the checks that need it: plugin loading stays light
    import networkx as nx

from ..hookspecs import hookimpl
from ..registry import ConstraintSpec, Param

__all__ = ["check_connected", "check_count", "check_grounded", "check_path", "grammarkit_constraints", "sideways_span"]

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


def _support(graph: nx.Graph, args: dict[str, Any], context: dict | None):  # noqa: ANN202
    """(sunk, floating, runs, nodes, ground, own, axis index, sign, max_span) of the shape: the
    support test of `grounded` (support.py) on the graph's parts."""
    import numpy as np

    from .graph import node_arrays
    from .support import carry_directions, support_problems

    context = context or {}
    rules = context.get("rules")
    up = _up_of(rules)
    tol = float(graph.graph.get("tolerance", 1e-6))
    data = dict(graph.nodes(data=True))  # one pass (NodeView lookups are slow on 100k parts)
    nodes = sorted(data, key=lambda n: data[n].get("index", 0))
    pos = {n: i for i, n in enumerate(nodes)}
    arrays = node_arrays(graph)
    if arrays is not None:  # a shape_graph's own (n, 3) rows: no per-node temporaries at 100k parts
        rows = np.fromiter((data[n]["index"] for n in nodes), dtype=np.int64, count=len(nodes))
        lo, hi = arrays["lo"][rows], arrays["hi"][rows]
    else:
        lo = np.array([data[n]["lo"] for n in nodes], dtype=np.float64).reshape(-1, 3)
        hi = np.array([data[n]["hi"] for n in nodes], dtype=np.float64).reshape(-1, 3)
    edges = np.array([(pos[u], pos[v]) for u, v in graph.edges()], dtype=np.int64).reshape(-1, 2)
    carry = context.get("carry")
    if carry is None or len(carry) != len(edges):
        boxy = np.array([bool(data[n].get("box", False)) for n in nodes], dtype=bool)
        assembly = context.get("assembly")
        parts = None
        if assembly is not None:
            parts = [assembly.parts[data[n]["index"]] for n in nodes]
        elif not boxy.all():
            boxy[:] = True  # no geometry at hand: judge by the bounding boxes
        keys = context.get("keys")
        carry = carry_directions(lo, hi, boxy, edges, tol, up, parts=parts,
                                 cache=context.get("support_cache"),
                                 keys=None if keys is None else [keys[data[n]["index"]] for n in nodes])
    ground = args.get("ground")
    if ground is None and rules is not None:
        ground = getattr(rules, "ground", None)
    k = int(np.argmax(np.abs(up)))
    sign = 1.0 if up[k] > 0 else -1.0
    own = False
    if ground is None and len(nodes):  # neither the grammar nor its examples say: the shape's own lowest point
        ground = float(lo[:, k].min()) if sign > 0 else float(hi[:, k].max())
        own = True
    sideways = bool(args.get("sideways") or False)
    max_span = args.get("max_span")
    max_span = None if max_span is None or not sideways else int(max_span)
    sunk, floating, runs, long_run = support_problems(lo, hi, carry, edges, tol, up, float(ground or 0.0),
                                                      sideways=sideways, max_span=max_span)
    return sunk, floating, runs, long_run, nodes, lo, hi, ground, own, k, sign, max_span


def check_grounded(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    import numpy as np

    if graph.number_of_nodes() == 0:
        return []
    sunk, floating, runs, long_run, nodes, lo, hi, ground, own, k, sign, max_span = _support(graph, args, context)
    sideways = bool(args.get("sideways") or False)
    where = f"{'xyz'[k]}={float(ground):.4g}" + (" (the shape's lowest point)" if own else "")
    out = []
    if len(sunk):
        depth = float(np.max(sign * ground - np.where(sign > 0, lo[sunk, k], -hi[sunk, k])))
        out.append(f"{len(sunk)} part(s) reach below the ground {where} (by up to {depth:.4g}): "
                   f"{_ids(nodes[i] for i in sunk)}")
    floating = np.setdiff1d(floating, long_run)
    if len(long_run):
        out.append(f"{len(long_run)} part(s) are held only sideways in runs longer than max_span={max_span} "
                   f"(no carried part below them): {_ids(nodes[i] for i in long_run)}")
    if len(floating):
        how = "contacts from below or from the side" if sideways else "contacts from below"
        out.append(f"{len(floating)} part(s) are not carried down to the ground {where} (no chain of "
                   f"{how}): {_ids(nodes[i] for i in floating)}")
    return out


def sideways_span(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> int | None:
    """The longest sideways run of the shape (the most parts in one connected group held only
    sideways, support.sideways_runs): what `learn` writes as `max_span`. None when some part
    is not carried even with side contacts."""
    if graph.number_of_nodes() == 0:
        return 0
    runs = _support(graph, {**args, "sideways": True, "max_span": None}, context)[2]  # unbounded
    return None if (runs < 0).any() else int(runs.max(initial=0))


def _up_of(rules: Any):  # noqa: ANN202
    import numpy as np

    from .orientation import up_vector

    axis = getattr(rules, "up", "+z") if rules is not None else "+z"
    v = up_vector(axis)
    return v if v is not None else np.array([0.0, 0.0, 1.0])


def check_path(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    import networkx as nx

    src, dst = str(args["from"]), str(args["to"])
    downhill = bool(args.get("downhill") or False)
    tol = float(graph.graph.get("tolerance", 1e-6))
    types = nx.get_node_attributes(graph, "type")
    targets = {n for n, t in types.items() if t == dst}
    starts = sorted((n for n, t in types.items() if t == src), key=str)
    if not starts:
        # a path needs somewhere to start: a ball track without an entry is no ball track
        return [f"no {src} part: nothing for the path from {src} to {dst} to start from"]
    if not targets:
        return [f"no {dst} part for the {len(starts)} {src} part(s) to reach: {_ids(starts)}"]
    # search backwards from all exits at once: a start is fine when it was reached
    up = _up_of((context or {}).get("rules"))
    z = {n: float(d["centroid"] @ up) for n, d in graph.nodes(data=True)}  # height along the up axis
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


def _check_filled(graph: nx.Graph, args: dict[str, Any], context: dict | None = None) -> list[str]:
    from .holes import check_filled

    return check_filled(graph, args, context)


@hookimpl
def grammarkit_constraints():  # noqa: ANN201
    return [
        ConstraintSpec("connected", (), "the shape graph is one connected piece", check_connected),
        ConstraintSpec("grounded",
                       (Param("ground", "number", required=False, default=None,
                              doc="the ground plane's height along the up axis (default: the examples' "
                                  "lowest point)"),
                        Param("sideways", "any", required=False, default=False,
                              doc="support may also pass through side contacts (never downwards)"),
                        Param("max_span", "number", required=False, default=None,
                              doc="with sideways: at most this many parts in a row held only by side "
                                  "contacts (learn writes the examples' longest run)")),
                       "every part is carried down to the ground plane through contacts from below, "
                       "and none reaches below it", check_grounded),
        ConstraintSpec(
            "path",
            (Param("from", "string", doc="entry part type"), Param("to", "string", doc="exit part type"),
             Param("downhill", "any", required=False, default=False,
                   doc="every step must not climb (ball tracks)")),
            "there is an entry-type part and every one reaches an exit-type part through contacts",
            check_path),
        ConstraintSpec(
            "deformable", (Param("type", "string", doc="part type"),),
            "parts of the type may be deformed copies of their prototype (no rigid-copy check; "
            "see grammarkit.tiling.rigid)", lambda graph, args, context=None: []),
        ConstraintSpec(
            "filled",
            (Param("type", "string", doc="part type"), Param("site", "string", doc="one of its sites")),
            "every part of the type has a neighbour at the site wherever the site opens inside the "
            "shape's outline (no holes; see grammarkit.tiling.holes)", _check_filled),
        ConstraintSpec(
            "count",
            (Param("type", "string"), Param("lo", "number", required=False, default=0),
             Param("hi", "number", required=False, default=None)),
            "the number of parts of a type lies within lo..hi", check_count),
    ]
