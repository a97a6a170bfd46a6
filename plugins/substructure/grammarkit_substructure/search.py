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
import operator
from dataclasses import dataclass, field
from typing import Callable, Sequence


# the operations live in .operations, the exponential reference in .brute_force
__all__ = ["Operation", "OrderedGraph", "Side", "Symmetry", "find_symmetries"]


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
