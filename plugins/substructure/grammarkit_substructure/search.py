"""Replaceable substructures (Liu et al. 2015, section 4): every operation, in polynomial time.

Terms (index-based graphs; `OrderedGraph` below):

- Each node has a *cyclic order* of its edges (`ordering.cyclic_orders`). A *half-edge* is a
  (node, position) pair; the half-edges with the relations `next` (the following edge around
  the node) and `twin` (the same edge seen from the other end) form the dual graph G* the
  paper walks on (its figure 8).
- Two nodes are *compatible* when they have the same type and the same degree (the same
  docking-site configuration in use).
- A *partial symmetry* f: A -> B maps a connected node set A of the donor graph D onto a node
  set B of the host graph H (D and H may be the same graph). Every a in A carries a
  correspondence sigma_a between its edge positions and those of f(a): a rotation (the
  "edge assignment" of the paper), composed with at most q adjacent transpositions over the
  whole symmetry when `q > 0` (the dummy edges). f is an isomorphism of the induced graphs
  D[A] and H[B] that respects the correspondences, and it is *closed*: across every edge
  position whose two neighbours are compatible, both neighbours are matched to each other.
  Closed symmetries are the maximal ones: no compatible neighbour pair can be added.
- The *operations* are the complements of closed symmetries: D - A and H - B fall into
  connected components, the boundary pairs (a, w) <-> (f(a), w') link components of the two
  sides, and every connected group of linked components gives one operation: cut the host's
  components S out (cut edges (f(a), w')), copy the donor's components S' in, and connect
  each copied w to f(a). Every new edge repeats the observed edge (a, w) between the same
  types, so the result is grammar-consistent by construction. Operations that differ only by
  boundary node pairs of the same type are one operation here: such a pair would be inside
  the symmetry (normalised representatives, the paper's section 4.3.1).

Enumeration (section 4.3.2 and 4.4): a symmetry is fixed by one node pair and one edge
assignment (at most k choices). From each such seed, a depth-first walk over half-edge pairs
of G* (`next` around matched nodes, `twin` across edges to compatible nodes) grows the
symmetry and stops at boundary half-edges. A hash of the half-edge pairs already walked
(every pair belongs to at most one closed symmetry) skips seeds inside a known symmetry, so
each pair is walked once: O(k n^2) pairs in all, each symmetry's operations extracted in
O(n + m). `brute_force_symmetries` is the exponential reference (all connected subgraph
pairs, networkx VF2) the tests and the benchmark compare with.

The operations are as many as O(k n^2) (0.56 n^2 on the grown castles), so the cost per
operation decides the time (`find_operations`, q = 0): each symmetry's operations are made as
the walk finds it, without a `Symmetry` object; a seed with no compatible neighbour pair
across it is the one-pair symmetry {a -> b} at once (most seeds), and its operation, when
neither node is an articulation point, is "all edges of b, everything but a" with no flood;
on one graph the seeds (a, b) with b < a are skipped (always hashed already, as inverses);
floods and the pieces of one-group cuts are computed once per (node set, starts); the
cyclic garbage collector is paused. The results, their order and their pieces' storage are
those of the direct implementation (tests/substructure/test_fingerprints.py).
"""
from __future__ import annotations

import bisect
import itertools
import operator
from dataclasses import dataclass, field
from itertools import repeat
from typing import Callable, Collection, Iterable, Sequence

import numpy as np
from grammarkit.gcpause import paused_gc

__all__ = [
    "Operation", "OrderedGraph", "Side", "Symmetry", "brute_force_operations", "brute_force_symmetries",
    "find_operations", "find_symmetries", "operations_from_symmetry", "random_ordered_graph",
]


@dataclass
class OrderedGraph:
    """A graph on nodes 0..n-1 with types and a cyclic order of each node's neighbours."""

    types: list[str]
    nbrs: list[list[int]]  # nbrs[u]: neighbours of u in cyclic order
    pos: list[dict[int, int]] = field(default_factory=list)  # pos[u][w]: position of w around u

    def __post_init__(self) -> None:
        if not self.pos:
            self.pos = [{w: i for i, w in enumerate(row)} for row in self.nbrs]

    def __len__(self) -> int:
        return len(self.types)

    def cut_nodes(self) -> set[int]:
        """Articulation points (computed once): removing any other node leaves its neighbours
        in one component, which lets single-node symmetries skip the floods."""
        cached = self.__dict__.get("_cut_nodes")
        if cached is None:
            import networkx as nx

            g = nx.Graph()
            g.add_nodes_from(range(len(self.types)))
            g.add_edges_from(self.edges)
            cached = self.__dict__["_cut_nodes"] = set(nx.articulation_points(g))
        return cached

    def outside_component(self, v: int) -> tuple[int, ...]:
        """The nodes not in v's connected component (computed once per component)."""
        labels = self.__dict__.get("_labels")
        if labels is None:
            labels = {}
            for s0 in range(len(self.types)):
                if s0 in labels:
                    continue
                labels[s0] = s0
                stack = [s0]
                while stack:
                    x = stack.pop()
                    for w in self.nbrs[x]:
                        if w not in labels:
                            labels[w] = s0
                            stack.append(w)
            self.__dict__["_labels"] = labels
            self.__dict__["_outside"] = {}
        c = labels[v]
        out = self.__dict__["_outside"].get(c)
        if out is None:
            out = self.__dict__["_outside"][c] = tuple(x for x in range(len(self.types)) if labels[x] != c)
        return out

    @property
    def edges(self) -> list[tuple[int, int]]:
        return sorted({(min(u, w), max(u, w)) for u, row in enumerate(self.nbrs) for w in row})


