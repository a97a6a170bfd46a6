"""Cycle-consistent decoding of edge categories (beyond the paper).

The predictor (predictor.py) gives every edge of a graph scores over its type pair's categories
(votes of several strings: summed log-probabilities). Choosing each edge's best category
independently ignores what the categories mean: a category is a rigid placement, so around every
cycle of the graph the placements must compose to the identity, and parts that the graph does not
join must not touch. These constraints nearly always fix the categories (docs/string-vae.md,
"Measured": the few castle graphs where they do not have two valid shapes); an LSTM has to learn
this cycle reasoning from data, slowly.

`ConsistentDecoder.decode` searches for the categories with the largest summed votes among those
that *close geometrically*:

- parts are placed one at a time in an ear-decomposition order (`placement_order`: shortest
  ears first, so every cycle closes as soon as possible), each through the edge to the part
  before it on its ear (its parent) with one of the pair's categories: the parent's canonical
  frame times the category's placement (categories.py);
- every other edge to an already placed part is a cycle edge: its category is read off the
  geometry (`EdgeCategories.classify`), and a placement that is in no docking category of the
  pair is dropped (the cycle does not close);
- a placement that touches a placed part the graph does not join to it is dropped (exact
  contact test, `grammarkit.tiling.contacts`, at the examples' tolerance; results are cached by
  the rounded relative placement, which repeats a great deal since every placement is a
  composition of a few dozen categories);
- a placement farther from a placed part than the graph lets them be is dropped (`_reach`: the
  shortest path between them, each edge weighted by its type pair's longest docking step, an
  admissible bound), which stops a chain that turned the wrong way long before its ear closes;
- a beam of the best `beam` partial placements (summed votes of their decided edges; every
  partial placement after k parts has decided the same edges, so their scores compare) is kept
  after each part; if it empties, the search runs once more with a beam `widen` times wider.

Beam search (a hand-written search: the problem is a small constraint problem over rigid
placements, which no library in our dependencies states) is not complete: when the votes rank
the true category of an early edge too low it can fall out of the beam. The result says whether
a consistent labelling was found; when none was, the edges keep their voted categories and the
reason names the part and the edge where the last placements failed.

Every complete placement in the final beam is a candidate shape: `Instantiator.build` makes it
and checks it like any instantiation (the requested graph, `validate` at both tolerances), so
the search doubles as an instantiation that needs no further search (`instantiate_consistent`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .graphs import TypedGraph

__all__ = ["ConsistentDecoder", "ConsistentResult", "instantiate_consistent", "placement_order"]


@dataclass
class ConsistentResult:
    categories: dict[tuple[int, int], int]  # (u, v), u < v: category u -> v
    consistent: bool  # True: every cycle closes and no two parts the graph does not join touch
    score: float = 0.0  # summed votes of the chosen categories
    frames: list = field(default_factory=list)  # complete placements, best first: (frames, variants)
    expansions: int = 0  # placements tested
    contact_tests: int = 0  # exact contact tests run (cache misses)
    reason: str | None = None
    seconds: float = 0.0


def _shortest_ear(adj: list, placed: set[int]) -> list[int] | None:
    """The shortest path between two placed parts (or from one back to itself: a cycle) whose
    inner parts are all unplaced, as [start, inner..., end]; None if there is none. BFS from
    every placed part through unplaced ones (a cycle back to the start is two BFS branches with
    different first steps meeting); ties by the lowest start part, then BFS order."""
    best: list[int] | None = None

    def walk(x: int, prev: dict) -> list[int]:
        out = []
        while x != -1:
            out.append(x)
            x = prev[x]
        return out[::-1]  # s, ..., x

    for s in sorted(placed):
        prev = {s: -1}
        depth = {s: 0}
        hop: dict[int, int] = {}
        queue = [s]
        for c in queue:
            if best is not None and 2 * depth[c] + 1 >= len(best) - 1:
                break  # no shorter ear from s
            for w in adj[c]:
                if c == s:
                    if w not in placed and w not in prev:
                        prev[w], depth[w], hop[w] = c, 1, w
                        queue.append(w)
                    continue
                ear = None
                if w in placed and w != s:  # s ... c w: an ear to another placed part
                    ear = walk(c, prev) + [w]
                elif w not in placed and w in prev and hop[w] != hop[c]:  # s ... c w ... s
                    ear = walk(c, prev) + walk(w, prev)[::-1]
                elif w not in placed and w not in prev:
                    prev[w], depth[w], hop[w] = c, depth[c] + 1, hop[c]
                    queue.append(w)
                if ear is not None and (best is None or len(ear) < len(best)):
                    best = ear
    return best


def placement_order(graph: TypedGraph) -> list[tuple[int, int]]:
    """(part, parent) pairs, the parent placed before the part (-1 for a root): an ear
    decomposition with the shortest ears first, so that every cycle closes as soon as possible
    and a wrong category is caught within one ear. The root is the part with the most
    neighbours (lowest index on ties); then repeatedly the shortest ear (a path between placed
    parts through unplaced ones, or a cycle back to one) is placed along the path; parts on no
    cycle (trees hanging off) follow in breadth-first order. Hand-written: networkx has ear
    decompositions of no kind that put the shortest ears first."""
    n = len(graph.types)
    adj = graph.adjacency()
    out: list[tuple[int, int]] = []
    placed: set[int] = set()
    while len(placed) < n:
        root = max((x for x in range(n) if x not in placed), key=lambda x: (len(adj[x]), -x))
        out.append((root, -1))
        placed.add(root)
        while True:
            ear = _shortest_ear(adj, placed)
            if ear is None:
                break
            for a, b in zip(ear[:-2], ear[1:-1]):
                out.append((b, a))
                placed.add(b)
        # tree parts (no cycle through them) in breadth-first order from the placed ones
        queue = sorted(placed)
        for c in queue:
            for w in adj[c]:
                if w not in placed:
                    placed.add(w)
                    out.append((w, c))
                    queue.append(w)
    return out


def _relative(Fa: np.ndarray, Fb: np.ndarray) -> np.ndarray:
    """b's frame in a's, inv(Fa) @ Fb, for rigid frames (the inverse is the transpose)."""
    R = Fa[:3, :3].T
    out = np.eye(4)
    out[:3, :3] = R @ Fb[:3, :3]
    out[:3, 3] = R @ (Fb[:3, 3] - Fa[:3, 3])
    return out


@dataclass
class _State:
    score: float
    frames: np.ndarray  # (n, 4, 4); rows of unplaced parts are unused
    variants: list
    cats: dict  # (u, v), u < v -> category u -> v


class ConsistentDecoder:
    """Beam search over categories that close every cycle (see the module docstring).

    `instantiator` (instantiate.Instantiator) provides the categories, the part geometry, the
    contact tolerance and the final check."""

    def __init__(self, instantiator: Any, *, beam: int = 16, widen: int = 8):
        self.inst = instantiator
        self.cats = instantiator.cats
        self.beam = max(1, int(beam))
        self.widen = max(1, int(widen))  # when the beam empties: one more search, this many times wider
        self._touch_cache: dict[tuple, bool] = {}
        self._radius: dict[tuple[str, str], float] = {}
        self.contact_tests = 0

    # ---- geometry helpers ---------------------------------------------------------------------
    def _r(self, t: str, v: str) -> float:
        """Radius of the part's vertices around its frame origin (a bounding sphere)."""
        key = (t, v)
        if key not in self._radius:
            local, _faces = self.inst.library.variants[(t, v)]
            self._radius[key] = float(np.linalg.norm(local, axis=1).max())
        return self._radius[key]

    def _touch(self, ta: str, va: str, Fa: np.ndarray, tb: str, vb: str, Fb: np.ndarray) -> bool:
        """Do parts a and b touch (exact test at the instantiator's tolerance)? Cached by the
        rounded placement of b in a's frame."""
        rel = _relative(Fa, Fb)
        size = max(self.inst.library.sizes.get(ta, 1.0), self.inst.library.sizes.get(tb, 1.0)) or 1.0
        key = (ta, va, tb, vb, tuple(np.round(rel[:3, 3] / (1e-6 * size)).astype(np.int64).tolist()),
               tuple(np.round(rel[:3, :3].ravel() / 1e-6).astype(np.int64).tolist()))
        hit = self._touch_cache.get(key)
        if hit is None:
            self.contact_tests += 1
            a = self.inst.part(ta, Fa, "a", va)
            b = self.inst.part(tb, Fb, "b", vb)
            hit = bool(self.inst._touching(b, [a], [0]))
            self._touch_cache[key] = hit
        return hit

    def _reach(self, graph: TypedGraph) -> np.ndarray:
        """(n, n): the farthest two parts' frame origins can be apart: the shortest path
        between them in the graph, each edge weighted by the longest step (origin to origin)
        of its type pair's categories, plus a margin for the classification tolerance."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import shortest_path

        cats, T = self.cats, graph.types
        step: dict[tuple[str, str], float] = {}
        rows, cols, w = [], [], []
        for u, v in graph.edges:
            key = tuple(sorted((T[u], T[v])))
            if key not in step:
                ks = cats.pair_categories(*key)
                size = max(cats.sizes.get(key[0], 1.0), cats.sizes.get(key[1], 1.0)) or 1.0
                step[key] = (max((float(np.linalg.norm(cats.categories[k].matrix[:3, 3])) for k in ks), default=0.0)
                             + cats.position_tolerance * size + 1e-9)
            rows += [u, v]
            cols += [v, u]
            w += [step[key], step[key]]
        n = len(T)
        D = shortest_path(coo_matrix((w, (rows, cols)), shape=(n, n)).tocsr(), directed=False)
        return np.where(np.isfinite(D), D, np.inf)

    # ---- the search ---------------------------------------------------------------------------
    def decode(self, graph: TypedGraph, votes: dict[tuple[int, int], np.ndarray], *,
               deadline: float | None = None) -> ConsistentResult:
        """Categories for every edge (u, v), u < v (direction u -> v) maximising the summed
        `votes` (scores over all categories, direction u -> v; entries <= -1e8 impossible)
        among the labellings that close every cycle without collisions: a beam of `beam`
        placements, and if it empties, once more with a beam `widen` times wider."""
        res = self._search(graph, votes, self.beam, deadline)
        if not res.consistent and self.widen > 1 and res.reason != "time budget spent":
            wide = self._search(graph, votes, self.beam * self.widen, deadline)
            wide.expansions += res.expansions
            wide.contact_tests += res.contact_tests
            wide.seconds += res.seconds
            res = wide
        return res

    # long: one beam search over the parts in ear order: its placement, contact and cycle-closing
    # long: checks share the beam's state at every step; split up, that state would be passed around
    def _search(self, graph: TypedGraph, votes: dict[tuple[int, int], np.ndarray], width: int,
                deadline: float | None) -> ConsistentResult:
        t0 = time.perf_counter()
        tests0 = self.contact_tests
        cats, lib = self.cats, self.inst.library
        T = graph.types
        n = len(T)
        fallback = {e: int(np.argmax(v)) for e, v in votes.items()}
        if n == 0 or not graph.edges:
            return ConsistentResult(fallback, True, seconds=time.perf_counter() - t0)
        adj = graph.adjacency()
        order = placement_order(graph)
        assert sorted(y for y, _ in order) == list(range(n))
        adjset = [set(a) for a in adj]

        def score_of(x: int, y: int, k: int) -> float:
            """Votes for category k of the edge x -> y."""
            u, v = (x, y) if x < y else (y, x)
            kk = k if x < y else cats.reverse.get(k, k)
            s = votes.get((u, v))
            if s is None:  # no prediction for this edge: every category equally likely
                return 0.0
            return float(s[kk]) if s[kk] > -1e8 else -1e6

        reach = self._reach(graph)
        root = order[0][0]
        root_variants = sorted({v for (t, v) in lib.variants if t == T[root]}) or [lib.default[T[root]]]
        frame0 = lib.start_frame.get(T[root], np.eye(4))
        beam: list[_State] = []
        for v in root_variants:
            F = np.zeros((n, 4, 4))
            F[root] = frame0
            var: list = [None] * n
            var[root] = v
            beam.append(_State(0.0, F, var, {}))
        placed = [root]
        placed_set = {root}
        expansions = 0
        reason = None
        for y, x in order[1:]:
            if deadline is not None and time.monotonic() > deadline:
                reason = "time budget spent"
                beam = []
                break
            others = [w for w in adj[y] if w != x and w in placed_set]
            strangers = [p for p in placed if p not in adjset[y]]
            new_beam: list[_State] = []
            fails: dict[str, int] = {}
            for st in beam:
                if x < 0:  # a new component: any frame will do
                    cands = [(None, np.eye(4), lib.default[T[y]])]
                else:
                    ks = [k for k in cats.pair_categories(T[x], T[y])
                          if cats.variants(k, T[x], T[y])[0] in ("", st.variants[x])]
                    cands = [(k, cats.placement(k, T[x], T[y]), cats.variants(k, T[x], T[y])[1] or lib.default[T[y]])
                             for k in ks]
                for k, A, vy in cands:
                    expansions += 1
                    Fy = st.frames[x] @ A if x >= 0 else np.eye(4)
                    s = st.score + (score_of(x, y, k) if k is not None else 0.0)
                    new_cats = {}
                    if k is not None:
                        new_cats[(min(x, y), max(x, y))] = k if x < y else cats.reverse.get(k, k)
                    ok = True
                    for w in others:
                        kw, _d = cats.classify(T[w], T[y], _relative(st.frames[w], Fy),
                                               st.variants[w] or None, vy or None)
                        if kw is None:
                            ok = False
                            key = f"cycle edge {w}-{y} ({T[w]}-{T[y]}) does not close"
                            fails[key] = fails.get(key, 0) + 1
                            break
                        s += score_of(w, y, kw)
                        new_cats[(min(w, y), max(w, y))] = kw if w < y else cats.reverse.get(kw, kw)
                    if not ok:
                        continue
                    if len(placed) > 1:
                        # every placed part must stay within reach of y through the graph: the
                        # rest of a cycle can still close (an admissible bound)
                        P = st.frames[placed][:, :3, 3]
                        if np.any(np.linalg.norm(P - Fy[:3, 3], axis=1) > reach[y, placed]):
                            key = f"part {y} ({T[y]}) is placed out of reach of a part it must meet"
                            fails[key] = fails.get(key, 0) + 1
                            continue
                    if strangers:
                        P = st.frames[strangers][:, :3, 3]
                        radius = np.array([self._r(T[p], st.variants[p]) for p in strangers]) + self._r(T[y], vy)
                        near = np.flatnonzero(np.linalg.norm(P - Fy[:3, 3], axis=1)
                                              <= radius + 2 * self.inst.tolerance)
                        for j in near:
                            p = strangers[int(j)]
                            if self._touch(T[p], st.variants[p], st.frames[p], T[y], vy, Fy):
                                ok = False
                                key = f"part {y} ({T[y]}) touches part {p} ({T[p]}), which it may not"
                                fails[key] = fails.get(key, 0) + 1
                                break
                    if not ok:
                        continue
                    F = st.frames.copy()
                    F[y] = Fy
                    var = list(st.variants)
                    var[y] = vy
                    new_beam.append(_State(s, F, var, {**st.cats, **new_cats}))
            placed.append(y)
            placed_set.add(y)
            if not new_beam:
                common = max(fails, key=fails.get) if fails else f"no docking category joins {T[x]} and {T[y]}"
                reason = f"no consistent placement of part {y} ({T[y]}) from part {x} ({T[x]}): {common}"
                beam = []
                break
            new_beam.sort(key=lambda st: -st.score)  # stable: ties keep the earlier states' order
            beam = new_beam[:width]
        secs = time.perf_counter() - t0
        tests = self.contact_tests - tests0
        if not beam:
            return ConsistentResult(fallback, False, expansions=expansions, contact_tests=tests,
                                    reason=reason or "no consistent placement", seconds=secs)
        best = beam[0]
        return ConsistentResult(dict(best.cats), True, best.score,
                                [(list(st.frames), list(st.variants)) for st in beam],
                                expansions, tests, None, secs)


def instantiate_consistent(instantiator: Any, decoder: "ConsistentDecoder", graph: TypedGraph,
                           votes: dict[tuple[int, int], np.ndarray], *, tries: int = 8,
                           deadline: float | None = None):
    """Instantiate `graph` from its cycle-consistent decoding: the complete placements of the
    final beam, best first, are built and checked (`Instantiator.build`) until one passes (at
    most `tries`). Returns an `instantiate.Instantiation`: `insertions` counts the placements
    the search tested, `monte_carlo` the edges whose category is not their best voted one."""
    from .instantiate import Instantiation

    t0 = time.perf_counter()
    res = decoder.decode(graph, votes, deadline=deadline)
    out = Instantiation(None, insertions=res.expansions)
    out.monte_carlo = sum(int(res.categories.get(e) != int(np.argmax(v))) for e, v in votes.items())
    if not res.consistent:
        out.reason = res.reason
        out.seconds = time.perf_counter() - t0
        return out
    problems = []
    for frames, variants in res.frames[:max(1, tries)]:
        out.tries += 1
        asm, problem = instantiator.build(graph, frames, variants)
        if asm is not None:
            out.assembly = asm
            out.categories = dict(res.categories) if out.tries == 1 else _categories_of(decoder, graph, frames, variants)
            break
        problems.append(problem)
        if deadline is not None and time.monotonic() > deadline:
            break
    if out.assembly is None:
        common = max(set(problems), key=problems.count) if problems else "no placement"
        out.reason = f"{out.tries} consistent placement(s) built, none valid; most often: {common}"
    out.seconds = time.perf_counter() - t0
    return out


def _categories_of(decoder: "ConsistentDecoder", graph: TypedGraph, frames, variants) -> dict:  # noqa: ANN001
    """The category of every edge (u, v), u < v, direction u -> v, read off placed frames."""
    cats, T = decoder.cats, graph.types
    out = {}
    for u, v in graph.edges:
        k, _ = cats.classify(T[u], T[v], np.linalg.inv(frames[u]) @ frames[v], variants[u] or None, variants[v] or None)
        out[(u, v)] = k
    return out
