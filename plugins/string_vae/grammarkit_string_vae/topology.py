"""The part of a tiling grammar that a string can be checked against: its topology rules.

A shape string fixes the shape graph but no geometry, so of a tiling grammar's rules
(`grammarkit.tiling.rules_from_grammar`) it can be checked against:

- known part types, allowed type pairs (`dock A -- B`);
- each part's neighbour types and counts (`neighbors T: {...} | ...` and count ranges),
  checked with `Rules.check_neighbors` itself, so a string is valid exactly when the graph
  would pass those checks of `grammarkit validate`;
- the global constraints that depend on the graph only: `connected`, `count(T, lo, hi)` and
  the reachability part of `path(from=A, to=B)`.

Docking placements, `grounded`, the downhill part of `path` and plugin constraints need
geometry: they are listed as `deferred` and checked when a string is instantiated in 3D.

`TopologyRules` also holds what the masked decoder needs: for each type the allowed
neighbour-count vectors as a union of boxes (per-type lo..hi plus a total degree range), so
"can this part still get a neighbour of type Y?" is a few comparisons. An exact multiset is a
box of one point; count ranges are one box; molecules' valences (`from_valences`) are one box
with a total degree bound.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from grammarkit.errors import GrammarkitError

from .graphs import TypedGraph

__all__ = ["Box", "TopologyRules", "TopologyViolation"]

# Types without neighbour rules may have any number of neighbours; the masked decoder still
# needs a finite bound to plan a completion (see masked.py).
UNBOUNDED = 10**6


@dataclass(frozen=True)
class Box:
    """Allowed neighbour counts: lo[k] <= count of type k <= hi[k], and total_lo <= degree <= total_hi."""

    lo: tuple[int, ...]
    hi: tuple[int, ...]
    total_lo: int
    total_hi: int


@dataclass(frozen=True)
class TopologyViolation:
    rule: str  # "unknown-type", "pair", "neighbors", "neighbor-count", "degree", "constraint NAME"
    message: str
    node: int | None = None  # the part (node index) it concerns
    edge: tuple[int, int] | None = None  # or the edge


@dataclass
class TopologyRules:
    """Topology rules over `types` (indices into this tuple are used internally)."""

    types: tuple[str, ...]
    boxes: dict[int, tuple[Box, ...]]  # per type index: the union of allowed boxes
    pair_ok: tuple[tuple[bool, ...], ...]  # [a][b]: may types a and b touch?
    count_limits: dict[int, tuple[int, int | None]] = field(default_factory=dict)  # count(T, lo, hi)
    reach: tuple[tuple[int, int], ...] = ()  # path(from=A, to=B): (A, B) type indices
    deferred: tuple[str, ...] = ()  # constraint names checked only in 3D
    rules: Any = None  # the grammarkit.tiling.Rules they came from (None for molecules)
    name: str = ""
    kind: str = "tiling"  # or "valence"

    # ---- construction ---------------------------------------------------------------------
    @classmethod
    def from_grammar(cls, grammar: Any) -> "TopologyRules":
        """From a tiling grammar (a Grammar IR or a `grammarkit.tiling.Rules`)."""
        from grammarkit.tiling import Rules, rules_from_grammar

        rules = grammar if isinstance(grammar, Rules) else rules_from_grammar(grammar)
        return cls.from_rules(rules)

    @classmethod
    def from_rules(cls, rules: Any) -> "TopologyRules":
        types = tuple(sorted(rules.types))
        if not types:
            raise GrammarkitError(f"grammar {rules.name!r} names no part types")
        index = {t: k for k, t in enumerate(types)}
        n = len(types)
        pair_ok = tuple(tuple(rules.allows_pair(a, b) for b in types) for a in types)
        boxes: dict[int, tuple[Box, ...]] = {}
        for t in types:
            k = index[t]
            cap = tuple(UNBOUNDED if pair_ok[k][j] else 0 for j in range(n))
            lo, hi = [0] * n, list(cap)
            for ranges in rules.neighbor_counts.get(t, ()):  # every range statement must hold
                for j, other in enumerate(types):
                    r_lo, r_hi = ranges.get(other, (0, 0))  # closed world: unlisted types 0..0
                    lo[j] = max(lo[j], int(r_lo))
                    hi[j] = min(hi[j], UNBOUNDED if r_hi is None else int(r_hi))
            ms = rules.neighbor_multisets.get(t)
            if ms is not None:
                found = []
                for m in sorted(ms):
                    if any(x not in index for x in m):
                        continue
                    counts = [0] * n
                    for x in m:
                        counts[index[x]] += 1
                    if all(lo[j] <= counts[j] <= hi[j] for j in range(n)):
                        found.append(Box(tuple(counts), tuple(counts), len(m), len(m)))
                boxes[k] = tuple(found)
            else:
                if all(lo[j] <= hi[j] for j in range(n)):
                    boxes[k] = (Box(tuple(lo), tuple(hi), sum(lo), min(UNBOUNDED, sum(hi))),)
                else:
                    boxes[k] = ()
        count_limits: dict[int, tuple[int, int | None]] = {}
        reach: list[tuple[int, int]] = []
        deferred: list[str] = []
        for name, args, _where in rules.constraints:
            if name == "connected":
                continue  # a string always describes one connected graph
            if name == "count" and str(args.get("type")) in index:
                lo = int(args.get("lo") or 0)
                hi = args.get("hi")
                k = index[str(args["type"])]
                old = count_limits.get(k, (0, None))
                new_hi = None if hi is None else int(hi)
                count_limits[k] = (max(old[0], lo), new_hi if old[1] is None else
                                   (old[1] if new_hi is None else min(old[1], new_hi)))
            elif name == "path" and str(args.get("from")) in index and str(args.get("to")) in index:
                reach.append((index[str(args["from"])], index[str(args["to"])]))
                if args.get("downhill"):
                    deferred.append("path(downhill)")
            else:
                deferred.append(name)
        return cls(types, boxes, pair_ok, count_limits, tuple(reach), tuple(dict.fromkeys(deferred)),
                   rules, rules.name, "tiling")

    @classmethod
    def from_valences(cls, valences: Mapping[str, int], name: str = "valence") -> "TopologyRules":
        """Molecule skeletons: atoms of type T have between 1 and valences[T] neighbours of any
        type (bond orders and hydrogens are not part of the graph); any two atoms may bond."""
        types = tuple(sorted(valences))
        n = len(types)
        boxes = {k: (Box((0,) * n, (int(valences[t]),) * n, 1, int(valences[t])),)
                 for k, t in enumerate(types)}
        pair_ok = tuple(tuple(True for _ in types) for _ in types)
        return cls(types, boxes, pair_ok, name=name, kind="valence")

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "TopologyRules":
        """Inverse of `to_json` (models and datasets carry their rules this way); checks then
        use the boxes, which accept exactly what `Rules.check_neighbors` accepts."""
        try:
            types = tuple(data["types"])
            index = {t: k for k, t in enumerate(types)}
            boxes = {index[t]: tuple(Box(tuple(b["lo"]), tuple(b["hi"]), int(b["total"][0]), int(b["total"][1]))
                                     for b in bs) for t, bs in data["boxes"].items()}
            ok = [[False] * len(types) for _ in types]
            for a, b in data["pairs"]:
                ok[index[a]][index[b]] = ok[index[b]][index[a]] = True
            count = {index[t]: (int(v[0]), None if v[1] is None else int(v[1]))
                     for t, v in data.get("count", {}).items()}
            reach = tuple((index[a], index[b]) for a, b in data.get("reach", ()))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise GrammarkitError(f"malformed topology rules ({type(exc).__name__}: {exc})") from None
        return cls(types, boxes, tuple(tuple(r) for r in ok), count, reach, tuple(data.get("deferred", ())),
                   None, str(data.get("name", "")), str(data.get("kind", "tiling")))

    # ---- queries ---------------------------------------------------------------------------
    def index(self, type_name: str) -> int:
        return self.types.index(type_name)

    def to_json(self) -> dict:
        return {"name": self.name, "kind": self.kind, "types": list(self.types),
                "boxes": {self.types[k]: [{"lo": list(b.lo), "hi": [min(h, UNBOUNDED) for h in b.hi],
                                           "total": [b.total_lo, b.total_hi]} for b in bs]
                          for k, bs in self.boxes.items()},
                "pairs": [[a, b] for i, a in enumerate(self.types) for j, b in enumerate(self.types)
                          if i <= j and self.pair_ok[i][j]],
                "count": {self.types[k]: list(v) for k, v in self.count_limits.items()},
                "reach": [[self.types[a], self.types[b]] for a, b in self.reach],
                "deferred": list(self.deferred)}

    def describe_boxes(self, k: int) -> str:
        """The allowed neighbourhoods of type k in words (multisets, ranges or degrees)."""
        parts = []
        for b in self.boxes.get(k, ()):
            if b.lo == b.hi:
                parts.append("{" + ", ".join(t for j, t in enumerate(self.types) for _ in range(b.lo[j])) + "}")
            elif self.kind == "valence":
                parts.append(f"{b.total_lo}..{b.total_hi} neighbours")
            else:
                parts.append(", ".join(f"{t} in {b.lo[j]}..{'' if b.hi[j] >= UNBOUNDED else b.hi[j]}"
                                       for j, t in enumerate(self.types) if b.hi[j] > 0))
        return " | ".join(parts) or "none (this type cannot occur)"

    def neighbour_ok(self, k: int, counts: Sequence[int]) -> bool:
        """Are these final neighbour counts (per type index) allowed for a type-k part?"""
        total = sum(counts)
        for b in self.boxes.get(k, ()):
            if b.total_lo <= total <= b.total_hi and all(lo <= c <= hi for lo, c, hi in zip(b.lo, counts, b.hi)):
                return True
        return False

    def check(self, graph: TypedGraph, *, limit: int = 100) -> list[TopologyViolation]:
        """Every topology rule the graph breaks (empty: valid as far as a string can tell)."""
        out: list[TopologyViolation] = []
        index = {t: k for k, t in enumerate(self.types)}
        for v, t in enumerate(graph.types):
            if t not in index:
                out.append(TopologyViolation("unknown-type", f"type {t!r} does not occur in the grammar", v))
        if out:
            return out[:limit]
        adj = graph.adjacency()
        for a, b in graph.edges:
            ta, tb = index[graph.types[a]], index[graph.types[b]]
            if not self.pair_ok[ta][tb]:
                out.append(TopologyViolation("pair", f"{graph.types[a]} may not touch {graph.types[b]} "
                                             "(no dock allows this pair)", a, (a, b)))
        for v, t in enumerate(graph.types):
            nbr = [graph.types[w] for w in adj[v]]
            if self.rules is not None:
                problems = self.rules.check_neighbors(t, nbr)
                for rule, allowed in problems:
                    out.append(TopologyViolation(rule, f"{t} has neighbours {{{', '.join(sorted(nbr))}}}; "
                                                 f"allowed: {allowed}", v))
            else:
                counts = [0] * len(self.types)
                for x in nbr:
                    counts[index[x]] += 1
                if not self.neighbour_ok(index[t], counts):
                    out.append(TopologyViolation("neighbors", f"{t} has neighbours {{{', '.join(sorted(nbr))}}}; "
                                                 f"allowed: {self.describe_boxes(index[t])}", v))
        hist = graph.histogram()
        for k, (lo, hi) in self.count_limits.items():
            c = hist.get(self.types[k], 0)
            if c < lo or (hi is not None and c > hi):
                out.append(TopologyViolation("constraint count", f"{c} {self.types[k]} part(s), allowed "
                                             f"{lo}..{'' if hi is None else hi}"))
        if graph.types:
            import networkx as nx

            comps = nx.number_connected_components(graph.to_networkx())
            if comps > 1:
                out.append(TopologyViolation("constraint connected", f"the graph falls apart into {comps} pieces"))
            elif comps == 1:
                for a, b in self.reach:
                    if hist.get(self.types[a], 0) and not hist.get(self.types[b], 0):
                        out.append(TopologyViolation("constraint path", f"no {self.types[b]} part for the "
                                                     f"{self.types[a]} part(s) to reach"))
        return out[:limit]

    def is_valid(self, graph: TypedGraph) -> bool:
        return not self.check(graph, limit=1)