@dataclass(frozen=True)
class Symmetry:
    """A closed partial symmetry f: A (donor) -> B (host).

    pairs: ((a, f(a)), ...) sorted; sigma: per pair, host position of each donor position;
    violations: adjacent transpositions used (dummy edges)."""

    pairs: tuple[tuple[int, int], ...]
    sigma: tuple[tuple[int, ...], ...]
    violations: int = 0

    @property
    def key(self) -> tuple:
        return (self.pairs, self.sigma)


@dataclass(frozen=True)
class Side:
    """A node set given explicitly, or as "every node of 0..n-1 except `nodes`" (the large
    remainder of a graph, never listed during enumeration: that keeps it output-sensitive)."""

    nodes: tuple[int, ...]
    n: int
    complement: bool = False

    def members(self) -> tuple[int, ...]:
        if not self.complement:
            return self.nodes
        out = set(self.nodes)
        return tuple(v for v in range(self.n) if v not in out)

    def size(self) -> int:
        return self.n - len(self.nodes) if self.complement else len(self.nodes)

    def subset_of(self, other: "Side") -> bool:
        if not self.complement and not other.complement:
            return set(self.nodes) <= set(other.nodes)
        if not self.complement:  # explicit inside a complement: disjoint from what it leaves out
            return not (set(self.nodes) & set(other.nodes))
        if not other.complement:
            return set(self.members()) <= set(other.nodes)
        return set(other.nodes) <= set(self.nodes)


@dataclass(frozen=True)
class Operation:
    """Cut the piece S out of the host, copy the piece S' of the donor into the hole.

    pairs: the cut edges and their correspondence, ((a, w, b, w2), ...): the donor's cut edge
    (a, w) with w in S' and a outside it; the host's cut edge (b, w2) with w2 in S and b
    outside it; the copy of w is connected to b. The pairs determine the operation (S' is what
    the donor's cut edges enclose on the w side, S likewise in the host). `removed` (S) and
    `copied` (S') list the nodes. `recursive`: "grow" (S inside S': the host's piece is
    replaced by a larger copy that contains it), "shrink" (S' inside S) or "" (neither);
    only meaningful when donor and host are the same graph."""

    pairs: tuple[tuple[int, int, int, int], ...]
    removed_side: Side
    copied_side: Side
    recursive: str = ""
    symmetry_size: int = 0
    violations: int = 0

    @property
    def removed(self) -> tuple[int, ...]:
        return self.removed_side.members()

    @property
    def copied(self) -> tuple[int, ...]:
        return self.copied_side.members()

    @property
    def key(self) -> tuple:
        return self.pairs

    def to_json(self, host_ids: Sequence[str] | None = None, donor_ids: Sequence[str] | None = None) -> dict:
        h = (lambda i: host_ids[i]) if host_ids is not None else int
        d = (lambda i: donor_ids[i]) if donor_ids is not None else int
        return {
            "removed": [h(i) for i in self.removed],
            "copied": [d(i) for i in self.copied],
            "cut_removed": [[h(b), h(w2)] for _, _, b, w2 in self.pairs],
            "cut_copied": [[d(a), d(w)] for a, w, _, _ in self.pairs],
            "boundary": [{"copied": d(w), "attach_to": h(b), "replaces": h(w2), "observed_at": d(a)}
                         for a, w, b, w2 in self.pairs],
            "recursive": self.recursive or None,
            "symmetry_size": self.symmetry_size,
            "violations": self.violations,
        }


_new = object.__new__


def _operation(pairs: tuple, removed: Side, copied: Side, recursive: str, size: int,
               violations: int) -> Operation:
    """`Operation(...)`, three times faster: the frozen dataclass's __init__ goes through
    object.__setattr__ per field, about 0.6 s of the enumeration's 3.7 s at 1,000 parts (half
    a million operations). Fills the same instance dict, so the result is equal to, and
    indistinguishable from, the constructor's."""
    op = _new(Operation)
    d = op.__dict__
    d["pairs"] = pairs
    d["removed_side"] = removed
    d["copied_side"] = copied
    d["recursive"] = recursive
    d["symmetry_size"] = size
    d["violations"] = violations
    return op


# -- growth ----------------------------------------------------------------------------------
class _Conflict(Exception):
    """The closure of a seed is not a symmetry (a compatible pair is matched inconsistently)."""


def _compatible(D: OrderedGraph, H: OrderedGraph, w: int, w2: int) -> bool:
    return D.types[w] == H.types[w2] and len(D.nbrs[w]) == len(H.nbrs[w2])


