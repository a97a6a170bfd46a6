"""The prior's pruning (refine.with_prior's floor): proposals whose prior factor alone is below
the network estimate's objective are not rendered, and the search ends where it ends without
the pruning."""
from __future__ import annotations

import math

import numpy as np

from grammarkit_sketch import refine as R


class FakeScorer:
    """A score with its optimum away from the network's estimate, counting evaluations."""

    def __init__(self, best, width=0.3):
        self.best, self.width, self.calls = np.asarray(best, float), width, 0

    def start(self, u):
        return np.concatenate([np.asarray(u, float), [0.5, 0.5]])

    def __call__(self, u):
        self.calls += 1
        u = np.asarray(u, float)
        d = u[:len(self.best)] - self.best
        return 0.9 * math.exp(-float(d @ d) / (2 * self.width ** 2)) * (1 - 0.1 * abs(u[-1] - 0.5))


def _unpruned_refine(scorer, u0, steps, sigma):
    """refine's pattern search with the prior but no floor (what it was before)."""
    k = len(u0)
    start = scorer.start(np.asarray(u0, float))
    goal = R.with_prior(scorer, u0, sigma)
    u, _ = R.pattern(goal, start, min(steps, R.PATTERN_WARMUP))
    u, _ = R.scan(goal, u, R.SCAN_POINTS, k, R.SCAN_MIN_GAIN)
    u, s = R.pattern(goal, u, steps)
    u, _ = R.keep_network_values(goal, u, s, np.asarray(u0, float), R.NETWORK_TOLERANCE, at_least=goal(start))
    return u[:k], scorer(u)


def test_pruned_and_unpruned_searches_end_at_the_same_parameters_with_fewer_renders():
    for best, u0, sigma in (([0.7, 0.2], [0.5, 0.3], 0.05), ([0.9, 0.9, 0.1], [0.6, 0.8, 0.2], 0.1),
                            ([0.3], [0.35], 0.02)):
        a, b = FakeScorer(best), FakeScorer(best)
        u_pruned, s_pruned, _ = R.refine(a, np.array(u0), 10, "pattern", prior_sigma=sigma)
        u_full, s_full = _unpruned_refine(b, np.array(u0), 10, sigma)
        assert np.array_equal(u_pruned, u_full) and s_pruned == s_full
        assert a.calls < b.calls  # the scan's far points are never rendered


def test_the_floor_only_skips_what_cannot_be_taken():
    sc = FakeScorer([0.5])
    goal = R.with_prior(sc, np.array([0.5]), 0.05, floor=0.5)
    assert goal(np.array([0.5, 0.5, 0.5])) > 0 and sc.calls == 1
    assert goal(np.array([0.9, 0.5, 0.5])) == 0.0 and sc.calls == 1  # factor e^-32: not rendered
