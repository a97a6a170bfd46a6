"""Calibrated snippet probabilities and the "not sure, redraw" answer.

The classifiers' softmax is over-confident on drawings unlike their training set (issue 30:
wrong answers at 0.98). Temperature scaling (Guo et al. 2017, "On Calibration of Modern
Neural Networks") divides the logits by one number T per object type, fitted on held-out
drawings by minimising the negative log-likelihood; it changes no ranking, so accuracy stays
the same, only the probabilities move. A recognition whose calibrated top-1 probability is
below the type's redraw threshold is answered "not sure, redraw".

Both numbers live in a type's `metrics` in the models file ("temperature", "redraw_below"),
written by plugins/sketch/scripts/calibrate_shipped.py; a file without them means T = 1 and
no redraw answer (the networks' raw softmax, as trained).

Expected calibration error (ECE): the top-1 probabilities are put in 10 equal-width bins over
[0, 1]; ECE = sum over bins of (share of drawings in the bin) x |accuracy - mean confidence|.
"""
from __future__ import annotations

import numpy as np

__all__ = ["softmax", "fit_temperature", "expected_calibration_error", "redraw_threshold",
           "reliability"]

T_RANGE = (1.0, 20.0)  # never sharpen: a held-out set the network gets all right would drive T to 0


def softmax(logits: np.ndarray, temperature: float = 1.0) -> np.ndarray:
    z = np.asarray(logits, dtype=np.float64) / float(temperature)
    z = z - z.max(axis=-1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


def _nll(logits: np.ndarray, labels: np.ndarray, temperature: float) -> float:
    z = np.asarray(logits, dtype=np.float64) / temperature
    z = z - z.max(axis=1, keepdims=True)
    log_p = z - np.log(np.exp(z).sum(axis=1, keepdims=True))
    return float(-log_p[np.arange(len(labels)), labels].mean())


def fit_temperature(logits: np.ndarray, labels: np.ndarray) -> float:
    """The T in T_RANGE minimising the mean negative log-likelihood of `labels` (N,) under
    softmax(logits (N, C) / T). Bounded scalar search over log T (the NLL is convex in 1/T)."""
    from scipy.optimize import minimize_scalar

    logits = np.asarray(logits, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    if logits.ndim != 2 or len(logits) != len(labels) or len(labels) == 0:
        raise ValueError("fit_temperature needs (N, C) logits and N labels, N > 0")
    if logits.shape[1] < 2:
        return 1.0
    lo, hi = np.log(T_RANGE[0]), np.log(T_RANGE[1])
    res = minimize_scalar(lambda s: _nll(logits, labels, float(np.exp(s))), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-4})
    return float(np.exp(res.x))


def reliability(confidence: np.ndarray, correct: np.ndarray, bins: int = 10) -> list[dict]:
    """Per equal-width bin of the top-1 probability: count, mean confidence, accuracy."""
    conf = np.asarray(confidence, dtype=np.float64)
    ok = np.asarray(correct, dtype=bool)
    index = np.minimum((conf * bins).astype(int), bins - 1)
    out = []
    for b in range(bins):
        sel = index == b
        out.append({"lo": b / bins, "hi": (b + 1) / bins, "n": int(sel.sum()),
                    "confidence": float(conf[sel].mean()) if sel.any() else float("nan"),
                    "accuracy": float(ok[sel].mean()) if sel.any() else float("nan")})
    return out


def expected_calibration_error(confidence: np.ndarray, correct: np.ndarray, bins: int = 10) -> float:
    """ECE with `bins` equal-width bins over the top-1 probability (see module)."""
    n = len(np.asarray(confidence))
    if n == 0:
        return float("nan")
    return float(sum(b["n"] / n * abs(b["accuracy"] - b["confidence"])
                     for b in reliability(confidence, correct, bins) if b["n"]))


def redraw_threshold(confidence: np.ndarray, correct: np.ndarray, max_share: float = 0.03,
                     ceiling: float = 0.6) -> float:
    """The redraw threshold: the calibrated top-1 probability below which an answer is more
    often wrong than right on the held-out drawings (the largest such bin edge up to
    `ceiling`), lowered so that at most `max_share` of those drawings get a redraw answer.
    0.0 when no answer is below it (never redraw)."""
    conf = np.sort(np.asarray(confidence, dtype=np.float64))
    ok = np.asarray(correct, dtype=bool)[np.argsort(np.asarray(confidence), kind="stable")]
    if len(conf) == 0:
        return 0.0
    threshold = 0.0
    for t in np.arange(0.05, ceiling + 1e-9, 0.05):
        below = conf < t
        if below.any() and ok[below].mean() < 0.5:
            threshold = round(float(t), 2)
    # at most max_share of the drawings below it
    k = int(np.floor(max_share * len(conf)))
    cap = float(conf[k]) if k < len(conf) else 1.0
    return float(min(threshold, cap))