def _sigma_choices(D: OrderedGraph, H: OrderedGraph, u: int, u2: int, rot: int, fixed: int | None,
                   budget: int) -> list[tuple[tuple[int, ...], int]]:
    """Correspondences of u's positions to u2's: the rotation by `rot`, and (budget allowing)
    the rotation with adjacent transpositions that make more neighbour pairs compatible
    (a dummy edge skips the misordered edge and comes back to it). `fixed`: the position we
    entered by (its partner is given)."""
    d = len(D.nbrs[u])
    base = tuple((i + rot) % d for i in range(d))
    out = [(base, 0)]
    if budget <= 0 or d < 3:
        return out

    def score(sig: tuple[int, ...]) -> int:
        return sum(_compatible(D, H, D.nbrs[u][i], H.nbrs[u2][sig[i]]) for i in range(d))

    frontier = [(base, 0)]
    for _ in range(budget):
        nxt = []
        for sig, used in frontier:
            s0 = score(sig)
            for i in range(d):
                j = (i + 1) % d
                if fixed in (i, j):
                    continue
                sw = list(sig)
                sw[i], sw[j] = sw[j], sw[i]
                sw = tuple(sw)
                if score(sw) > s0 and all(sw != s for s, _ in out):
                    out.append((sw, used + 1))
                    nxt.append((sw, used + 1))
        frontier = nxt
    return out


def _grow0(D: OrderedGraph, H: OrderedGraph, cd: list, ch: list, a: int, b: int, rot: int,
           walked: set, nh: int, kk: int) -> tuple[dict, dict, dict] | None:
    """The closed symmetry grown from the seed (a -> b, rotation rot) as (f, f^-1, rotation of
    each donor node), or None (q = 0).

    Depth-first over half-edge pairs of the dual graph: around a matched node pair the walk
    follows `next` (position i -> i + 1 on both sides); across an edge it follows `twin` into
    the neighbour pair, which must be compatible (`cd`/`ch`: class = (type, degree) per node)
    and either new on both sides or already matched to each other with the same rotation
    (else the closure is no symmetry). Every (donor node, host node, rotation) state walked
    goes into `walked` (as one int), the paper's hash: the walk from any of them gives the
    same closure, so no seed is walked twice."""
    dn, hn, dpos, hpos = D.nbrs, H.nbrs, D.pos, H.pos
    fmap = {a: b}
    inv = {b: a}
    rots = {a: rot}
    stack = [a]
    ok = True
    while stack and ok:
        u = stack.pop()
        u2, r = fmap[u], rots[u]
        nb_u, nb_u2 = dn[u], hn[u2]
        d = len(nb_u)
        for i in range(d):  # the `next` walk around u
            w = nb_u[i]
            w2 = nb_u2[(i + r) % d]
            m = fmap.get(w)
            if m is not None or w2 in inv:
                # an edge inside the match: it must map onto the corresponding edge
                if m != w2 or rots[w] != (hpos[w2][u2] - dpos[w][u]) % len(dn[w]):
                    ok = False
                    break
                continue
            if cd[w] != ch[w2]:
                continue  # a boundary half-edge pair: the walk stops here
            fmap[w] = w2  # the `twin` step
            inv[w2] = w
            rots[w] = (hpos[w2][u2] - dpos[w][u]) % len(dn[w])
            stack.append(w)
    for x, x2 in fmap.items():
        walked.add((x * nh + x2) * kk + rots[x])
    if not ok:
        return None
    return fmap, inv, rots


def _inverse(sym: Symmetry) -> Symmetry:
    """f^-1 of a symmetry of one graph: closed whenever f is."""
    items = []
    for (a, b), s in zip(sym.pairs, sym.sigma):
        inv = [0] * len(s)
        for i, j in enumerate(s):
            inv[j] = i
        items.append(((b, a), tuple(inv)))
    items.sort()
    return Symmetry(tuple(p for p, _ in items), tuple(g for _, g in items), sym.violations)


def _grow(D: OrderedGraph, H: OrderedGraph, a: int, b: int, rot: int, q: int) -> list[Symmetry]:
    """Closed symmetries grown from the seed with at most q violations (dummy edges), searched
    exhaustively: the walk branches wherever an adjacent transposition of the edge
    correspondence at a node pair makes more neighbour pairs compatible. The largest results
    are kept, and among those the ones with the fewest violations (section 4.4)."""
    results: list[Symmetry] = []

    def run(fmap: dict, inv: dict, sig: dict, stack: list, used: int) -> None:
        while stack:
            u = stack.pop()
            u2 = fmap[u]
            s_u = sig[u]
            nb_u, nb_u2 = D.nbrs[u], H.nbrs[u2]
            for i in range(len(nb_u)):
                w, w2 = nb_u[i], nb_u2[s_u[i]]
                j, j2 = D.pos[w][u], H.pos[w2][u2]
                if w in fmap or w2 in inv:
                    if fmap.get(w) != w2 or sig[w][j] != j2:
                        raise _Conflict
                    continue
                if not _compatible(D, H, w, w2):
                    continue
                rot_w = (j2 - j) % len(D.nbrs[w])
                choices = _sigma_choices(D, H, w, w2, rot_w, j, q - used)
                if len(choices) == 1:
                    fmap[w], inv[w2], sig[w] = w2, w, choices[0][0]
                    stack.append(w)
                    continue
                for s_w, extra in choices:  # one branch per correspondence
                    f2, i2, g2 = dict(fmap), dict(inv), dict(sig)
                    f2[w], i2[w2], g2[w] = w2, w, s_w
                    try:
                        # u goes back on the stack: its remaining positions are walked again
                        run(f2, i2, g2, stack + [w, u], used + extra)
                    except _Conflict:
                        pass
                return
        pairs = tuple(sorted(fmap.items()))
        results.append(Symmetry(pairs, tuple(sig[x] for x, _ in pairs), used))

    for s0, extra in _sigma_choices(D, H, a, b, rot, None, q):
        try:
            run({a: b}, {b: a}, {a: s0}, [a], extra)
        except _Conflict:
            pass
    if not results:
        return []
    best = max(len(r.pairs) for r in results)
    top = [r for r in results if len(r.pairs) == best]
    fewest = min(r.violations for r in top)
    seen, out = set(), []
    for r in top:
        if r.violations == fewest and r.key not in seen:
            seen.add(r.key)
            out.append(r)
    return out


