"""Fine-tune the classifiers of a models file (default: the shipped weights) on renders with
issue 30's perturbations (style "augmented": the page turned and the view off by up to 5
degrees, 40% of the drawings with 5-25% of the ink cut out), starting from their trained
weights; with `--regressors`, the parameter regressors too, on the same renders (cached: the
second pass renders nothing). Then calibrate with calibrate_shipped.py.

    python plugins/sketch/scripts/finetune_shipped.py -o tuned.sketch.pt [--samples 40] [--epochs 4]
        [--regressors [--regressor-epochs 8 --regressor-lr 3e-4 --regressor-batch 8]]
        [--no-classifiers]

The shipped weights: train_shipped.py, then this script with its defaults and `--regressors`
on them, then calibrate_shipped.py (docs/sketch.md, "Calibration and robustness").

A run of the defaults took ~12 minutes on the loaded 2-core machine (rendering dominates);
same models, settings and seed give the same file. `-o` never defaults to the shipped file
(`--replace-shipped` to write it).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SHIPPED = ROOT / "plugins" / "sketch" / "grammarkit_sketch" / "weights" / "library.sketch.pt"


class LineReporter:
    """Progress as plain lines (one per task and every few steps), for logs."""

    def __init__(self) -> None:
        self.start = time.monotonic()

    def say(self, message: str) -> None:
        print(f"[{time.monotonic() - self.start:7.1f} s] {message}", flush=True)

    def task(self, description: str, total: int):  # noqa: ANN201
        self.say(f"{description} (0 of {total})")
        done = [0]

        def advance(n: int = 1, info: str = "") -> None:
            done[0] += n
            if done[0] == total or done[0] % max(1, total // 5) < n:
                self.say(f"{description}: {done[0]} of {total} {info}")
        return advance

    def note(self, message: str) -> None:
        self.say(f"note: {message}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True)
    ap.add_argument("--replace-shipped", action="store_true")
    ap.add_argument("--models", type=Path, default=None)
    ap.add_argument("--samples", type=int, default=40, help="augmented renders per snippet")
    ap.add_argument("--epochs", type=int, default=4)
    ap.add_argument("--lr", type=float, default=5e-4)
    ap.add_argument("--types", default=None, help="comma-separated object types (default: all)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--regressors", action="store_true", help="fine-tune the regressors as well")
    ap.add_argument("--no-classifiers", action="store_true", help="keep the classifiers as they are")
    ap.add_argument("--regressor-epochs", type=int, default=8)
    ap.add_argument("--regressor-lr", type=float, default=3e-4)
    ap.add_argument("--regressor-batch", type=int, default=8)
    args = ap.parse_args(argv)
    if args.output.resolve() == SHIPPED.resolve() and not args.replace_shipped:
        ap.error(f"{args.output} is the shipped weights file; pass --replace-shipped to write it")
    import torch

    from grammarkit_sketch.models import save_models
    from grammarkit_sketch.recognizer import get_recognizer
    from grammarkit_sketch.training import TrainConfig, fine_tune_classifier, fine_tune_regressors

    torch.set_num_threads(1)
    rec = get_recognizer(args.models)
    reporter = LineReporter()
    cfg = TrainConfig(samples=args.samples, classifier_epochs=args.epochs, lr=args.lr,
                      style="augmented", seed=args.seed, workers=args.workers)
    reg_cfg = TrainConfig(samples=args.samples, regressor_epochs=args.regressor_epochs,
                          lr=args.regressor_lr, batch=args.regressor_batch, style="augmented",
                          seed=args.seed, workers=args.workers)
    chosen = [t.strip() for t in args.types.split(",")] if args.types else list(rec.models.types)
    for t in chosen:
        key = rec.library.check_type(t)
        if not args.no_classifiers:
            rec.models.types[key] = fine_tune_classifier(rec.library, rec.models.types[key], cfg, reporter)
            reporter.say(f"{t}: {rec.models.types[key].metrics.get('fine_tune')}")
        if args.regressors:
            rec.models.types[key] = fine_tune_regressors(rec.library, rec.models.types[key], reg_cfg, reporter)
            reporter.say(f"{t}: {rec.models.types[key].metrics.get('fine_tune_regressors')}")
    if not args.no_classifiers:
        rec.models.meta["fine_tune"] = {"samples": args.samples, "epochs": args.epochs, "lr": args.lr,
                                        "seed": args.seed, "style": "augmented", "types": chosen}
    if args.regressors:
        rec.models.meta["fine_tune_regressors"] = {
            "samples": args.samples, "epochs": args.regressor_epochs, "lr": args.regressor_lr,
            "batch": args.regressor_batch, "seed": args.seed, "style": "augmented", "types": chosen}
    save_models(rec.models, args.output)
    reporter.say(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
