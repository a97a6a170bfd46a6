"""Reproduce the shipped weights (grammarkit_sketch/weights/library.sketch.pt) for
grammars/library.grammar: the same as

    grammarkit train sketch --library grammars/library.grammar \
        -o plugins/sketch/grammarkit_sketch/weights/library.sketch.pt \
        --samples SAMPLES --classifier-epochs CLASSIFIER_EPOCHS --regressor-epochs REGRESSOR_EPOCHS --seed 0

with the settings below. Same library, settings, seed and torch build give the same file.
Rendered training sets are cached (GRAMMARKIT_SKETCH_CACHE, default ~/.cache/grammarkit/sketch),
so a second run only trains.

    python plugins/sketch/scripts/train_shipped.py [--jobs 6] [--workers 1] [--threads 1]

The settings: 2,000 samples per snippet and 40 regressor epochs bring the regressors' validation
RMSE to 0.01-0.12 (500 and 15: 0.03-0.18); 42 minutes with `--jobs 2` on the 2-core machine
(docs/sketch.md, "Training your own").

`--jobs N` trains the object types in N processes at once (`train sketch --types T` each,
then one file): a type's training depends only on the type, the settings and the seed, so the
result equals a single run. One torch thread per process: on a loaded machine a second torch
thread mostly spins (measured: 5x the CPU time per sample).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
LIBRARY = ROOT / "grammars" / "library.grammar"
SAMPLES = 2000
CLASSIFIER_EPOCHS = 14
REGRESSOR_EPOCHS = 40


def train_args(output: Path, workers: int, threads: int, types: str | None = None,
               plain: bool = False) -> list[str]:
    args = ["train", "sketch", "--library", str(LIBRARY), "-o", str(output), "--samples", str(SAMPLES),
            "--classifier-epochs", str(CLASSIFIER_EPOCHS), "--regressor-epochs", str(REGRESSOR_EPOCHS),
            "--seed", "0", "--workers", str(workers), "--threads", str(threads)]
    if plain:
        args += ["--style", "plain", "--classifiers-only"]
    return args + (["--types", types] if types else [])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=1, help="object types trained at once (processes)")
    ap.add_argument("--workers", type=int, default=1, help="rendering processes per job")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per job")
    ap.add_argument("--plain", action="store_true",
                    help="the paper's Table 3 comparison instead: classifiers only, trained on exact line "
                         "drawings with the same settings (for benchmarks/bench_sketch.py --plain-models)")
    ap.add_argument("-o", "--output", type=Path,
                    default=ROOT / "plugins" / "sketch" / "grammarkit_sketch" / "weights" / "library.sketch.pt")
    args = ap.parse_args()
    if args.jobs <= 1:  # the command itself (through the CLI: plugins use the public API only)
        cmd = [sys.executable, "-m", "grammarkit", *train_args(args.output, args.workers, args.threads,
                                                                plain=args.plain)]
        return subprocess.run(cmd).returncode

    from grammarkit_sketch.library import load_library
    from grammarkit_sketch.models import load_models, merge_models, save_models

    types = list(load_library(LIBRARY).types)
    with tempfile.TemporaryDirectory() as tmp:
        parts = {t: Path(tmp) / f"{t}.pt" for t in types}

        def run(t: str) -> int:
            cmd = [sys.executable, "-m", "grammarkit", *train_args(parts[t], args.workers, args.threads, t, args.plain)]
            done = subprocess.run(cmd, capture_output=True, text=True)
            print(f"--- {t} (exit {done.returncode})\n{done.stdout}{done.stderr[-2000:]}", flush=True)
            return done.returncode

        with ThreadPoolExecutor(args.jobs) as pool:
            codes = list(pool.map(run, types))
        if any(codes):
            print("some object types failed to train; nothing written", file=sys.stderr)
            return 1
        merged = merge_models([load_models(parts[t]) for t in types])
        save_models(merged, args.output)
    print(f"wrote {args.output} ({args.output.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