def _node_classes(D: OrderedGraph, H: OrderedGraph) -> tuple[list[int], list[int], dict]:
    """Class ids of (type, degree), shared by both graphs: the donor's per node, the host's per
    node, and the host's nodes by class (a seed pairs only nodes of one class)."""
    classes: dict = {}
    cd = [classes.setdefault((D.types[v], len(D.nbrs[v])), len(classes)) for v in range(len(D))]
    ch = [classes.setdefault((H.types[v], len(H.nbrs[v])), len(classes)) for v in range(len(H))]
    by_class: dict = {}
    for b in range(len(H)):
        by_class.setdefault(ch[b], []).append(b)
    return cd, ch, by_class


def _walk_q0(D: OrderedGraph, H: OrderedGraph, same: bool, progress: Callable[[int], None] | None):
    """The closed symmetries (q = 0), each once, in seed order: yields (a, b, rot, grown) where
    grown is None for the one-pair symmetry {a -> b} (rotation rot) and (f, f^-1, rotations)
    otherwise. When D and H are one graph, the inverse of each symmetry is closed too; its
    states go into the hash without a walk and it is not yielded (the caller derives it).

    Most seeds give one-pair symmetries (no neighbour pair across the seed is compatible);
    they are recognised by comparing the neighbours' classes around a and b under the
    rotation (tuples precomputed per node and rotation), without a walk."""
    cd, ch, by_class = _node_classes(D, H)
    nh = len(H)
    kk = max([len(r) for r in D.nbrs] + [len(r) for r in H.nbrs] + [1])
    # classes of the neighbours of each donor node by position; of each host node by position
    # under each rotation r (host position (i + r) mod d at donor position i)
    ncd = [tuple(cd[w] for w in row) for row in D.nbrs]
    nch = []
    for row in H.nbrs:
        c = tuple(ch[w] for w in row)
        nch.append([c[r:] + c[:r] for r in range(max(len(c), 1))])
    walked: set = set()
    eq = operator.eq
    for a in range(len(D)):
        if progress is not None:
            progress(1)
        d = len(D.nbrs[a])
        na = ncd[a]
        members = by_class.get(cd[a], ())
        # With D = H, a seed (a, b, rot) with b < a is never new: at b's turn the seed
        # (b, a, -rot) was walked or skipped, and either way (a, b, rot) went into the hash as
        # a state of its inverse (or its walk failed, and so would this one).
        for b in members[bisect.bisect_left(members, a):] if same else members:
            nb_rot = nch[b]
            for rot in range(max(d, 1)):
                if same and a == b and rot == 0:
                    continue  # the identity
                if not any(map(eq, na, nb_rot[rot])):
                    # No compatible pair across the seed: the symmetry is {a -> b}. Such a
                    # seed is in no walked closure (each of their states has a compatible
                    # pair), so only its inverse can be hashed, and that is a seed of this
                    # loop only when a = b (b < a is skipped above).
                    if same and a == b:
                        if (a * nh + a) * kk + rot in walked:
                            continue
                        walked.add((a * nh + a) * kk + ((-rot) % d if d else 0))
                    yield a, b, rot, None
                    continue
                if (a * nh + b) * kk + rot in walked:
                    continue
                grown = _grow0(D, H, cd, ch, a, b, rot, walked, nh, kk)
                if grown is None:
                    continue
                if same:  # its inverse is closed too: no need to walk it again
                    fmap, _, rots = grown
                    for x, x2 in fmap.items():
                        dx = len(D.nbrs[x])
                        walked.add((x2 * nh + x) * kk + ((-rots[x]) % dx if dx else 0))
                yield a, b, rot, grown


def _symmetry_q0(D: OrderedGraph, a: int, b: int, rot: int, grown) -> Symmetry:  # noqa: ANN001
    if grown is None:
        d = len(D.nbrs[a])
        return Symmetry(((a, b),), (tuple((i + rot) % d for i in range(d)),), 0)
    fmap, _, rots = grown
    pairs = tuple(sorted(fmap.items()))
    dn = D.nbrs
    return Symmetry(pairs, tuple(tuple((i + rots[x]) % len(dn[x]) for i in range(len(dn[x])))
                                 for x, _ in pairs), 0)


def find_symmetries(D: OrderedGraph, H: OrderedGraph | None = None, *, q: int = 0,
                    progress: Callable[[int], None] | None = None) -> list[Symmetry]:
    """All closed partial symmetries from the donor D into the host H (default: D itself),
    the identity excluded. Deterministic order (by seed; with D = H each symmetry is followed
    by its inverse)."""
    same = H is None or H is D
    H = D if H is None else H
    found: dict = {}
    if q == 0:
        for a, b, rot, grown in _walk_q0(D, H, same, progress):
            sym = _symmetry_q0(D, a, b, rot, grown)
            found.setdefault(sym.key, sym)
            if same:
                inv = _inverse(sym)
                found.setdefault(inv.key, inv)
        return list(found.values())
    return _symmetries_q(D, H, same, q, progress)


