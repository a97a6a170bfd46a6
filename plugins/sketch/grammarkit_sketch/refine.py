"""Refinement of the estimated parameters against the sketch (Nishida et al. 2016, s. 6.1).

A candidate (normalised parameter vector u) is derived on the stage, drawn in the exact line
style through the stage camera, and scored against the sketch with the paper's equation (1),

    s = exp(-||D(I_prop) - D(I_sketch)||_F / sqrt(H W)),

D the Euclidean distance transform to the nearest line pixel. Both images are at the score
canvas size (dataset.quick_size: the stage canvas with its shorter side 128 pixels; for the
fit-framed mass, the 128x128 network input). Dividing the Frobenius norm by sqrt(HW) makes it
the RMS difference in pixels, so the score does not depend on the resolution (1 for a perfect
match, 0.37 for 1 px RMS).

Two searches, both measured in benchmarks/bench_sketch.py:
- `metropolis`: the paper's Metropolis-Hastings: a Gaussian proposal around the current state,
  accepted with probability min(1, s_prop / s_cur); the best state visited is returned.
- `greedy`: the coordinate search of Nishida's public code: each step tries +/- delta on every
  parameter and keeps the best improvement; delta starts at 0.02 and shrinks by 0.8 every 10
  steps.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .dataset import quick_size, score_image, stage_view
from .drawing import draw
from .drawing import DrawStyle
from .image import distance_map
from .library import SnippetInfo
from .stages import StageDeriver

METHODS = ("greedy", "metropolis")
EXACT_STYLE = DrawStyle(sketchy=False, width=2.0)
GREEDY_STEP = 0.02
GREEDY_SHRINK = 0.8
GREEDY_EVERY = 10
MH_SIGMA = 0.04


def score_from_distance(d_prop: np.ndarray, d_sketch: np.ndarray) -> float:
    diff = d_prop.astype(np.float64) - d_sketch.astype(np.float64)
    return math.exp(-float(np.sqrt((diff * diff).mean())))


@dataclass
class Scorer:
    """Scores parameter vectors of one snippet against one sketch (results cached)."""

    deriver: StageDeriver
    info: SnippetInfo
    names: Sequence[str]  # the parameters searched, in u order
    fixed: dict  # values of the other parameters
    sketch_distance: np.ndarray
    evaluations: int = 0

    def __post_init__(self) -> None:
        self._cache: dict[tuple, float] = {}

    def values(self, u: np.ndarray) -> dict:
        params = {p.name: p for p in self.info.params}
        out = dict(self.fixed)
        out.update({n: params[n].value(x) for n, x in zip(self.names, u)})
        return out

    def render(self, u: np.ndarray) -> np.ndarray | None:
        """The proposal's score image (None if the values cannot be derived)."""
        from grammarkit.errors import GrammarkitError

        try:
            model = self.deriver.derive(self.info.name, self.values(u))
        except GrammarkitError:
            return None
        stage = self.deriver.stage
        size = quick_size(stage)
        ink = draw(model, stage_view(stage, model, size), EXACT_STYLE, stage.host_box(), supersample=1)
        return score_image(ink, stage)

    def __call__(self, u: np.ndarray) -> float:
        key = tuple(np.round(np.clip(u, 0.0, 1.0), 6))
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        self.evaluations += 1
        x = self.render(np.asarray(key))
        s = 0.0 if x is None else score_from_distance(distance_map(x), self.sketch_distance)
        self._cache[key] = s
        return s


def greedy(score: Callable[[np.ndarray], float], u0: np.ndarray, steps: int,
           step: float = GREEDY_STEP) -> tuple[np.ndarray, float]:
    u = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    best = score(u)
    for it in range(steps):
        if it and it % GREEDY_EVERY == 0:
            step *= GREEDY_SHRINK
        cand_u, cand_s = None, best
        for j in range(len(u)):
            for sign in (1.0, -1.0):
                v = u.copy()
                v[j] = min(1.0, max(0.0, v[j] + sign * step))
                if v[j] == u[j]:
                    continue
                s = score(v)
                if s > cand_s:
                    cand_u, cand_s = v, s
        if cand_u is not None:
            u, best = cand_u, cand_s
    return u, best


def metropolis(score: Callable[[np.ndarray], float], u0: np.ndarray, steps: int, seed: int = 0,
               sigma: float = MH_SIGMA) -> tuple[np.ndarray, float]:
    rng = np.random.default_rng([seed, 31])
    u = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    cur = score(u)
    best_u, best = u, cur
    for _ in range(steps):
        v = np.clip(u + rng.normal(0.0, sigma, size=len(u)), 0.0, 1.0)
        s = score(v)
        if cur <= 0.0 or rng.random() < min(1.0, s / cur):
            u, cur = v, s
            if s > best:
                best_u, best = v, s
    return best_u, best


def refine(scorer: Scorer, u0: np.ndarray, steps: int, method: str = "greedy",
           seed: int = 0) -> tuple[np.ndarray, float, float]:
    """(refined u, its score, seconds)."""
    if method not in METHODS:
        raise ValueError(f"unknown refinement method {method!r}; expected one of {', '.join(METHODS)}")
    t0 = time.perf_counter()
    if steps <= 0 or len(u0) == 0:
        return np.asarray(u0, float), scorer(np.asarray(u0, float)), time.perf_counter() - t0
    if method == "greedy":
        u, s = greedy(scorer, u0, steps)
    else:
        u, s = metropolis(scorer, u0, steps, seed)
    return u, s, time.perf_counter() - t0
