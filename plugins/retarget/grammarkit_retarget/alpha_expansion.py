"""Multi-label energy minimisation by alpha-expansion (Boykov, Veksler, Zabih 2001) over scipy's
max-flow.

    E(L) = sum_p D_p(L_p) + sum_{(p,q) in edges} V_pq(L_p, L_q)

D may be infinite (forbidden labels). V_pq is position dependent (the retargeting seam cost
depends on where the seam is), given as a vectorised function, and must be a metric in the
labels (V(a, a) = 0, triangle inequality) for the expansion move to be a graph cut; infinite
values are allowed and become uncuttable edges. Each expansion move is one s-t minimum cut
(Kolmogorov and Zabih's construction), solved by `scipy.sparse.csgraph.maximum_flow` with
Dinic's method (BSD licence).

Why by hand: no Python wrapper of a multi-label graph-cut library takes a position-dependent
pairwise term, and the ones that exist (PyMaxflow: GPL-3; gco: research-only) may not be
dependencies of grammarkit (NOTES.md, "Retargeting anchors").

Costs are turned into integers (scipy's max-flow wants int32 capacities) with a scale chosen
so that the finite energy of any labelling stays below 2**29; infinite costs become edges of
capacity 2**30, which a finite cut never crosses, so no sum can overflow int32. Because of
the rounding a move is accepted only when it lowers the exact (float) energy.

`icm` (iterated conditional modes) is the naive baseline the benchmark compares against.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, maximum_flow

__all__ = ["LabelProblem", "Solution", "alpha_expansion", "icm"]

FINITE_LIMIT = 2 ** 29
INFINITE_CAPACITY = 2 ** 30

Pairwise = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


@dataclass
class LabelProblem:
    """unary: (N, M) float, np.inf for a forbidden label; edges: (E, 2) node pairs;
    pairwise(edge_index, label_at_p, label_at_q) -> (len,) costs (np.inf allowed);
    max_pairwise: an upper bound of the finite pairwise costs (sets the integer scale)."""

    unary: np.ndarray
    edges: np.ndarray
    pairwise: Pairwise
    max_pairwise: float

    @property
    def n_nodes(self) -> int:
        return int(self.unary.shape[0])

    @property
    def n_labels(self) -> int:
        return int(self.unary.shape[1])

    def energy(self, labels: np.ndarray) -> float:
        labels = np.asarray(labels)
        u = self.unary[np.arange(self.n_nodes), labels].sum()
        if len(self.edges) == 0:
            return float(u)
        e = np.arange(len(self.edges))
        v = self.pairwise(e, labels[self.edges[:, 0]], labels[self.edges[:, 1]]).sum()
        return float(u + v)


@dataclass
class Solution:
    labels: np.ndarray
    energy: float
    initial_energy: float
    cycles: int = 0
    moves: int = 0  # expansion moves attempted
    accepted: int = 0
    seconds: float = 0.0
    flow_seconds: float = 0.0  # inside scipy's max-flow
    history: list[float] = field(default_factory=list)  # energy after each cycle
    truncated: int = 0  # pairwise terms made regular by truncation (rounding noise only)

    def stats(self) -> dict:
        return {"energy": self.energy, "initial_energy": self.initial_energy,
                "cycles": self.cycles, "moves": self.moves, "accepted": self.accepted,
                "seconds": round(self.seconds, 4), "flow_seconds": round(self.flow_seconds, 4)}


def _scale(problem: LabelProblem) -> float:
    finite_unary = problem.unary[np.isfinite(problem.unary)]
    max_unary = float(np.abs(finite_unary).max()) if finite_unary.size else 0.0
    bound = len(problem.edges) * max(problem.max_pairwise, 0.0) + problem.n_nodes * max_unary
    return float(FINITE_LIMIT / max(bound, 1e-12))


# long: one alpha-expansion move is one graph (unary edges, the pairwise table's four cases, the
# source/sink terminals) built in vectorised steps that share the same index arrays; split, each
# piece would take and return half a dozen of them
def _expansion_move(problem: LabelProblem, labels: np.ndarray, alpha: int, scale: float,
                    timing: list[float]) -> tuple[np.ndarray | None, int]:
    """The labelling after the best alpha-expansion of `labels` (None if nothing can move)."""
    n = problem.n_nodes
    unary_alpha = problem.unary[:, alpha]
    free = np.isfinite(unary_alpha) & (labels != alpha)
    if not free.any():
        return None, 0
    node_of = np.full(n, -1, dtype=np.int64)
    free_nodes = np.flatnonzero(free)
    node_of[free_nodes] = np.arange(len(free_nodes))
    nf = len(free_nodes)
    c0 = problem.unary[free_nodes, labels[free_nodes]].astype(np.float64)  # keep
    c1 = unary_alpha[free_nodes].astype(np.float64)  # switch to alpha
    rows, cols, caps = [], [], []

    p, q = problem.edges[:, 0], problem.edges[:, 1]
    fp, fq = free[p], free[q]
    lp, lq = labels[p], labels[q]
    eidx = np.arange(len(p))
    a_vec = np.full(len(p), alpha, dtype=labels.dtype)

    # edges with one free end: the fixed end keeps its label; fold into the free node's costs
    for free_side, sel in ((0, fp & ~fq), (1, fq & ~fp)):
        if not sel.any():
            continue
        e = eidx[sel]
        if free_side == 0:
            keep = problem.pairwise(e, lp[sel], lq[sel])
            switch = problem.pairwise(e, a_vec[sel], lq[sel])
            node = node_of[p[sel]]
        else:
            keep = problem.pairwise(e, lp[sel], lq[sel])
            switch = problem.pairwise(e, lp[sel], a_vec[sel])
            node = node_of[q[sel]]
        np.add.at(c0, node, keep)
        np.add.at(c1, node, switch)

    truncated = 0
    both = fp & fq
    if both.any():
        e = eidx[both]
        A = problem.pairwise(e, lp[both], lq[both])  # finite: the current labelling is
        B = problem.pairwise(e, lp[both], a_vec[both])
        C = problem.pairwise(e, a_vec[both], lq[both])
        D = problem.pairwise(e, a_vec[both], a_vec[both])
        P, Q = node_of[p[both]], node_of[q[both]]
        binf, cinf = ~np.isfinite(B), ~np.isfinite(C)
        # both finite: E = A + (C-A) xp + (D-C) xq + (B+C-A-D)(1-xp) xq
        ok = ~binf & ~cinf
        np.add.at(c1, P[ok], C[ok] - A[ok])
        np.add.at(c1, Q[ok], D[ok] - C[ok])
        w = B[ok] + C[ok] - A[ok] - D[ok]
        truncated = int((w < -1e-9).sum())
        rows.append(P[ok]); cols.append(Q[ok]); caps.append(np.round(np.maximum(w, 0) * scale))
        # C infinite (p -> alpha while q keeps is forbidden): edge q -> p uncuttable, and
        # E' = A (1 - xq) + B xq (1 - xp) + D xp   (xp = 1 implies xq = 1)
        sel = cinf & ~binf
        np.add.at(c0, Q[sel], A[sel])
        np.add.at(c1, P[sel], D[sel])
        rows.append(Q[sel]); cols.append(P[sel]); caps.append(np.full(sel.sum(), INFINITE_CAPACITY))
        rows.append(P[sel]); cols.append(Q[sel]); caps.append(np.round(B[sel] * scale))
        # B infinite (p keeps while q -> alpha is forbidden): the mirror image,
        # E' = A (1 - xp) + C xp (1 - xq) + D xq   (xq = 1 implies xp = 1)
        sel = binf & ~cinf
        np.add.at(c0, P[sel], A[sel])
        np.add.at(c1, Q[sel], D[sel])
        rows.append(P[sel]); cols.append(Q[sel]); caps.append(np.full(sel.sum(), INFINITE_CAPACITY))
        rows.append(Q[sel]); cols.append(P[sel]); caps.append(np.round(C[sel] * scale))
        # both infinite: p and q move together
        sel = binf & cinf
        np.add.at(c0, P[sel], A[sel])
        np.add.at(c1, P[sel], D[sel])
        for a_, b_ in ((P[sel], Q[sel]), (Q[sel], P[sel])):
            rows.append(a_); cols.append(b_); caps.append(np.full(sel.sum(), INFINITE_CAPACITY))

    # terminal edges: source side = keep (x = 0), sink side = alpha (x = 1)
    s, t = nf, nf + 1
    diff = c1 - c0
    inf1 = ~np.isfinite(c1)
    cap_s = np.where(inf1, INFINITE_CAPACITY, np.round(np.maximum(diff, 0) * scale))
    cap_t = np.where(inf1, 0, np.round(np.maximum(-diff, 0) * scale))
    idx = np.arange(nf)
    rows += [np.full(nf, s), idx]
    cols += [idx, np.full(nf, t)]
    caps += [cap_s, cap_t]
    r = np.concatenate(rows).astype(np.int64)
    c = np.concatenate(cols).astype(np.int64)
    w = np.minimum(np.concatenate(caps), INFINITE_CAPACITY).astype(np.int64)
    keep = (w > 0) & (r != c)
    graph = sp.csr_array((w[keep].astype(np.int32), (r[keep], c[keep])), shape=(nf + 2, nf + 2))
    graph.sum_duplicates()
    t0 = time.perf_counter()
    flow = maximum_flow(graph, s, t, method="dinic")
    timing.append(time.perf_counter() - t0)
    residual = (graph - flow.flow).tocsr()
    residual.data[residual.data < 0] = 0
    residual.eliminate_zeros()
    reach = breadth_first_order(residual, s, directed=True, return_predecessors=False)
    source_side = np.zeros(nf + 2, dtype=bool)
    source_side[reach] = True
    switch = ~source_side[:nf]
    if not switch.any():
        return None, truncated
    new = labels.copy()
    new[free_nodes[switch]] = alpha
    return new, truncated


def alpha_expansion(problem: LabelProblem, init: np.ndarray, *, max_cycles: int = 8,
                    order: np.ndarray | None = None) -> Solution:
    """Minimise the energy from a labelling `init` of finite energy.

    One cycle tries an expansion move for every label (in `order`, default 0..M-1); a move is
    kept when it lowers the energy. Stops after a cycle without improvement or `max_cycles`."""
    t0 = time.perf_counter()
    labels = np.asarray(init, dtype=np.int64).copy()
    energy = problem.energy(labels)
    if not np.isfinite(energy):
        raise ValueError("alpha_expansion needs an initial labelling of finite energy")
    sol = Solution(labels=labels, energy=energy, initial_energy=energy)
    scale = _scale(problem)
    timing: list[float] = []
    order = np.arange(problem.n_labels) if order is None else np.asarray(order)
    # a move is a function of the labelling: one that failed is not tried again until some
    # other move has changed the labelling (same result, fewer max-flow calls)
    failed_at = np.full(problem.n_labels, -1)
    changed_at = 0
    step = 0
    for _ in range(max_cycles):
        improved = False
        sol.cycles += 1
        for alpha in order:
            step += 1
            if failed_at[alpha] > changed_at:
                continue
            new, trunc = _expansion_move(problem, sol.labels, int(alpha), scale, timing)
            sol.moves += 1
            sol.truncated += trunc
            e = problem.energy(new) if new is not None else np.inf
            if e < sol.energy - 1e-9 * max(1.0, abs(sol.energy)):
                sol.labels, sol.energy = new, e
                sol.accepted += 1
                improved = True
                changed_at = step
            else:
                failed_at[alpha] = step
        sol.history.append(sol.energy)
        if not improved:
            break
    sol.seconds = time.perf_counter() - t0
    sol.flow_seconds = float(sum(timing))
    return sol


def icm(problem: LabelProblem, init: np.ndarray, *, max_sweeps: int = 20) -> Solution:
    """Iterated conditional modes: each node in turn takes the label that is best given its
    neighbours. The naive baseline (a local minimum with respect to single-node changes)."""
    t0 = time.perf_counter()
    labels = np.asarray(init, dtype=np.int64).copy()
    energy = problem.energy(labels)
    sol = Solution(labels=labels, energy=energy, initial_energy=energy)
    n, m = problem.n_nodes, problem.n_labels
    incident: list[list[tuple[int, int, bool]]] = [[] for _ in range(n)]
    for e, (a, b) in enumerate(problem.edges):
        incident[a].append((e, b, True))
        incident[b].append((e, a, False))
    all_labels = np.arange(m)
    for _ in range(max_sweeps):
        changed = False
        sol.cycles += 1
        for node in range(n):
            cost = problem.unary[node].astype(np.float64).copy()
            for e, other, node_is_p in incident[node]:
                ev = np.full(m, e)
                lo = np.full(m, labels[other])
                cost += problem.pairwise(ev, all_labels, lo) if node_is_p else \
                    problem.pairwise(ev, lo, all_labels)
            best = int(np.argmin(cost))
            if cost[best] < cost[labels[node]] - 1e-12:
                labels[node] = best
                changed = True
            sol.moves += 1
        if not changed:
            break
    sol.labels = labels
    sol.energy = problem.energy(labels)
    sol.seconds = time.perf_counter() - t0
    return sol
