"""Drawing perturbations a person's sketch shows and the stage camera's renders do not: a
page turned by a few degrees, strokes that stop short or break off. Used as training
augmentation (`training.TrainConfig.augment`) and, with other pens, as robustness test
styles (`drawing.test_style`: "rotated", "partial"). A perspective error is the third
(`DrawStyle.pitch_offset` / `yaw_offset`, drawn through a turned camera, not an image edit).

All operate on ink maps (H x W float, 1 = line) with a numpy Generator, so the same seed gives
the same drawing.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rotate_ink", "break_strokes", "augment_ink", "MAX_ROTATION", "MAX_PERSPECTIVE"]

MAX_ROTATION = 6.0  # degrees: the "small rotations" (5) with a margin
MAX_PERSPECTIVE = 6.0  # degrees of camera pitch/yaw error covered in training (the 5, with a margin)
MAX_PARTIAL = 0.3  # share of the ink cut out of a training drawing at most


def rotate_ink(ink: np.ndarray, degrees: float) -> np.ndarray:
    """The drawing turned by `degrees` about the canvas centre (bilinear; paper outside)."""
    from scipy.ndimage import rotate

    if abs(degrees) < 1e-9:
        return np.asarray(ink, dtype=np.float32)
    out = rotate(np.asarray(ink, dtype=np.float32), float(degrees), reshape=False, order=1,
                 mode="constant", cval=0.0, prefilter=False)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def break_strokes(ink: np.ndarray, rng: np.random.Generator, share: float = 0.15,
                  gap: float = 0.03) -> np.ndarray:
    """Partial strokes: gaps cut into the lines, each a disc of radius `gap` x the canvas's
    shorter side, centred on line pixels, until about `share` of the ink is gone."""
    ink = np.asarray(ink, dtype=np.float32).copy()
    ys, xs = np.nonzero(ink > 0.5)
    if len(ys) == 0 or share <= 0:
        return ink
    h, w = ink.shape
    r = max(1.0, gap * min(h, w))
    total = float((ink > 0.5).sum())
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(200):  # bounded: each cut removes at least one disc's worth of line
        if (ink > 0.5).sum() <= (1.0 - share) * total:
            break
        i = int(rng.integers(len(ys)))
        cut = (yy - ys[i]) ** 2 + (xx - xs[i]) ** 2 <= r * r
        ink[cut] = 0.0
    return ink


def augment_ink(ink: np.ndarray, rng: np.random.Generator, *, max_rotation: float = MAX_ROTATION,
                partial_chance: float = 0.5, max_partial: float = 0.25) -> np.ndarray:
    """A training drawing perturbed: turned by up to `max_rotation` degrees either way and,
    with probability `partial_chance`, with up to `max_partial` of its ink cut out in gaps."""
    out = rotate_ink(ink, float(rng.uniform(-max_rotation, max_rotation)))
    if rng.random() < partial_chance:
        out = break_strokes(out, rng, share=float(rng.uniform(0.05, max_partial)))
    return out
