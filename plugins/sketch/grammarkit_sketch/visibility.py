"""How far a parameter moves the drawing across its range, at the refinement score's canvas.

A parameter is only recoverable from a sketch to the degree it moves the sketch's lines: one
that shifts a line by 3 pixels over its whole range is hidden in a pen that wobbles and
overshoots by about as much. `parameter_reach` measures it (used by
plugins/sketch/scripts/visibility.py and benchmarks/bench_sketch.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .dataset import quick_size
from .image import distance_map
from .library import SnippetInfo
from .refine import SCORE_SHORT, Scorer
from .stages import StageDeriver

#: displacement (pixels of the 128 px score canvas) below which a parameter counts as weakly
#: visible: the held-out pens wobble by up to 1 px and overshoot by up to 3.5 px at that size
WEAK_REACH = 6.0


@dataclass(frozen=True)
class Reach:
    parameter: str
    hausdorff: float  # largest displacement of a line between the range's ends, pixels (mean)
    chamfer: float  # average displacement (symmetric mean chamfer distance), pixels (mean)

    @property
    def weak(self) -> bool:
        return self.hausdorff < WEAK_REACH


def _drawable_end(sc: Scorer, base: np.ndarray, j: int, end: float) -> np.ndarray | None:
    """The drawing with coordinate j at `end`, or as near it (towards the base value) as the
    snippet can be derived (a cornice cannot project further than its guard allows)."""
    for t in np.linspace(0.0, 1.0, 11)[:-1]:
        u = base.copy()
        u[j] = end + t * (base[j] - end)
        x = sc.render(u)
        if x is not None:
            return x
    return None


def parameter_reach(deriver: StageDeriver, info: SnippetInfo, names: Sequence[str], bases: int = 4,
                    short: int = SCORE_SHORT, seed: int = 0) -> list[Reach]:
    """For each parameter of `names`: the drawings (exact lines, stage camera, score canvas) at
    the bottom and the top of its range (or the nearest derivable values), the others at
    `bases` points (the middle of the
    ranges, then random); the mean over those points of the Hausdorff and chamfer distances."""
    blank = np.zeros(quick_size(deriver.stage, short)[::-1], bool)
    sc = Scorer(deriver, info, list(names), dict(info.defaults()), blank, short=short)
    rng = np.random.default_rng(seed)
    points = [np.full(len(names), 0.5)] + [rng.random(len(names)) for _ in range(bases - 1)]
    out = []
    for j, n in enumerate(names):
        far, mean = [], []
        for base in points:
            a, b = _drawable_end(sc, base, j, 0.0), _drawable_end(sc, base, j, 1.0)
            if a is None or b is None or not a.any() or not b.any():
                continue
            da, db = distance_map(a), distance_map(b)
            far.append(max(float(db[a].max()), float(da[b].max())))
            mean.append(0.5 * (float(db[a].mean()) + float(da[b].mean())))
        scale = SCORE_SHORT / short  # pixels of the 128 px canvas
        out.append(Reach(n, scale * float(np.mean(far)) if far else 0.0,
                         scale * float(np.mean(mean)) if mean else 0.0))
    return out