def _symmetries_q(D: OrderedGraph, H: OrderedGraph, same: bool, q: int,
                  progress: Callable[[int], None] | None) -> list[Symmetry]:
    """The closed symmetries with up to q > 0 violations: every seed is grown (`_grow`
    branches, so the hash of walked states does not apply), duplicates dropped by key."""
    found: dict = {}
    cd, ch, by_class = _node_classes(D, H)
    for a in range(len(D)):
        if progress is not None:
            progress(1)
        d = len(D.nbrs[a])
        for b in by_class.get(cd[a], ()):
            for rot in range(max(d, 1)):
                if same and a == b and rot == 0:
                    continue  # the identity
                for sym in _grow(D, H, a, b, rot, q):
                    if same and all(x == y for x, y in sym.pairs) and all(
                            s == tuple(range(len(s))) for s in sym.sigma):
                        continue
                    found.setdefault(sym.key, sym)
    return list(found.values())


# -- operations ------------------------------------------------------------------------------
def _flood_groups(nbrs: Sequence[Sequence[int]], inside: set[int], starts: Sequence[int]):
    """Which `starts` lie in one component of the graph without `inside`, output-sensitively.

    Breadth-first floods from every start run interleaved (one node per flood per round);
    floods that meet merge. A flood whose queue empties has found its whole component (listed).
    Once at most one flood is still running, its component is everything else (not listed):
    so the cost is about the size of the small components, not of the graph.
    Returns (group of each start, {group: nodes or None for the unlisted remainder}); groups
    are numbered by flood (the first start's flood is 0).

    Floods are indices into lists, and one list `owner` (flood per node, -1 free, -2 inside)
    serves the membership tests: this loop runs for every distinct cut, so it is kept tight."""
    first: dict[int, int] = {}
    for s0 in starts:
        if s0 not in first:
            first[s0] = len(first)
    k = len(first)
    owner = [-1] * len(nbrs)
    for x in inside:
        owner[x] = -2
    parent = list(range(k))
    queues = [[s0] for s0 in first]
    members = [[s0] for s0 in first]
    heads = [0] * k
    for s0, g in first.items():
        owner[s0] = g

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    active = list(range(k))
    while len(active) > 1:
        nxt = []
        merged = False
        for g in active:
            if parent[g] != g:
                continue  # merged into another flood this round
            q = queues[g]
            h = heads[g]
            if h >= len(q):
                continue  # finished: its component is complete
            heads[g] = h + 1
            for w in nbrs[q[h]]:
                o = owner[w]
                if o == g or o == -2:
                    continue
                if o == -1:
                    owner[w] = g
                    q.append(w)
                    members[g].append(w)
                    continue
                r = find(o)
                if r != g:  # two floods meet: one component
                    parent[r] = g
                    merged = True
                    q.extend(queues[r][heads[r]:])
                    mr = members[r]
                    members[g].extend(mr)
                    for x in mr:
                        owner[x] = g
            if heads[g] < len(q):
                nxt.append(g)
        active = list(dict.fromkeys(find(g) for g in nxt)) if merged else nxt
    roots = {find(g) for g in range(k)}
    result = {r: (None if r in active else tuple(sorted(members[r]))) for r in roots}
    return {s0: find(g) for s0, g in first.items()}, result


def operations_from_symmetry(D: OrderedGraph, H: OrderedGraph, sym: Symmetry,
                             same: bool) -> list[Operation]:
    """The operations a closed symmetry defines: one per linked group of unmatched components
    (found by `_flood_groups`, so a huge remainder is never listed)."""
    pieces = _Pieces(D, H, same)
    rows = [[H.nbrs[b][j] for j in s] for (_, b), s in zip(sym.pairs, sym.sigma)]
    return [Operation(pairs, removed, copied, rec, len(sym.pairs), sym.violations)
            for pairs, removed, copied, rec, _ in pieces.operations(sym.pairs, rows)]


def _size(side: Side) -> int:
    return side.n - len(side.nodes) if side.complement else len(side.nodes)


