"""Flat-kernel Mean Shift (numpy + a k-d tree): the clustering `learn` uses for docking sites
and placements, and the string VAE for its placement categories."""
from __future__ import annotations

import numpy as np

__all__ = ["mean_shift"]


def mean_shift(points: np.ndarray, bandwidth: float, *, max_iter: int = 100,
               max_seeds: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """(modes (m, d), label per point (n,)) of flat-kernel Mean Shift. Deterministic."""
    X = np.asarray(points, dtype=np.float64)
    n = len(X)
    if n == 0:
        return np.zeros((0, X.shape[1] if X.ndim == 2 else 0)), np.zeros(0, dtype=int)
    if bandwidth <= 0:
        raise ValueError("mean_shift: bandwidth must be positive")
    # seeds: one per occupied bin of size bandwidth/2 (like sklearn's bin seeding) for big inputs
    if n > max_seeds:
        keys = np.floor(X / (bandwidth / 2)).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        seeds = X[np.sort(first)]
    else:
        seeds = X.copy()
    from scipy.spatial import cKDTree

    tree = cKDTree(X)
    modes = []
    for s in seeds:
        m = s
        for _ in range(max_iter):
            idx = tree.query_ball_point(m, bandwidth)
            new = X[idx].mean(axis=0) if idx else m
            if np.linalg.norm(new - m) <= 1e-6 * bandwidth:
                m = new
                break
            m = new
        modes.append((len(tree.query_ball_point(m, bandwidth)), tuple(m)))
    # strongest modes first; drop modes within half a bandwidth of a kept one
    modes.sort(key=lambda c: (-c[0], c[1]))
    kept: list[np.ndarray] = []
    for _, m in modes:
        m = np.array(m)
        if all(np.linalg.norm(m - k) > bandwidth / 2 for k in kept):
            kept.append(m)
    centres = np.array(kept)
    labels = np.argmin(np.linalg.norm(X[:, None, :] - centres[None, :, :], axis=2), axis=1)
    # drop modes that own no point, keep the order of first appearance (deterministic output)
    used = []
    for lab in labels:
        if lab not in used:
            used.append(int(lab))
    remap = {old: new for new, old in enumerate(used)}
    return centres[used], np.array([remap[int(lab)] for lab in labels])
