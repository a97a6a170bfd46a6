"""Rigid docking by least squares (Kabsch 1976; Kalojanov 2019 section 4, "docking transform").

`dock(a, b)` finds the rotation R (a proper rotation, det +1) and translation t minimising
sum ||R a_i + t - b_i||^2, i.e. the transform that moves points `a` onto points `b`, from the SVD
of the 3x3 covariance. A reflection would fit mirrored inputs better; the sign correction
(`diag(1, 1, d)`) forbids it, because parts cannot be mirrored by a rigid docking.

One or two points do not fix a rotation: with `allow_translation=True` (the default) they give a
pure translation (of the centroids) - the sampler's boundaries of one node need exactly that; with
`allow_translation=False` they raise. Three or more collinear points leave the rotation about
their line free: that is an error, as are mismatched shapes and non-finite numbers.
"""
from __future__ import annotations

import numpy as np

from ..errors import ShapeError

__all__ = ["apply", "dock"]


def dock(a_points, b_points, *, allow_translation: bool = True) -> tuple[np.ndarray, float]:  # noqa: ANN001
    """(4x4 rigid transform taking `a_points` onto `b_points`, RMS residual)."""
    try:
        a = np.asarray(a_points, dtype=np.float64)
        b = np.asarray(b_points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"dock: expected two (n, 3) arrays of numbers: {exc}") from None
    if a.ndim != 2 or a.shape[1] != 3 or b.shape != a.shape:
        raise ShapeError(f"dock: expected two (n, 3) point sets of the same size, got shapes "
                         f"{a.shape} and {b.shape}")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ShapeError("dock: the points contain NaN or infinite coordinates")
    n = len(a)
    if n == 0:
        raise ShapeError("dock: no points to align")
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    T = np.eye(4)
    scale = max(float(np.abs(a - ca).max()), float(np.abs(b - cb).max()), 1e-12)
    if n < 3 or _rank(a - ca, scale) < 2 or _rank(b - cb, scale) < 2:
        if n >= 3 or not allow_translation:
            raise ShapeError(f"dock: need at least 3 non-collinear points to fix a rotation, got {n} "
                             f"{'collinear ' if n >= 3 else ''}point(s)")
        T[:3, 3] = cb - ca
        return T, _rms(a + T[:3, 3], b)
    H = (a - ca).T @ (b - cb)
    U, _, Vt = np.linalg.svd(H)
    d = 1.0 if np.linalg.det(Vt.T @ U.T) >= 0 else -1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    T[:3, :3] = R
    T[:3, 3] = cb - R @ ca
    return T, _rms(apply(T, a), b)


def _rank(centered: np.ndarray, scale: float) -> int:
    s = np.linalg.svd(centered, compute_uv=False)
    return int((s > 1e-9 * scale * max(1.0, np.sqrt(len(centered)))).sum())


def _rms(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.sqrt(((x - y) ** 2).sum(axis=1).mean()))


def apply(transform: np.ndarray, points) -> np.ndarray:  # noqa: ANN001
    p = np.asarray(points, dtype=np.float64)
    return p @ transform[:3, :3].T + transform[:3, 3]