class _Pieces:
    """Extracts the operations of symmetries of D into H (`operations`), with the caches that
    make it output-sensitive: the floods of one (matched node set, starts) are computed once
    (many symmetries share their donor or host node set), and the pieces of one-node
    symmetries of nodes that are no articulation point are "everything else", one `Side`
    per node."""

    def __init__(self, D: OrderedGraph, H: OrderedGraph, same: bool) -> None:
        self.D, self.H, self.same = D, H, same
        self.cut_d, self.cut_h = D.cut_nodes(), H.cut_nodes()
        self.floods_d: dict = {}
        self.floods_h: dict = self.floods_d if same else {}
        self.rest_d: dict = {}
        self.rest_h: dict = self.rest_d if same else {}
        self.connected_d = not len(D) or not D.outside_component(0)
        self.connected_h = not len(H) or not H.outside_component(0)

    @staticmethod
    def rest(G: OrderedGraph, v: int, cache: dict) -> Side:
        """Everything but v (and other connected components): the piece beside a one-node
        symmetry whose node is no articulation point."""
        side = cache.get(v)
        if side is None:
            other = G.outside_component(v)
            nodes = (v,) if not other else tuple(sorted({v, *other}))
            side = cache[v] = Side(nodes, len(G), True)
        return side

    @staticmethod
    def _flood(G: OrderedGraph, inside: set, starts: list, cache: dict) -> list:
        """[group of each start, components, the piece of all of them (filled by the caller)]:
        `_flood_groups` once per (inside, starts)."""
        key = (frozenset(inside), tuple(starts))
        out = cache.get(key)
        if out is None:
            out = cache[key] = [*_flood_groups(G.nbrs, inside, starts), None]
        return out

    def operations(self, pairs: Sequence[tuple[int, int]], rows: Sequence[Sequence[int]],
                   A: Collection[int] | None = None, B: Collection[int] | None = None) -> list[tuple]:
        """(cut pairs, removed Side, copied Side, recursive, size of both pieces) of every
        operation of the closed symmetry with the (a, f(a)) `pairs` (sorted by a); rows[k]: the
        host neighbours of f(a) at a's edge positions (the correspondence sigma applied).
        A, B: the matched nodes of each side, when the caller has them (the walk's dicts)."""
        D, H = self.D, self.H
        dn = D.nbrs
        if len(pairs) == 1:
            a, b = pairs[0]
            bpairs = [(a, w, b, w2) for w, w2 in zip(dn[a], rows[0])]
            if not bpairs:
                return []
            if a not in self.cut_d and b not in self.cut_h:
                # one node that is no articulation point on either side: everything else is
                # one component on each side, so there is exactly one operation (no flood)
                bpairs.sort()
                return self.finish(tuple(bpairs), self.rest(H, b, self.rest_h), self.rest(D, a, self.rest_d))
            A, B = {a}, {b}
        else:
            if A is None or B is None:
                A = {x for x, _ in pairs}
                B = {y for _, y in pairs}
            bpairs = [(a, w, b, w2) for (a, b), row in zip(pairs, rows)
                      for w, w2 in zip(dn[a], row) if w not in A]
            if not bpairs:
                return []
        flood_d = self._flood(D, A, [p[1] for p in bpairs], self.floods_d)
        flood_h = self._flood(H, B, [p[3] for p in bpairs], self.floods_h)
        gd, comps_d = flood_d[0], flood_d[1]
        gh, comps_h = flood_h[0], flood_h[1]
        other_d = () if self.connected_d else D.outside_component(pairs[0][0])
        other_h = () if self.connected_h else H.outside_component(pairs[0][1])
        if len(comps_d) == 1 and len(comps_h) == 1:  # one group: one operation
            # its pieces depend on the flood only (the node set and the graph): made once
            if flood_d[2] is None:
                flood_d[2] = _side(comps_d, comps_d.keys(), A, len(D), other_d)
            if flood_h[2] is None:
                flood_h[2] = _side(comps_h, comps_h.keys(), B, len(H), other_h)
            bpairs.sort()
            return self.finish(tuple(bpairs), flood_h[2], flood_d[2])
        # union-find over the components of both sides (donor: group id, host: id + offset)
        off = len(D) + 1
        parent: dict = {}

        def find(x):  # noqa: ANN001, ANN202
            while parent.setdefault(x, x) != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for _, w, _, w2 in bpairs:
            ra, rb = find(gd[w]), find(gh[w2] + off)
            if ra != rb:
                parent[ra] = rb
        groups: dict = {}
        for p in bpairs:
            groups.setdefault(find(gd[p[1]]), []).append(p)
        out = []
        for _, gp in sorted(groups.items(), key=lambda kv: min(kv[1])):
            copied = _side(comps_d, {gd[p[1]] for p in gp}, A, len(D), other_d)
            removed = _side(comps_h, {gh[p[3]] for p in gp}, B, len(H), other_h)
            gp.sort()
            out.extend(self.finish(tuple(gp), removed, copied))
        return out

    def finish(self, pairs: tuple, removed: Side, copied: Side) -> list[tuple]:
        rec = ""
        rs, cs = _size(removed), _size(copied)
        if self.same:
            if copied == removed and all(w == w2 for _, w, _, w2 in pairs):
                return []  # replaces a piece by itself, attached where it was: no change
            if rs < cs and removed.subset_of(copied):
                rec = "grow"
            elif cs < rs and copied.subset_of(removed):
                rec = "shrink"
        return [(pairs, removed, copied, rec, rs + cs)]


def _side(comps: dict, chosen, excluded_base: set, n: int, other: tuple) -> Side:  # noqa: ANN001
    """The piece made of the `chosen` components (`_flood_groups`' result): listed, or, when it
    holds the unlisted remainder, as the complement of everything else."""
    if any(comps[c] is None for c in chosen):  # the unlisted remainder is in this piece
        out = set(excluded_base)
        out.update(other)  # other connected components of the graph are not part of it
        for c, nodes in comps.items():
            if c not in chosen and nodes is not None:
                out.update(nodes)
        return Side(tuple(sorted(out)), n, True)
    if len(chosen) == 1:
        return Side(comps[next(iter(chosen))], n)
    return Side(tuple(sorted(v for c in chosen for v in comps[c])), n)


_REVERSED = {"grow": "shrink", "shrink": "grow", "": ""}


