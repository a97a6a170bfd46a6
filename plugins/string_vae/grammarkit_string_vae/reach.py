"""How many parts a chain needs to come back to a part: a lower bound for placed decoding.

Placed decoding (placed.py) must keep every open ring closable: the ring's owner has to be
reachable by a chain of parts hanging from a part that can still grow, within the tokens the
length budget leaves. A straight-line bound (distance over the longest docking step) is loose
on a castle: a wall run between two towers is three parts long, and towers turn by right angles,
so the chain walks a grid. `ReachTable` is exact up to collisions: a breadth-first search over
chains of edge-category placements (every category of every type pair, composed from an
identity frame; geometry variants and collisions ignored, so it never says more than the
truth) gives, for a part of type `tc` and a part of type `to` at a position relative to it, the
fewest new parts after `tc` whose last one docks to `to` there by some category.

Positions are kept on a grid of cells (a fraction of the shortest docking step) and every entry
is spread to the 26 neighbouring cells, so a position within one cell of a reachable one gets
at most its count (rounding never makes the bound larger than the truth). Beyond `depth` parts
the table answers `depth + 1`, again a lower bound.
"""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["ReachTable"]


class ReachTable:
    def __init__(self, cats, types: list[str], *, depth: int = 36, max_states: int = 60000):  # noqa: ANN001
        self.depth = int(depth)
        self.types = list(types)
        steps = []
        self.moves: dict[str, list[tuple[str, np.ndarray]]] = {t: [] for t in self.types}
        for ta in self.types:
            for tb in self.types:
                for k in cats.pair_categories(ta, tb):
                    A = np.asarray(cats.placement(k, ta, tb), dtype=float)
                    self.moves[ta].append((tb, A))
                    steps.append(float(np.linalg.norm(A[:3, 3])))
        positive = [s for s in steps if s > 1e-9]
        self.cell = 0.2 * (min(positive) if positive else 1.0)
        self.table: dict[tuple[str, str], dict[int, int]] = {}
        for tc in self.types:
            self._search(tc, max_states)

    def _search(self, tc: str, max_states: int) -> None:
        """Breadth-first over chains hanging from a type-`tc` part at the identity frame, one
        layer of poses per type at a time (numpy); then every reachable docking position of
        every type, with its fewest parts, spread to the neighbouring cells."""
        names = self.types
        layer = {tc: np.eye(4)[None]}
        seen: dict[str, np.ndarray] = {}
        found_t, found_p, found_d = [], [], []
        d = 0
        for d in range(self.depth + 1):
            for tx, P in layer.items():  # parts d parts after c: what they can dock to
                for to, A in self.moves[tx]:
                    found_t.append(np.full(len(P), names.index(to)))
                    found_p.append((P @ A)[:, :3, 3])
                    found_d.append(np.full(len(P), d))
            if d == self.depth or sum(len(v) for v in seen.values()) > max_states:
                break
            nxt: dict[str, list] = {}
            for tx, P in layer.items():
                for ty, A in self.moves[tx]:
                    nxt.setdefault(ty, []).append(P @ A)
            layer = {}
            for ty, parts in nxt.items():
                Q = np.concatenate(parts)
                keys = np.rint(np.concatenate([Q[:, :3, 3] / (0.5 * self.cell),
                                               Q[:, :3, :3].reshape(len(Q), 9) * 100], axis=1)).astype(np.int64)
                h = (keys * _MIX).sum(axis=1) + names.index(ty)  # one int64 per pose (wrapping)
                h, first = np.unique(h, return_index=True)
                new = ~np.isin(h, seen.get(ty, _EMPTY))
                seen[ty] = np.concatenate([seen.get(ty, _EMPTY), h[new]])
                fresh = first[new]
                if len(fresh):
                    layer[ty] = Q[np.sort(fresh)]
            if not layer:
                break
        if d < self.depth and not layer:
            self.depth = d  # every chain ends: nothing beyond is reachable at all
        T = np.concatenate(found_t)
        C = np.floor(np.concatenate(found_p) / self.cell).astype(np.int64)
        D = np.concatenate(found_d)
        offsets = np.array(list(itertools.product((-1, 0, 1), repeat=3)), dtype=np.int64)
        rows = np.concatenate([T[:, None], C], axis=1)
        rows, inverse = np.unique(rows, axis=0, return_inverse=True)
        best = np.full(len(rows), np.iinfo(np.int64).max)
        np.minimum.at(best, inverse.ravel(), D)
        spread = (rows[:, None, :] + np.concatenate([np.zeros((27, 1), np.int64), offsets], axis=1)[None]).reshape(-1, 4)
        sd = np.repeat(best, 27)
        order = np.argsort(sd, kind="stable")
        spread, sd = spread[order], sd[order]
        spread, first = np.unique(spread, axis=0, return_index=True)
        packed = _pack(spread[:, 1:])
        dd = sd[first]
        for ti, to in enumerate(names):
            m = spread[:, 0] == ti
            self.table[(tc, to)] = dict(zip(packed[m].tolist(), dd[m].tolist()))

    def parts_needed(self, tc: str, Fc: np.ndarray, to: str, Fo: np.ndarray) -> int:
        """A lower bound on the parts to write after a type-`tc` part at frame `Fc` before one
        of them can dock to the type-`to` part at frame `Fo` (0: `tc` itself can)."""
        # frames are rigid (products of the categories' rigid placements), so the inverse
        # rotation is the transpose: d @ R = R^T d, ~30x cheaper than a solve per call (the
        # placed decoder asks this ~30,000 times per latent point)
        rel = (Fo[:3, 3] - Fc[:3, 3]) @ Fc[:3, :3]
        c = np.floor(rel / self.cell).astype(np.int64)
        key = ((int(c[0]) + _BIAS) << 42) | ((int(c[1]) + _BIAS) << 21) | (int(c[2]) + _BIAS)
        return self.table.get((tc, to), {}).get(key, self.depth + 1)


_BIAS = 1 << 20
_EMPTY = np.zeros(0, dtype=np.int64)
_MIX = np.random.default_rng(20261202).integers(1, 1 << 62, size=12, dtype=np.int64) | 1


def _pack(cells: np.ndarray) -> np.ndarray:
    """(n, 3) integer cells -> one int64 each (21 bits per axis)."""
    c = cells.astype(np.int64) + _BIAS
    return (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]
