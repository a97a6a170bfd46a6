"""The one polygon crossing test (geometry.footprints.first_crossing): the same answer as the
pairwise test on random rings, and bounded work on large outlines (issue 31)."""
from __future__ import annotations

import math
import random

import pytest

from grammarkit.geometry.footprints import MAX_VERTICES, first_crossing, validate_polygon


def _pairwise(ring, eps=0.0):
    n = len(ring)

    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            c, d = ring[j], ring[(j + 1) % n]
            if orient(a, b, c) * orient(a, b, d) < -eps and orient(c, d, a) * orient(c, d, b) < -eps:
                return i, j
    return None


@pytest.mark.parametrize("seed", range(40))
def test_same_first_crossing_as_the_pairwise_test(seed):
    rnd = random.Random(seed)
    n = rnd.randint(4, 60)
    ring = [(rnd.uniform(0, 10), rnd.uniform(0, 10)) for _ in range(n)]
    assert first_crossing(ring) == _pairwise(ring)


def test_a_fine_lot_at_the_vertex_limit_is_simple_and_one_crossing_is_found():
    n = MAX_VERTICES
    rnd = random.Random(1)
    ring = [((50 + rnd.uniform(0, 0.01)) * math.cos(2 * math.pi * i / n),
             (50 + rnd.uniform(0, 0.01)) * math.sin(2 * math.pi * i / n)) for i in range(n)]
    assert first_crossing(ring) is None
    assert len(validate_polygon(ring)) == n
    ring[100], ring[101] = ring[101], ring[100]  # two swapped vertices: edges 99 and 101 cross
    assert first_crossing(ring) == _pairwise(ring)


def test_a_spiky_star_is_checked_exactly():
    n = 2_000
    ring = [((5 + (i % 2)) * math.cos(2 * math.pi * i / n), (5 + (i % 2)) * math.sin(2 * math.pi * i / n))
            for i in range(n)]
    assert first_crossing(ring) is None
    ring[500], ring[700] = ring[700], ring[500]
    assert first_crossing(ring) == _pairwise(ring)


def test_beyond_the_vertex_limit_is_a_clear_error():
    ring = [(math.cos(t), math.sin(t)) for t in (2 * math.pi * i / (MAX_VERTICES + 1) for i in range(MAX_VERTICES + 1))]
    with pytest.raises(ValueError, match=f"limit is {MAX_VERTICES:,}"):
        first_crossing(ring)