class _Kept:
    """The operations found so far, one per key (cut pairs): the one of the largest symmetry
    with the fewest violations, the first found among equals. With D = H, every symmetry's
    inverse has the same operations with the sides exchanged (`add`)."""

    def __init__(self, same: bool) -> None:
        self.same = same
        self.ops: dict = {}  # cut pairs -> (size of both pieces, Operation)

    def keep(self, pairs: tuple, removed: Side, copied: Side, rec: str, total: int, size: int,
             violations: int) -> None:
        old = self.ops.get(pairs)
        if old is None or (violations, -size) < (old[1].violations, -old[1].symmetry_size):
            self.ops[pairs] = (total, _operation(pairs, removed, copied, rec, size, violations))

    def add(self, found: list, size: int, violations: int) -> None:
        keep = self.keep
        for pairs, removed, copied, rec, total in found:
            keep(pairs, removed, copied, rec, total, size, violations)
        if self.same:
            for pairs, removed, copied, rec, total in found:
                keep(tuple(sorted([(b, w2, a, w) for a, w, b, w2 in pairs])), copied, removed,
                     _REVERSED[rec], total, size, violations)

    def sorted(self) -> list[Operation]:
        """Smallest first: by the sizes of both pieces, then by the cut pairs. (The first cut
        pair is spelled out in the key: most keys tie on the size, and comparing its ints
        directly is about three times faster than comparing the nested tuples.)"""
        order = sorted(self.ops.items(), key=lambda kv: (kv[1][0], *kv[0][0], kv[0]))
        return [op for _, (_, op) in order]


def find_operations(D: OrderedGraph, H: OrderedGraph | None = None, *, q: int = 0,
                    progress: Callable[[int], None] | None = None) -> list[Operation]:
    """Every normalised operation that copies a piece of D into a hole cut in H (default D).
    Sorted by the sizes of both pieces, then by the cut pairs."""
    same = H is None or H is D
    H = D if H is None else H
    # The enumeration allocates millions of small tuples (hash states, cut pairs) and no
    # reference cycles; the cyclic garbage collector would traverse the growing heap again and
    # again (it doubles the time at 1,000 parts: 7.8 s instead of 3.9 s), so it is paused
    # meanwhile and restored as the caller had it.
    with paused_gc():
        kept = _Kept(same)
        pieces = _Pieces(D, H, same)
        if q == 0:
            _operations_q0(D, H, same, progress, pieces, kept)
        else:
            done: set = set()
            for sym in _symmetries_q(D, H, same, q, progress):
                if sym.key in done:
                    continue
                rows = [[H.nbrs[b][j] for j in s] for (_, b), s in zip(sym.pairs, sym.sigma)]
                kept.add(pieces.operations(sym.pairs, rows), len(sym.pairs), sym.violations)
                if same:
                    done.add(_inverse(sym).key)
        return kept.sorted()


def _operations_q0(D: OrderedGraph, H: OrderedGraph, same: bool, progress: Callable[[int], None] | None,
                   pieces: _Pieces, kept: _Kept) -> None:
    """The operations of every closed symmetry (q = 0) into `kept`, each symmetry as it is
    found. One-pair symmetries of nodes that are no articulation point (most of them) take a
    short path: their one operation cuts all edges of b and copies everything but a."""
    hn, dn = H.nbrs, D.nbrs
    cut_d, cut_h = pieces.cut_d, pieces.cut_h
    rest, rest_d, rest_h = pieces.rest, pieces.rest_d, pieces.rest_h
    finish, add = pieces.finish, kept.add
    rotated: dict = {}  # (b, r): host neighbours of b at the donor's positions under rotation r

    def row_of(b: int, r: int) -> list:
        row = rotated.get((b, r))
        if row is None:
            nb = hn[b]
            row = rotated[(b, r)] = nb[r:] + nb[:r]
        return row

    ops = kept.ops
    nd, nh = len(D), len(H)
    for a, b, rot, grown in _walk_q0(D, H, same, progress):
        if grown is None:
            row = rotated.get((b, rot))
            if row is None:
                row = row_of(b, rot)
            if a in cut_d or b in cut_h or not row:
                add(pieces.operations(((a, b),), (row,)), 1, 0)
                continue
            copied = rest_d.get(a) or rest(D, a, rest_d)
            removed = rest_h.get(b) or rest(H, b, rest_h)
            nb_a = dn[a]
            pairs = tuple(sorted(zip(repeat(a), nb_a, repeat(b), row)))
            rs, cs = nh - len(removed.nodes), nd - len(copied.nodes)
            if same and (a == b or rs != cs):  # a possible no-op, or a recursive rule
                found = finish(pairs, removed, copied)
                if not found:
                    continue
                rec = found[0][3]
            else:
                rec = ""
            # a one-pair symmetry never displaces an operation found before: the first of the
            # largest symmetries is kept (`_Kept.keep`)
            if pairs not in ops:
                ops[pairs] = (rs + cs, _operation(pairs, removed, copied, rec, 1, 0))
            if same:
                pairs = tuple(sorted(zip(repeat(b), row, repeat(a), nb_a)))
                if pairs not in ops:
                    ops[pairs] = (rs + cs, _operation(pairs, copied, removed, _REVERSED[rec], 1, 0))
            continue
        fmap, inv, rots = grown
        pairs = sorted(fmap.items())
        add(pieces.operations(pairs, [row_of(x2, rots[x]) for x, x2 in pairs], fmap, inv), len(pairs), 0)


