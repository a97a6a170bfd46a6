"""Fine-tune the classifiers of a models file (default: the shipped weights) on renders with
issue 30's perturbations (style "augmented": the page turned and the view off by up to 6
degrees, 40% of the drawings with 5-30% of the ink cut out), starting from their trained
weights, reading the drawing's centre lines (strokes.py: one line width for every pen);
with `--regressors`, the parameter regressors too, on the same renders (cached: the second
pass renders nothing). Then calibrate with calibrate_shipped.py.

    python plugins/sketch/scripts/finetune_shipped.py -o tuned.sketch.pt [--samples 120] [--epochs 6]
        [--lr 1e-3] [--seed 0] [--classifier-input centre-lines|as-drawn]
        [--regressors [--regressor-epochs 6 --regressor-lr 3e-4 --regressor-batch 8]]
        [--no-classifiers]

The shipped weights (issue 30) are the previous shipped file (git: the weights before commit
"sketch: ship centre-line classifiers", i.e. train_shipped.py's step 1 with its classifiers
fine-tuned on 40 augmented renders per snippet) put through this script with its defaults
and `--regressors`, then `calibrate_shipped.py --n 6`:

    python plugins/sketch/scripts/finetune_shipped.py --models OLD.sketch.pt -o tuned.pt --regressors
    python plugins/sketch/scripts/calibrate_shipped.py --models tuned.pt -o library.sketch.pt --n 6

with three networks then put back to the previous file's (tests/sketch/test_session.py
failed with the tuned ones): Roof's and Window's classifiers (with their calibration) and
Facade's regressors (docs/sketch.md, benchmark section 6).

About 12 minutes of rendering (2,760 augmented drawings) and 8 minutes of training (six
classifiers, 23 regressors, one torch thread) on the shared 2-core machine at a load average
of about 9; same models, settings and seed give the same file (a type's tuning depends only
on the type, so `--types` runs in parallel processes merge to the same weights). `-o` never
defaults to the shipped file (`--replace-shipped` to write it).
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
    ap.add_argument("--samples", type=int, default=120, help="augmented renders per snippet")
    ap.add_argument("--epochs", type=int, default=6)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--types", default=None, help="comma-separated object types (default: all)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--classifier-input", default="centre-lines", choices=("as-drawn", "centre-lines"),
                    help="what the tuned classifiers read (the trained weights are the starting point; "
                         "as-drawn: the paper's input)")
    ap.add_argument("--regressors", action="store_true", help="fine-tune the regressors as well")
    ap.add_argument("--no-classifiers", action="store_true", help="keep the classifiers as they are")
    ap.add_argument("--regressor-epochs", type=int, default=6)
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
            rec.models.types[key] = fine_tune_classifier(rec.library, rec.models.types[key], cfg, reporter,
                                                         args.classifier_input)
            reporter.say(f"{t}: {rec.models.types[key].metrics.get('fine_tune')}")
        if args.regressors:
            rec.models.types[key] = fine_tune_regressors(rec.library, rec.models.types[key], reg_cfg, reporter)
            reporter.say(f"{t}: {rec.models.types[key].metrics.get('fine_tune_regressors')}")
    if not args.no_classifiers:
        rec.models.meta["fine_tune"] = {"samples": args.samples, "epochs": args.epochs, "lr": args.lr,
                                        "seed": args.seed, "style": "augmented", "types": chosen,
                                        "classifier_input": args.classifier_input}
    if args.regressors:
        rec.models.meta["fine_tune_regressors"] = {
            "samples": args.samples, "epochs": args.regressor_epochs, "lr": args.regressor_lr,
            "batch": args.regressor_batch, "seed": args.seed, "style": "augmented", "types": chosen}
    save_models(rec.models, args.output)
    reporter.say(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
