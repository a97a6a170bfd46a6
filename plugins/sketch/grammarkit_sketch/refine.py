"""Refinement of the estimated parameters against the sketch (Nishida et al. 2016, s. 6.1).

A candidate (normalised parameter vector u) is derived on the stage, drawn in the exact line
style through the stage camera and compared with the sketch at the score canvas
(dataset.quick_size: the stage canvas with its shorter side 128 pixels; for the fit-framed
mass, both drawings framed on their own extent at 128 x 128). Both are reduced to line masks
found at the drawing's own resolution (dataset.line_mask); D is the Euclidean distance
transform to the nearest line pixel, in pixels of the 128 px canvas. Two scores:

- `paper`: equation (1), s = exp(-||D(I_prop) - D(I_sketch)||_F / sqrt(H W)), the RMS
  difference of the two transforms (1 for a perfect match, 0.37 for 1 px RMS).
- `chamfer` (the default): s = exp(-mean symmetric chamfer distance), each line pixel's
  distance to the other drawing's lines capped at CHAMFER_CAP: only the lines count, not the
  empty paper, where the paper's score also adds up the difference of the transforms.

The search may also turn the view (`view_range` degrees of pitch and yaw, two more search
coordinates): the pens draw up to 2 degrees off the stage camera, which moves lines by more
pixels than many parameters do.

Three searches, all measured in benchmarks/bench_sketch.py:
- `metropolis`: the paper's Metropolis-Hastings: a Gaussian proposal around the current state,
  accepted with probability min(1, s_prop / s_cur); the best state visited is returned.
- `greedy`: the coordinate search of Nishida's public code: each step tries +/- delta on every
  coordinate and keeps the best improvement; delta starts at 0.02 and shrinks by 0.8 every 10
  steps.
- `pattern` (the default): compass search with per-coordinate steps (start 0.08, halved on
  failure), one sweep of line searches over the parameters (`scan`), and a move back towards
  the network's estimate where the score is flat (`keep_network_values`); see `refine`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from .dataset import line_mask, quick_size, stage_view
from .drawing import draw
from .drawing import DrawStyle
from .image import distance_map
from .library import SnippetInfo
from .stages import StageDeriver

METHODS = ("pattern", "greedy", "metropolis")
PATTERN_STEP = 0.08
PATTERN_WARMUP = 3
SCAN_POINTS = 11
SCAN_MIN_GAIN = 0.01  # relative score gain a line search must make to move a parameter
NETWORK_TOLERANCE = 0.003  # relative score loss accepted to move back towards a network value
VIEW_RANGE = 3.0  # degrees: the training pens draw up to 2 off the stage camera
PATTERN_MIN_STEP = 0.005
EXACT_STYLE = DrawStyle(sketchy=False, width=2.0)
GREEDY_STEP = 0.02
GREEDY_SHRINK = 0.8
GREEDY_EVERY = 10
MH_SIGMA = 0.04


def score_from_distance(d_prop: np.ndarray, d_sketch: np.ndarray) -> float:
    diff = d_prop.astype(np.float64) - d_sketch.astype(np.float64)
    return math.exp(-float(np.sqrt((diff * diff).mean())))


SCORES = ("chamfer", "paper", "pen")
SCORE_SHORT = 128  # default score canvas, shorter side (pixels); distances are in these pixels
CHAMFER_CAP = 8.0  # distances beyond this (128 px canvas) count as this: a stroke far off


def chamfer_score(prop: np.ndarray, d_prop: np.ndarray, sketch: np.ndarray, d_sketch: np.ndarray,
                  cap: float = CHAMFER_CAP) -> float:
    """exp(-mean truncated symmetric chamfer distance): how far, on average, each drawn line
    pixel of either image is from the other image's lines, capped at `cap`."""
    if not prop.any() or not sketch.any():
        return math.exp(-cap)
    a = float(np.minimum(d_sketch[prop], cap).mean())
    b = float(np.minimum(d_prop[sketch], cap).mean())
    return math.exp(-0.5 * (a + b))