# -- brute force (reference) -----------------------------------------------------------------
def _connected_subsets(nbrs: Sequence[Sequence[int]], limit: int | None = None) -> Iterable[frozenset]:
    """Every connected node set (each once), by extension from its smallest node."""
    n = len(nbrs)
    seen: set = set()
    for s in range(n):
        stack = [frozenset([s])]
        while stack:
            cur = stack.pop()
            if cur in seen:
                continue
            seen.add(cur)
            yield cur
            if limit is not None and len(cur) >= limit:
                continue
            for v in cur:
                for w in nbrs[v]:
                    if w > s and w not in cur:
                        stack.append(cur | {w})


def brute_force_symmetries(D: OrderedGraph, H: OrderedGraph | None = None, *,
                           max_subsets: int = 2_000_000) -> list[Symmetry]:
    """The closed symmetries by exhaustive search: every connected node set A of D, every
    induced subgraph of H isomorphic to D[A] with compatible nodes (networkx VF2), kept when
    the correspondence of edge positions is one rotation per node and the map is closed.
    Exponential: for small graphs (tests, benchmark baseline)."""
    import networkx as nx
    from networkx.algorithms import isomorphism as iso

    same = H is None or H is D
    H = D if H is None else H
    gh = nx.Graph()
    for v in range(len(H)):
        gh.add_node(v, c=(H.types[v], len(H.nbrs[v])))
    gh.add_edges_from(H.edges)
    gd = nx.Graph()
    for v in range(len(D)):
        gd.add_node(v, c=(D.types[v], len(D.nbrs[v])))
    gd.add_edges_from(D.edges)
    found: dict = {}
    count = 0
    for A in _connected_subsets(D.nbrs):
        count += 1
        if count > max_subsets:
            raise RuntimeError("brute force: too many connected subsets")
        sub = gd.subgraph(A)
        gm = iso.GraphMatcher(gh, sub, node_match=lambda x, y: x["c"] == y["c"])
        for m in gm.subgraph_isomorphisms_iter():  # host node -> donor node, induced
            f = {a: b for b, a in m.items()}
            sig = {}
            ok = True
            for a, b in f.items():
                d = len(D.nbrs[a])
                rots = None
                for i, w in enumerate(D.nbrs[a]):
                    if w in f:
                        r = (H.pos[b][f[w]] - i) % d
                        if rots is None:
                            rots = r
                        elif rots != r:
                            ok = False
                            break
                if not ok:
                    break
                if rots is None:  # a single node: every rotation is a separate symmetry
                    sig[a] = None
                else:
                    sig[a] = tuple((i + rots) % d for i in range(d))
            if not ok:
                continue
            free = [a for a in f if sig[a] is None]
            rot_sets = [range(max(len(D.nbrs[a]), 1)) for a in free]
            for rots in itertools.product(*rot_sets):
                s2 = dict(sig)
                for a, r in zip(free, rots):
                    d = len(D.nbrs[a])
                    s2[a] = tuple((i + r) % d for i in range(d)) if d else ()
                if not _closed(D, H, f, s2):
                    continue
                pairs = tuple(sorted(f.items()))
                sym = Symmetry(pairs, tuple(s2[a] for a, _ in pairs))
                if same and all(x == y for x, y in pairs) and all(
                        s == tuple(range(len(s))) for s in sym.sigma):
                    continue
                found.setdefault(sym.key, sym)
    return list(found.values())


def _closed(D: OrderedGraph, H: OrderedGraph, f: dict, sig: dict) -> bool:
    inv = {b: a for a, b in f.items()}
    for a, b in f.items():
        for i, w in enumerate(D.nbrs[a]):
            w2 = H.nbrs[b][sig[a][i]]
            if w not in f and w2 not in inv and not _compatible(D, H, w, w2):
                continue
            if f.get(w) != w2 or inv.get(w2) != w:
                return False
            if sig[w][D.pos[w][a]] != H.pos[w2][b]:
                return False
    return True


def brute_force_operations(D: OrderedGraph, H: OrderedGraph | None = None) -> list[Operation]:
    same = H is None or H is D
    H = D if H is None else H
    ops: dict = {}
    for sym in brute_force_symmetries(D, H):
        for op in operations_from_symmetry(D, H, sym, same):
            ops.setdefault(op.key, op)
    return sorted(ops.values(), key=lambda o: (o.removed_side.size() + o.copied_side.size(), o.key))


def random_ordered_graph(n: int, n_types: int, rng: np.random.Generator, extra_edges: int = 3) -> OrderedGraph:
    """A random connected graph (a random tree plus extra edges) with random cyclic orders."""
    edges = {(int(rng.integers(v)), v) for v in range(1, n)}
    for _ in range(extra_edges):
        a, b = sorted(rng.choice(n, 2, replace=False).tolist())
        edges.add((a, b))
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for a, b in sorted(edges):
        nbrs[a].append(b)
        nbrs[b].append(a)
    for row in nbrs:
        rng.shuffle(row)
    types = [chr(65 + int(t)) for t in rng.integers(0, n_types, n)]
    return OrderedGraph(types, [list(map(int, r)) for r in nbrs])
