"""Graph instantiation (Kalojanov et al. 2019, section 6): a shape graph with edge categories
becomes an assembly of the example parts.

Every part of a type is a rigid copy of the type's `part` geometry
(`grammarkit.tiling.part_prototype`), placed by its Kalojanov frame. A try:

1. starts from a random edge: its first part is placed where a part of that type sits in the
   grammar's first example that has one (so shapes stand like the examples);
2. adds the other parts breadth-first. A part joins through the edge to its parent with that
   edge's category: the parent's frame times the category's placement (an actual docking
   of the input shapes). The partial shape is checked: the new part must touch exactly the
   placed parts it is adjacent to in the graph (no interpenetration, no missing contact), and
   its placement relative to every placed neighbour (cycle edges) must be one of the grammar's
   docking categories. If the predicted category fails, the other categories of the type
   pair are tried in a random order (the paper's Monte-Carlo edge insertion);
3. if no category of an edge works, the search jumps back to the latest placed part the
   failures were traced to (the parts on the tree path between the new part and the one it
   misses or hits: conflict-directed backjumping) and takes its next candidate, at most
   `budget` insertions per try;
4. a try that fails ends with the reason (the edge and, if a cycle edge was the reason, the
   cycle) and the next try starts from another random edge.

A finished shape is recomputed from geometry and validated against the whole grammar (docks,
neighbours, constraints) at the examples' contact tolerance and at `grammarkit validate`'s
default one, and its recomputed graph must be the requested graph; only then is it returned.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grammarkit.errors import GrammarkitError

from .categories import EdgeCategories
from .graphs import TypedGraph

__all__ = ["Instantiation", "Instantiator"]


@dataclass
class Instantiation:
    assembly: Any | None  # grammarkit.tiling.Assembly, or None when it failed
    tries: int = 0  # tries started (start edges)
    insertions: int = 0  # part placements tested
    monte_carlo: int = 0  # edges placed with another category than the predicted one
    categories: dict[tuple[int, int], int] = field(default_factory=dict)  # (u, v), u < v: used, u -> v
    reason: str | None = None
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return self.assembly is not None


class Instantiator:
    def __init__(self, grammar: Any, cats: EdgeCategories, *, library: Any = None, tolerance: float | None = None,
                 budget: int = 400):
        from grammarkit.tiling import default_tolerance, load_examples, rules_from_grammar

        from .categories import PartLibrary

        self.grammar = grammar
        self.cats = cats
        self.budget = int(budget)  # part insertions per try (backtracking included)
        self.rules = rules_from_grammar(grammar)
        self.library = library or PartLibrary(grammar)
        if tolerance is None:
            examples = load_examples(grammar)
            tolerance = min(default_tolerance(a) for a in examples) if examples else None
        if tolerance is None:
            raise GrammarkitError(f"grammar {grammar.name!r} has no examples to take the contact tolerance "
                                  "from; pass a tolerance")
        self.tolerance = float(tolerance)
        self.default_variant = self.library.default
        self.start_frame = self.library.start_frame

    def part(self, type_name: str, frame: np.ndarray, pid: str, variant: str | None = None):  # noqa: ANN201
        return self.library.part(type_name, frame, pid, variant)

    def _box(self, part) -> np.ndarray:  # noqa: ANN001
        """(2, 3) bounding box of a part, grown by the contact tolerance."""
        V = np.asarray(part.mesh.vertices)
        return np.stack([V.min(axis=0) - self.tolerance, V.max(axis=0) + self.tolerance])

    def _near(self, box: np.ndarray, boxes: list[np.ndarray]) -> list[int]:
        """Indices of `boxes` that overlap `box` (both grown by the tolerance: parts whose boxes
        do not overlap cannot be in contact)."""
        if not boxes:
            return []
        B = np.asarray(boxes)
        ok = np.all(B[:, 0] <= box[1], axis=1) & np.all(B[:, 1] >= box[0], axis=1)
        return np.flatnonzero(ok).tolist()

    def _touching(self, new, placed: list, near: list[int] | None = None) -> set[int]:  # noqa: ANN001
        """Indices into `placed` (Parts) that the new part touches (`near`: the candidates
        whose bounding boxes overlap the new part's, if already known)."""
        from grammarkit.tiling import contacts

        if not placed:
            return set()
        if near is None:
            near = self._near(self._box(new), [self._box(p) for p in placed])
        if not near:
            return set()
        parts = [new] + [placed[i] for i in near]
        pairs = np.array([[0, k + 1] for k in range(len(near))], dtype=np.int64)
        return {near[c.b - 1] for c in contacts(parts, self.tolerance, pairs=pairs)}

    # ---- the algorithm -----------------------------------------------------------------------
    def instantiate(self, graph: TypedGraph, predicted: dict[tuple[int, int], int] | None = None, *,
                    seed: int = 0, max_tries: int = 8, deadline: float | None = None) -> Instantiation:
        """Place `graph` using the predicted category of each edge (u, v), u < v, direction
        u -> v: one category, or a ranking (best first; the predictor's order is tried before
        the Monte-Carlo order). Missing edges: Monte-Carlo from the start."""
        t0 = time.perf_counter()
        predicted = dict(predicted or {})
        unknown = sorted({t for t in graph.types if t not in self.default_variant})
        if unknown:
            return Instantiation(None, reason=f"no edge categories for part type(s) {', '.join(unknown)}")
        if len(graph.types) == 1:
            asm = self._assembly(graph, [self.start_frame.get(graph.types[0], np.eye(4))])
            return Instantiation(asm, 1, 1, reason=None, seconds=time.perf_counter() - t0)
        adj = graph.adjacency()
        rng = np.random.default_rng(seed)
        out = Instantiation(None)
        reasons: list[str] = []
        for attempt in range(max_tries):
            if deadline is not None and time.monotonic() > deadline:
                reasons.append("time budget spent")
                break
            out.tries += 1
            u, v = graph.edges[int(rng.integers(len(graph.edges)))]
            start = u if rng.random() < 0.5 else v
            placed, used, why = self._try(graph, adj, start, predicted, rng, out)
            if placed is None:
                reasons.append(why)
                continue
            asm = self._assembly(graph, *placed)
            problem = self._final_check(graph, asm)
            if problem is None:
                out.assembly = asm
                out.categories = used
                out.reason = None
                out.seconds = time.perf_counter() - t0
                return out
            reasons.append(problem)
        out.reason = _summarise(reasons, out.tries)
        out.seconds = time.perf_counter() - t0
        return out

    # long: one chronological backtracking search: the insertion stack, the candidates per
    # long: part and the budget are one state, undone together
    def _try(self, graph: TypedGraph, adj, start: int, predicted, rng, out: Instantiation):  # noqa: ANN001
        """One try from `start`: parts in breadth-first order, each through the edge to its BFS
        parent; when no category of an edge works, backtrack chronologically to the previous
        part and take its next candidate (at most `self.budget` insertions per try)."""
        n = len(graph.types)
        T = graph.types
        order: list[tuple[int, int]] = []  # (node, its BFS parent)
        seen = {start}
        queue = deque([start])
        while queue:
            x = queue.popleft()
            nbrs = list(adj[x])
            rng.shuffle(nbrs)
            for y in nbrs:
                if y not in seen:
                    seen.add(y)
                    queue.append(y)
                    order.append((y, x))
        frames: list[np.ndarray | None] = [None] * n
        variant: list[str | None] = [None] * n
        parts: list = [None] * n
        placed: list[int] = [start]
        first = adj[start][0]
        cands0 = self._candidates(T[start], T[first], predicted.get((min(start, first), max(start, first))),
                                  start < first, rng, None)
        variant[start] = (self.cats.variants(cands0[0][0], T[start], T[first])[0] if cands0 else "") or \
            self.default_variant[T[start]]
        # any frame of the start part will do: another of its symmetric frames turns the whole
        # shape rigidly about it
        frames[start] = self.start_frame.get(T[start], np.eye(4))
        parts[start] = self.part(T[start], frames[start], f"{T[start]}.{start}", variant[start])
        boxes: list = [None] * n
        boxes[start] = self._box(parts[start])
        used: dict[tuple[int, int], int] = {}
        parent = {y: x for y, x in order}
        pos = {y: j for j, (y, _x) in enumerate(order)}
        pos[start] = -1

        def path(a: int, b: int) -> set[int]:
            """Nodes on the spanning-tree path between a and b (the parts whose placements
            decide where b lands relative to a)."""
            up: dict[int, int] = {}
            v, d = a, 0
            while True:
                up[v] = d
                if v == start:
                    break
                v, d = parent[v], d + 1
            out_: set[int] = set()
            v = b
            while v not in up:
                out_.add(v)
                v = parent[v]
            w = a
            while w != v:
                out_.add(w)
                w = parent[w]
            return out_

        # per position of `order`: its candidate list, the index of the one in use, and the
        # parts its failures were traced to (conflict-directed backjumping)
        cand_lists: list[list | None] = [None] * len(order)
        pick = [0] * len(order)
        conflicts: list[set[int]] = [set() for _ in order]
        budget = self.budget
        why = ""
        i = 0
        while i < len(order):
            y, x = order[i]
            key = (min(x, y), max(x, y))
            if cand_lists[i] is None:
                cand_lists[i] = self._candidates(T[x], T[y], predicted.get(key), x < y, rng, variant[x])
                pick[i] = 0
                conflicts[i] = set()
                if not cand_lists[i]:
                    return None, used, f"no docking category joins {T[x]} and {T[y]} (edge {x}-{y})"
            placed_nbrs = [w for w in adj[y] if frames[w] is not None]
            ok = False
            while pick[i] < len(cand_lists[i]):
                k, A, vy = cand_lists[i][pick[i]]
                pick[i] += 1
                if budget <= 0:
                    return None, used, why or f"insertion budget spent at edge {x}-{y}"
                budget -= 1
                out.insertions += 1
                Fy = frames[x] @ A  # the child's canonical frame, as the category is defined
                bad = self._cycle_misfit(graph, y, Fy, vy, placed_nbrs, frames, variant, x)
                if bad is not None:
                    why, w = bad
                    conflicts[i] |= path(x, w)
                    continue
                new = self.part(T[y], Fy, f"{T[y]}.{y}", vy)
                box = self._box(new)
                near = self._near(box, [boxes[p] for p in placed])
                out_of_reach = set(placed_nbrs) - {placed[j] for j in near}
                if out_of_reach:
                    # a graph neighbour whose box the new part's does not even overlap: the
                    # contact is missing, no exact contact test needed (fail fast); the missing
                    # contacts alone explain the failure for backjumping
                    touched = set(placed_nbrs) - out_of_reach
                else:
                    touched = {placed[j] for j in self._touching(new, [parts[p] for p in placed], near)}
                if touched != set(placed_nbrs):
                    extra = sorted(touched - set(placed_nbrs))
                    missing = sorted(set(placed_nbrs) - touched)
                    for j in extra + missing:
                        conflicts[i] |= path(x, j)
                    why = (f"part {y} ({T[y]}) attached to {x} ({T[x]}) "
                           + (f"touches {', '.join(f'{j} ({T[j]})' for j in extra)}, which it may not" if extra
                              else f"does not reach {', '.join(f'{j} ({T[j]})' for j in missing)}: the cycle "
                                   "through these parts does not close"))
                    continue
                frames[y], parts[y], variant[y], boxes[y] = Fy, new, vy, box
                placed.append(y)
                used[key] = k if x < y else self.cats.reverse.get(k, k)
                ok = True
                break
            if ok:
                i += 1
                continue
            # back-jump to the latest part the failures were traced to (its next candidate may
            # fix them); everything placed after it is undone
            culprits = [pos[v] for v in conflicts[i] | {x} if v != y]
            target = max(culprits) if culprits else i - 1
            if target < 0:
                return None, used, why or "no placement works"
            merged = (conflicts[i] | {x}) - {order[target][0]}
            for j in range(i, target - 1, -1):
                yj, xj = order[j]
                if frames[yj] is not None and yj != start:
                    frames[yj] = parts[yj] = variant[yj] = None
                    placed.remove(yj)
                    used.pop((min(xj, yj), max(xj, yj)), None)
                if j > target:
                    cand_lists[j] = None
            conflicts[target] |= merged
            i = target
        for j, (y, x) in enumerate(order):
            k_used = cand_lists[j][pick[j] - 1][0] if cand_lists[j] else None
            p = predicted.get((min(x, y), max(x, y)))
            if p is not None and not isinstance(p, (int, np.integer)):
                p = list(p)[0] if len(p) else None
            if p is None or k_used != (p if x < y else self.cats.reverse.get(int(p), int(p))):
                out.monte_carlo += 1
        return (frames, variant), used, ""

    def _candidates(self, tx: str, ty: str, pred: int | None, forward: bool, rng,  # noqa: ANN001
                    parent_variant: str | None) -> list[tuple[int, np.ndarray, str]]:
        """(category, child placement in the parent's frame, child variant) to try for edge
        x -> y: the predicted category first (given for min -> max; turned around for a
        same-type pair seen the other way), then the pair's others in a random order weighted
        by how often they occur (Monte-Carlo insertion). Only categories whose parent geometry
        is the parent's are kept."""
        cands = [k for k in self.cats.pair_categories(tx, ty)
                 if parent_variant is None or self.cats.variants(k, tx, ty)[0] in ("", parent_variant)]
        ranked: list[int] = []
        for p in ([pred] if isinstance(pred, (int, np.integer)) else list(pred or [])):
            p = int(p) if forward else self.cats.reverse.get(int(p), int(p))
            if p in cands and p not in ranked:
                ranked.append(p)
        rest = [k for k in cands if k not in ranked]
        if rest:
            w = np.array([self.cats.categories[k].count for k in rest], dtype=np.float64)
            order = rng.choice(len(rest), size=len(rest), replace=False, p=w / w.sum())
            rest = [rest[i] for i in order]
        out = []
        for k in ranked + rest:
            vy = self.cats.variants(k, tx, ty)[1] or self.default_variant[ty]
            out.append((k, self.cats.placement(k, tx, ty), vy))
        return out

    def build(self, graph: TypedGraph, frames, variants=None):  # noqa: ANN001, ANN201
        """(assembly, None) for parts placed at `frames` (per node; e.g. a complete placement of
        the consistent decoder) when the shape passes the final check (the requested graph,
        `validate` at both tolerances), else (None, the problem)."""
        asm = self._assembly(graph, frames, variants)
        problem = self._final_check(graph, asm)
        return (None, problem) if problem is not None else (asm, None)

    def _cycle_misfit(self, graph, y, Fy, vy, placed_nbrs, frames, variant, parent):  # noqa: ANN001, ANN201
        T = graph.types
        for w in placed_nbrs:
            if w == parent:
                continue
            k, d = self.cats.classify(T[w], T[y], np.linalg.inv(frames[w]) @ Fy, variant[w] or None, vy or None)
            if k is None:
                far = "in no docking orientation" if not np.isfinite(d) else f"{d:.2f} part sizes away from any docking"
                return f"cycle edge {w}-{y} ({T[w]}-{T[y]}) does not close: placing {y} from {parent} puts it {far}", w
        return None

    def _assembly(self, graph: TypedGraph, frames, variants=None):  # noqa: ANN001, ANN202
        from grammarkit.tiling import Assembly

        def build(frames):  # noqa: ANN001, ANN202
            counts: dict[str, int] = {}
            parts = []
            for i, t in enumerate(graph.types):
                k = counts.get(t, 0)
                counts[t] = k + 1
                p = self.part(t, frames[i], f"{t}.{k}", variants[i] if variants else None)
                p.meta["node"] = i
                parts.append(p)
            return parts

        parts = build(frames)
        up, ground = self.library.up, self.library.ground
        if up is not None and ground is not None:
            # placements are relative, so the built shape may float or sink as a whole: stand
            # it on the examples' ground (a translation along up changes no contact)
            low = min(float((np.asarray(p.mesh.vertices, dtype=np.float64) @ up).min()) for p in parts)
            if abs(ground - low) > 1e-9:
                T = np.eye(4)
                T[:3, 3] = (ground - low) * up
                parts = build([T @ F for F in frames])
        return Assembly(parts, name="instantiated")

    def _final_check(self, graph: TypedGraph, asm) -> str | None:  # noqa: ANN001
        from grammarkit.tiling import shape_graph, validate

        for tol in (self.tolerance, None):
            sg = shape_graph(asm, tol)
            index = {p.id: p.meta["node"] for p in asm.parts}
            got = sorted((min(index[a], index[b]), max(index[a], index[b])) for a, b in sg.edges())
            if got != sorted(graph.edges):
                extra = sorted(set(got) - set(graph.edges))[:3]
                missing = sorted(set(graph.edges) - set(got))[:3]
                return (f"the finished shape's contacts differ from the graph (extra {extra}, missing {missing}"
                        f"{'' if tol is not None else ', at the default validate tolerance'})")
            report = validate(self.grammar, asm, tolerance=tol, graph=sg)
            if not report.ok:
                return f"the finished shape breaks the grammar: {report.violations[0].format()}"
        return None


def _summarise(reasons: list[str], tries: int) -> str:
    if not reasons:
        return "no try was made"
    common = max(set(reasons), key=reasons.count)
    return f"{tries} tr{'y' if tries == 1 else 'ies'} failed; most often: {common}"