@dataclass
class Scorer:
    """Scores parameter vectors of one snippet against one sketch (results cached).

    `sketch` is the sketch's line mask at the score canvas (dataset.line_mask with the same
    `short`). `score`: "paper" is equation (1) of the paper on the distance transforms;
    "chamfer" (the default) the truncated symmetric chamfer distance (see `chamfer_score`).
    """

    deriver: StageDeriver
    info: SnippetInfo
    names: Sequence[str]  # the parameters searched, in u order
    fixed: dict  # values of the other parameters
    sketch: np.ndarray  # bool line mask at the score canvas
    score: str = "chamfer"
    short: int = SCORE_SHORT
    view_offset: tuple[float, float] = (0.0, 0.0)  # (pitch, yaw) degrees off the stage camera
    # > 0: u carries two more entries, the view's pitch and yaw offsets, u = 0 .. 1 mapping to
    # -view_range .. +view_range degrees (0.5: the stage camera), searched with the parameters
    view_range: float = 0.0
    evaluations: int = 0

    def __post_init__(self) -> None:
        if self.score not in SCORES:
            raise ValueError(f"unknown score {self.score!r}; expected one of {', '.join(SCORES)}")
        self._cache: dict[tuple, float] = {}
        self.sketch = np.asarray(self.sketch, dtype=bool)
        self.pen = EXACT_STYLE
        if self.score == "pen":
            # the proposals drawn with the sketch's own line width: a 7 px felt pen or five
            # passes over an edge are a band that exact 1 px lines sit inside, whose pixels'
            # distances add a pen-dependent cost (and thinning the band to its centre line
            # breaks it into spurs where two edges' bands merge, measured worse)
            from .strokes import thin

            centre = int(thin(self.sketch).sum())
            width_px = float(self.sketch.sum()) / max(1, centre)  # line area / line length
            scale = min(quick_size(self.deriver.stage, self.short)) / 256.0
            self.pen = replace(EXACT_STYLE, width=max(EXACT_STYLE.width, width_px / scale))
        self.sketch_distance = distance_map(self.sketch)
        # distances in pixels of a 128 px canvas whatever the score canvas, so the score's scale
        # (and Metropolis-Hastings' acceptance) does not depend on the resolution
        self._unit = SCORE_SHORT / float(self.short)

    def values(self, u: np.ndarray) -> dict:
        params = {p.name: p for p in self.info.params}
        out = dict(self.fixed)
        out.update({n: params[n].value(x) for n, x in zip(self.names, u)})
        return out

    @property
    def size(self) -> int:
        """Length of the searched vector: the parameters, then the view offsets if searched."""
        return len(self.names) + (2 if self.view_range > 0 else 0)

    def start(self, u: np.ndarray) -> np.ndarray:
        """The search's starting vector for parameter estimate `u` (the stage camera's view)."""
        u = np.asarray(u, dtype=float)
        return np.concatenate([u, [0.5, 0.5]]) if self.view_range > 0 else u

    def offsets(self, u: np.ndarray) -> tuple[float, float]:
        """(pitch, yaw) offset of the view of search vector `u`, degrees."""
        if self.view_range <= 0:
            return self.view_offset
        k = len(self.names)
        return (self.view_offset[0] + (float(u[k]) - 0.5) * 2 * self.view_range,
                self.view_offset[1] + (float(u[k + 1]) - 0.5) * 2 * self.view_range)

    def render(self, u: np.ndarray) -> np.ndarray | None:
        """The proposal's line mask at the score canvas (None if the values cannot be derived)."""
        from grammarkit.errors import GrammarkitError

        try:
            model = self.deriver.derive(self.info.name, self.values(u))
        except GrammarkitError:
            return None
        stage = self.deriver.stage
        size = quick_size(stage, self.short)
        style = self.pen
        pitch, yaw = self.offsets(u)
        if (pitch, yaw) != (0.0, 0.0):
            style = replace(self.pen, pitch_offset=pitch, yaw_offset=yaw)
        ink = draw(model, stage_view(stage, model, size, style), style, stage.host_box(), supersample=1)
        return line_mask(ink, stage, self.short)

    def compare(self, prop: np.ndarray) -> float:
        d_prop = distance_map(prop)
        if self.score == "paper":
            return score_from_distance(d_prop * self._unit, self.sketch_distance * self._unit)
        return chamfer_score(prop, d_prop * self._unit, self.sketch, self.sketch_distance * self._unit)

    def __call__(self, u: np.ndarray) -> float:
        key = tuple(np.round(np.clip(u, 0.0, 1.0), 6))
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        self.evaluations += 1
        x = self.render(np.asarray(key))
        s = 0.0 if x is None else self.compare(x)
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


