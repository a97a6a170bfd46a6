"""The operations of closed symmetries (Liu et al. 2015, section 4.3): each symmetry's
complement as cut-and-copy operations, found as the walk of `search` finds the symmetry
(`find_operations`, q = 0), with floods and pieces shared across symmetries. The terms are
those of `grammarkit_substructure.search`."""
from __future__ import annotations

from itertools import repeat
from typing import Callable, Collection, Sequence

from grammarkit.gcpause import paused_gc

from .search import (
    Operation, OrderedGraph, Side, Symmetry, _flood_groups, _inverse, _operation, _symmetries_q, _walk_q0,
)

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
