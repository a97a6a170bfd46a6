"""Alpha-expansion over scipy's max-flow: each move is the optimal expansion, the result is
within the 2x bound of the optimum for Potts energies, infinite costs are respected."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from grammarkit_retarget.alpha_expansion import LabelProblem, _expansion_move, _scale, alpha_expansion, icm


def _potts_problem(rng, n_nodes=7, n_labels=3, forbid=0.15, weight=1.0):
    unary = rng.uniform(0, 2, (n_nodes, n_labels))
    unary[rng.random((n_nodes, n_labels)) < forbid] = np.inf
    unary[np.arange(n_nodes), rng.integers(0, n_labels, n_nodes)] = rng.uniform(0, 2, n_nodes)
    edges = np.array([(i, j) for i in range(n_nodes) for j in range(i + 1, n_nodes)
                      if rng.random() < 0.5], dtype=np.int64).reshape(-1, 2)
    w = rng.uniform(0.1, 1.5, len(edges)) * weight

    def pairwise(e, a, b):
        return np.where(a != b, w[e], 0.0)

    return LabelProblem(unary=unary, edges=edges, pairwise=pairwise, max_pairwise=float(w.max()) if len(w) else 1.0)


def _brute_force(problem):
    best, best_e = None, np.inf
    for labels in itertools.product(range(problem.n_labels), repeat=problem.n_nodes):
        e = problem.energy(np.array(labels))
        if e < best_e:
            best, best_e = np.array(labels), e
    return best, best_e


def _finite_start(problem):
    return np.argmin(problem.unary, axis=1)  # every node has a finite label


@pytest.mark.parametrize("seed", range(12))
def test_each_expansion_move_is_the_best_expansion(seed):
    rng = np.random.default_rng(seed)
    p = _potts_problem(rng)
    labels = _finite_start(p)
    scale = _scale(p)
    for alpha in range(p.n_labels):
        new, _ = _expansion_move(p, labels, alpha, scale, [])
        got = p.energy(new) if new is not None else p.energy(labels)
        # brute force over every subset of nodes switching to alpha
        best = np.inf
        for mask in itertools.product((0, 1), repeat=p.n_nodes):
            cand = np.where(np.array(mask, bool), alpha, labels)
            best = min(best, p.energy(cand))
        assert got == pytest.approx(best, rel=1e-6, abs=1e-4 * p.max_pairwise), (seed, alpha)


@pytest.mark.parametrize("seed", range(12))
def test_result_is_within_twice_the_optimum_and_never_worse_than_icm(seed):
    rng = np.random.default_rng(100 + seed)
    p = _potts_problem(rng, n_nodes=8, n_labels=3, weight=2.0)
    start = _finite_start(p)
    sol = alpha_expansion(p, start)
    _, opt = _brute_force(p)
    assert np.isfinite(sol.energy) and sol.energy <= 2 * opt + 1e-9
    assert sol.energy <= p.energy(start) + 1e-12
    assert sol.energy <= icm(p, start).energy + 1e-9
    assert np.isfinite(p.unary[np.arange(p.n_nodes), sol.labels]).all()


def test_infinite_pairwise_costs_are_never_cut():
    # a chain where label 1 next to label 0 is forbidden: the chain must switch all at once
    n = 6
    unary = np.zeros((n, 2))
    unary[:, 1] = -1.0  # every node prefers label 1
    edges = np.array([(i, i + 1) for i in range(n - 1)])

    def pairwise(e, a, b):
        return np.where(a != b, np.inf, 0.0)

    p = LabelProblem(unary=unary, edges=edges, pairwise=pairwise, max_pairwise=1.0)
    sol = alpha_expansion(p, np.zeros(n, dtype=np.int64))
    assert (sol.labels == 1).all() and sol.energy == -n


def test_needs_a_finite_start():
    p = LabelProblem(unary=np.array([[np.inf, 0.0]]), edges=np.zeros((0, 2), np.int64),
                     pairwise=lambda e, a, b: np.zeros(len(e)), max_pairwise=1.0)
    with pytest.raises(ValueError, match="finite energy"):
        alpha_expansion(p, np.array([0]))


def test_large_costs_do_not_overflow_scipys_int32_capacities():
    rng = np.random.default_rng(7)
    n, m = 400, 5
    unary = rng.uniform(0, 1e6, (n, m))
    edges = np.array([(i, i + 1) for i in range(n - 1)])
    w = rng.uniform(0, 1e7, len(edges))
    p = LabelProblem(unary=unary, edges=edges, pairwise=lambda e, a, b: np.where(a != b, w[e], 0.0),
                     max_pairwise=float(w.max()))
    start = np.zeros(n, dtype=np.int64)
    sol = alpha_expansion(p, start)
    assert sol.energy <= p.energy(start) and sol.energy <= icm(p, start).energy * 1.0000001