def scan(score: Callable[[np.ndarray], float], u0: np.ndarray, points: int,
         dims: int | None = None, min_gain: float = 0.0) -> tuple[np.ndarray, float]:
    """One sweep of line searches: each of the first `dims` coordinates in turn is set to the
    best of `points` evenly spaced values in [0, 1] (the others held) when that beats the
    current score by more than the factor 1 + `min_gain`. Gets a parameter out of a wrong basin
    that a local step cannot leave; `min_gain` keeps a parameter the drawing barely shows (a
    score flat to within noise over part of its range) where it was instead of at the end of
    that range."""
    u = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    best = score(u)
    for j in range(len(u) if dims is None else dims):
        cand_u, cand_s = None, best * (1.0 + min_gain)
        for x in np.linspace(0.0, 1.0, points):
            v = u.copy()
            v[j] = x
            s = score(v)
            if s > cand_s:
                cand_u, cand_s = v, s
        if cand_u is not None:
            u, best = cand_u, cand_s
    return u, best


def keep_network_values(score: Callable[[np.ndarray], float], u: np.ndarray, best: float,
                        u_net: np.ndarray, tolerance: float, halvings: int = 5,
                        at_least: float = 0.0) -> tuple[np.ndarray, float]:
    """Each parameter in turn moves back towards the network's estimate as far as the score
    stays within the factor 1 - `tolerance` of the refined one (bisection, `halvings` steps).
    Where the drawing cannot tell values apart (a low mansard top pitch hidden in the outline)
    the search drifts on a flat score, often to the end of the range; the network's estimate,
    which has learnt what such drawings usually show, is the better guess there. The score
    never falls below `at_least` (the network estimate's: refinement never makes it worse)."""
    u = np.asarray(u, dtype=float).copy()
    floor = max(best * (1.0 - tolerance), at_least)
    for j in range(len(u_net)):
        if u[j] == u_net[j]:
            continue
        v = u.copy()
        v[j] = u_net[j]
        s = score(v)
        if s >= floor:
            u = v
            continue
        near, far = u[j], u_net[j]  # acceptable at near, not at far
        for _ in range(halvings):
            mid = 0.5 * (near + far)
            v[j] = mid
            if score(v) >= floor:
                near = mid
            else:
                far = mid
        u[j] = near
    return u, score(u)


def pattern(score: Callable[[np.ndarray], float], u0: np.ndarray, steps: int,
            step: float = PATTERN_STEP, min_step: float = PATTERN_MIN_STEP) -> tuple[np.ndarray, float]:
    """Compass (pattern) search: each step visits every parameter in turn and moves it by +/- its
    own step when that improves the score (first improvement); a parameter whose two moves both
    fail halves its step. Ends after `steps` sweeps or when every step is below `min_step`.

    Unlike `greedy`'s fixed 0.02 (the public code's delta), the steps start large, so a
    regressor error of 0.2 is reached in a few sweeps, and shrink only where the score says the
    optimum is near; a parameter that moves no pixel stops costing renders once its step is small.
    """
    u = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    best = score(u)
    h = np.full(len(u), float(step))
    for _ in range(steps):
        if (h < min_step).all():
            break
        for j in range(len(u)):
            if h[j] < min_step:
                continue
            moved = False
            for sign in (1.0, -1.0):
                v = u.copy()
                v[j] = min(1.0, max(0.0, v[j] + sign * h[j]))
                if v[j] == u[j]:
                    continue
                s = score(v)
                if s > best:
                    u, best, moved = v, s, True
                    break
            if not moved:
                h[j] *= 0.5
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


def with_prior(scorer: Callable[[np.ndarray], float], u_net: np.ndarray,
               sigma: float, floor: float = 0.0) -> Callable[[np.ndarray], float]:
    """The score times a Gaussian prior around the network's estimate: s(u) x exp(-|u - u_net|^2
    / (2 sigma^2)) over the parameters (not the view offsets). With sigma the regressor's
    validation RMSE this is the maximum a posteriori estimate with the network as the prior:
    the drawing moves a parameter away from the network's value only as far as it shows it
    better. Measured (docs/sketch.md): once the regressors reach RMSE 0.02-0.06, the score's own
    optimum (biased by the pen's overshoot and wobble) lies further from the truth than the
    network's estimate, and refinement without the prior made the error larger.

    `floor`: a value no search will accept a proposal at or below (the network estimate's
    objective: `refine`'s searches only take improvements on it). A score is at most 1, so a
    proposal whose prior factor alone is below `floor` cannot be taken: it is not rendered and
    counts 0.0, which changes no decision of the search (the same result, fewer renders)."""
    u_net = np.asarray(u_net, dtype=float)
    k = len(u_net)
    inv = 0.5 / (sigma * sigma)

    def objective(u: np.ndarray) -> float:
        d = np.asarray(u, dtype=float)[:k] - u_net
        factor = math.exp(-inv * float(d @ d))
        if factor < floor:
            return 0.0
        return scorer(u) * factor
    return objective


