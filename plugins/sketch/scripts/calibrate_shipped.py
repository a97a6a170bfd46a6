"""Fit the calibration of a models file (default: the shipped weights) on held-out drawings:
per object type, the temperature of its classifier's softmax and the "not sure, redraw"
threshold (grammarkit_sketch/calibration.py), written into the type's metrics. The network
weights are not changed (no retraining).

    python plugins/sketch/scripts/calibrate_shipped.py -o calibrated.sketch.pt [--n 8]
    python plugins/sketch/scripts/calibrate_shipped.py -o plugins/sketch/grammarkit_sketch/weights/library.sketch.pt --replace-shipped

The held-out drawings: `--n` per snippet in the training pens (style "sketchy") and as many
in the training pens with the page turned and the view off by up to 5 degrees and strokes
broken off (style "augmented"), seeds 5000 and 5001 (training uses seed 0, the benchmark's
test sets 1000+, and the benchmark's robustness pens, thick, overdrawn and jitter, are never
used here). Same models, n and seeds give the same numbers.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SHIPPED = ROOT / "plugins" / "sketch" / "grammarkit_sketch" / "weights" / "library.sketch.pt"
SETS = (("sketchy", 5000), ("augmented", 5001))


def say(message: str, start: float = time.monotonic()) -> None:
    print(f"[{time.monotonic() - start:7.1f} s] {message}", flush=True)


def class_index(classes: list[list[str]], name: str) -> int:
    return next(i for i, group in enumerate(classes) if name in group)


def held_out_logits(rec, object_type: str, n: int, sets=SETS, workers: int = 1):
    """(logits (N, C), labels (N,)) of the type's classifier on the held-out drawings."""
    import numpy as np

    from grammarkit_sketch.dataset import generate

    tm = rec.models.types[object_type]
    logits, labels = [], []
    for style, seed in sets:
        data = generate(rec.library, tm.stage, n, seed=seed, style=style, workers=workers)
        for i in range(len(data)):
            logits.append(rec.logits(tm, data.inputs(i)))
            labels.append(class_index(tm.classes, data.snippets[int(data.snippet[i])]))
    return np.array(logits), np.array(labels, dtype=np.int64)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True,
                    help="models file to write (never defaults to the shipped weights)")
    ap.add_argument("--replace-shipped", action="store_true",
                    help="allow -o to name the shipped weights file")
    ap.add_argument("--models", type=Path, default=None, help="models file to calibrate (default: shipped)")
    ap.add_argument("--n", type=int, default=8, help="held-out drawings per snippet and set")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    if args.output.resolve() == SHIPPED.resolve() and not args.replace_shipped:
        ap.error(f"{args.output} is the shipped weights file; pass --replace-shipped to write it")

    from grammarkit_sketch.calibration import (expected_calibration_error, fit_temperature,
                                               redraw_threshold, softmax)
    from grammarkit_sketch.models import save_models
    from grammarkit_sketch.recognizer import get_recognizer

    rec = get_recognizer(args.models)
    for t, tm in rec.models.types.items():
        logits, labels = held_out_logits(rec, t, args.n, workers=args.workers)
        before = softmax(logits, 1.0)
        temperature = fit_temperature(logits, labels)
        after = softmax(logits, temperature)
        conf, ok = after.max(axis=1), after.argmax(axis=1) == labels
        threshold = redraw_threshold(conf, ok)
        tm.metrics["temperature"] = round(temperature, 4)
        tm.metrics["redraw_below"] = round(threshold, 4)
        tm.metrics["calibration"] = {
            "drawings": int(len(labels)), "sets": [list(s) for s in SETS], "n": args.n,
            "accuracy": round(float(ok.mean()), 4),
            "ece_before": round(expected_calibration_error(before.max(1), before.argmax(1) == labels), 4),
            "ece_after": round(expected_calibration_error(conf, ok), 4),
            "redraw_share": round(float((conf < threshold).mean()), 4)}
        say(f"{t}: T = {temperature:.3f}, redraw below {threshold:.3f}; {tm.metrics['calibration']}")
    save_models(rec.models, args.output)
    say(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
