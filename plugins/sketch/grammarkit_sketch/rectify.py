"""Undoing a page turned by a few degrees before the networks see a drawing (issue 30): a
person's drawing does it, the stage camera's renders do not. Not in the paper, which feeds
the drawing as it is (`rectify=False` keeps that measurable beside this).

For stages seen straight on (pitch 0, yaw 0: facades, floors, windows), whose drawings are
made of horizontal and vertical lines: the network input is stretched back to the canvas's
aspect ratio (a turn of the page is a rotation there, a shear in the input, which squeezes a
storey's 560 x 128 canvas into 128 x 128), and the angle (within `MAX_TURN` degrees) at
which the ink's row and column profiles are sharpest is the page's turn; the drawing is turned back and squeezed
again. Oblique stages (masses, roofs, ledges) have no such reference (their vertical edges
converge in perspective) and are left as drawn.

All numpy/scipy, deterministic, a few milliseconds per drawing.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MAX_TURN", "MIN_TURN", "frontal", "page_turn", "rectify_input"]

MAX_TURN = 8.0  # degrees: the largest page turn looked for
MIN_TURN = 0.5  # degrees: smaller estimates are left alone (noise of the pen's wobble)
MIN_PIXELS = 30  # stroke pixels near an axis needed to trust an estimate


def _stretch(x: np.ndarray, aspect: float) -> np.ndarray:
    from .image import resize

    h, w = x.shape
    size = (round(w * aspect), h) if aspect >= 1 else (w, round(h / aspect))
    return resize(x, size)


def page_turn(img: np.ndarray, step: float = 0.25) -> float:
    """The turn (degrees, `augment.rotate_ink`'s sign) that brings the lines of `img` (an ink
    image in canvas proportions) closest onto the image axes: the angle within MAX_TURN whose
    row and column ink profiles are sharpest (largest sum of squares, the projection-profile
    deskew of document scanners, here over both axes; free of the staircase bias that pulls
    a gradient-direction estimate of thin lines towards 0). 0.0 with fewer than MIN_PIXELS
    ink pixels."""
    ys, xs = np.nonzero(img > 0.3)
    if len(xs) < MIN_PIXELS:
        return 0.0
    w = img[ys, xs].astype(np.float64)
    px, py = xs - xs.mean(), ys - ys.mean()
    angles = np.arange(-MAX_TURN, MAX_TURN + step / 2, step)
    sharp = np.empty(len(angles))
    for k, a in enumerate(np.radians(angles)):
        c, s_ = np.cos(a), np.sin(a)
        rows = np.round(c * py - s_ * px).astype(np.int64)
        cols = np.round(c * px + s_ * py).astype(np.int64)
        sharp[k] = (np.bincount(rows - rows.min(), w) ** 2).sum() + (np.bincount(cols - cols.min(), w) ** 2).sum()
    k = int(np.argmax(sharp))
    best = float(angles[k])
    if 0 < k < len(angles) - 1:  # parabola through the peak and its neighbours
        y0, y1, y2 = sharp[k - 1], sharp[k], sharp[k + 1]
        den = y0 - 2 * y1 + y2
        if den < 0:
            best += step * 0.5 * (y0 - y2) / den
    return best


def frontal(stage: Any) -> bool:
    """Is the stage seen straight on (its drawings' lines horizontal and vertical)?"""
    return stage.pitch == 0 and stage.yaw == 0


def rectify_input(x: np.ndarray, stage: Any) -> tuple[np.ndarray, float]:
    """(input, turn): a network input with the page's turn undone for a stage seen straight
    on (module docstring), and the turn found in degrees (0.0: left as drawn). `stage`: the
    StageSpec of the canvas the drawing was made on."""
    from .augment import rotate_ink
    from .image import RES, level, resize, to_input

    x = np.asarray(x, dtype=np.float32)
    if not frontal(stage):
        return x, 0.0
    w, h = stage.canvas_size() if stage.framing == "anchor" else (1, 1)
    big = _stretch(x, w / h)
    turn = page_turn(big)
    if abs(turn) < MIN_TURN:
        return x, 0.0
    back = rotate_ink(big, turn)
    return (to_input(back, "fit") if stage.framing == "fit" else level(resize(back, (RES, RES)))), turn