def refine(scorer: Scorer, u0: np.ndarray, steps: int, method: str = "pattern",
           seed: int = 0, prior_sigma: float | None = None) -> tuple[np.ndarray, float, float]:
    """(refined parameters u, its score, seconds). With a view search (scorer.view_range > 0)
    the view offsets are searched too; `scorer.offsets(...)` of the result is not returned, the
    parameters are what a recognition reports.

    `pattern`: a few compass-search sweeps (the view settles first), one line-search sweep over
    the parameters (`scan`, SCAN_POINTS values each), compass search for `steps` sweeps, then
    each parameter back towards the network's estimate as far as the score stays within
    NETWORK_TOLERANCE (`keep_network_values`). With `prior_sigma` it maximises the score times
    a Gaussian prior around the network's estimate (`with_prior`) instead of the score alone;
    the score returned is the match score s of the result either way. `greedy` and
    `metropolis` (Nishida's code and the paper) always search the score alone.
    """
    if method not in METHODS:
        raise ValueError(f"unknown refinement method {method!r}; expected one of {', '.join(METHODS)}")
    if prior_sigma is not None and not (prior_sigma > 0):
        raise ValueError(f"prior sigma must be > 0, got {prior_sigma!r}")
    t0 = time.perf_counter()
    k = len(u0)
    start = scorer.start(np.asarray(u0, float))
    if steps <= 0 or k == 0:
        return np.asarray(u0, float), scorer(start), time.perf_counter() - t0
    if method == "pattern":
        # with the prior: proposals that cannot beat the network's estimate are not rendered
        goal = scorer if prior_sigma is None else with_prior(scorer, u0, prior_sigma, floor=scorer(start))
        u, _ = pattern(goal, start, min(steps, PATTERN_WARMUP))
        u, _ = scan(goal, u, SCAN_POINTS, k, SCAN_MIN_GAIN)
        u, s = pattern(goal, u, steps)
        u, _ = keep_network_values(goal, u, s, np.asarray(u0, float), NETWORK_TOLERANCE,
                                   at_least=goal(start))
        s = scorer(u)
    elif method == "greedy":
        u, s = greedy(scorer, start, steps)
    else:
        u, s = metropolis(scorer, start, steps, seed)
    return u[:k], s, time.perf_counter() - t0


PLATEAU_PROBE = 0.02  # normalised: a value this far away deriving the same geometry is a plateau


def centre_on_plateaus(deriver: StageDeriver, info: SnippetInfo, values: dict,
                       names: Sequence[str]) -> dict:
    """Values with each parameter of `names` that sits on a plateau (a range of values deriving
    the same geometry: a facade's floor height only shows through the number of floors) moved
    to the middle of it. The drawing, hence the score, is unchanged; of the values the sketch
    cannot tell apart, the middle one has the smallest expected error."""
    from grammarkit.errors import GrammarkitError

    from .dataset import equivalence_interval

    def key(vals: dict) -> bytes | None:
        try:
            m = deriver.derive(info.name, vals)
        except GrammarkitError:
            return None
        verts = np.round(np.asarray(m.vertices), 4)
        return verts[np.lexsort(verts.T[::-1])].tobytes()

    out = dict(values)
    params = {p.name: p for p in info.params}
    for n in names:
        p = params[n]
        k0 = key(out)
        if k0 is None:
            return out
        d = PLATEAU_PROBE * (p.hi - p.lo)
        v = float(out[n])
        if not any(key({**out, n: x}) == k0 for x in (min(p.hi, v + d), max(p.lo, v - d)) if x != v):
            continue
        lo, hi = equivalence_interval(deriver, info.name, out, n, p.lo, p.hi)
        out[n] = (lo + hi) / 2
    return out

