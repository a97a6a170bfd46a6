"""Reproduce the shipped weights (grammarkit_sketch/weights/library.sketch.pt) for
grammars/library.grammar: the same command as

    grammarkit train sketch --library grammars/library.grammar \
        -o plugins/sketch/grammarkit_sketch/weights/library.sketch.pt \
        --samples SAMPLES --classifier-epochs CLASSIFIER_EPOCHS --regressor-epochs REGRESSOR_EPOCHS --seed 0

with the settings below. Same library, settings, seed and torch build give the same file.
Rendered training sets are cached (GRAMMARKIT_SKETCH_CACHE, default ~/.cache/grammarkit/sketch),
so a second run only trains.

    python plugins/sketch/scripts/train_shipped.py [--workers 2] [--threads 1]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = 1000
CLASSIFIER_EPOCHS = 8
REGRESSOR_EPOCHS = 35


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("-o", "--output", type=Path,
                    default=ROOT / "plugins" / "sketch" / "grammarkit_sketch" / "weights" / "library.sketch.pt")
    args = ap.parse_args()
    from grammarkit.cli import main as cli

    return cli(["train", "sketch", "--library", str(ROOT / "grammars" / "library.grammar"),
                "-o", str(args.output), "--samples", str(SAMPLES),
                "--classifier-epochs", str(CLASSIFIER_EPOCHS), "--regressor-epochs", str(REGRESSOR_EPOCHS),
                "--seed", "0", "--workers", str(args.workers), "--threads", str(args.threads)],
               standalone_mode=False) or 0


if __name__ == "__main__":
    sys.exit(main())
