"""Reproduce the shipped weights (grammarkit_sketch/weights/library.sketch.pt) for
grammars/library.grammar: the same as

    grammarkit train sketch --library grammars/library.grammar \
        -o plugins/sketch/grammarkit_sketch/weights/library.sketch.pt \
        --samples SAMPLES --classifier-epochs CLASSIFIER_EPOCHS --regressor-epochs REGRESSOR_EPOCHS --seed 0

with the settings below. Same library, settings, seed and torch build give the same file.
Rendered training sets are cached (GRAMMARKIT_SKETCH_CACHE, default ~/.cache/grammarkit/sketch),
so a second run only trains.

    python plugins/sketch/scripts/train_shipped.py -o library.sketch.pt [--jobs 2] [--quick]

`-o` is required and never defaults to the shipped file: writing over
plugins/sketch/grammarkit_sketch/weights/library.sketch.pt needs `--replace-shipped` as well.
`--quick` trains with 200 samples per snippet and 3 epochs (a few minutes: to check the
pipeline, not to ship); `--samples`, `--classifier-epochs`, `--regressor-epochs` override
either setting. Progress: one line per object type started and finished, with the elapsed
time, and the training command's own output line by line (prefixed with the type).

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
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
LIBRARY = ROOT / "grammars" / "library.grammar"
SHIPPED = ROOT / "plugins" / "sketch" / "grammarkit_sketch" / "weights" / "library.sketch.pt"
SAMPLES = 2000
CLASSIFIER_EPOCHS = 14
REGRESSOR_EPOCHS = 40
QUICK = {"samples": 200, "classifier_epochs": 3, "regressor_epochs": 3}

_print_lock = threading.Lock()
_start = time.monotonic()


def say(message: str) -> None:
    """One progress line with the elapsed time (lines of parallel jobs never interleave)."""
    with _print_lock:
        print(f"[{time.monotonic() - _start:7.1f} s] {message}", flush=True)


def train_args(output: Path, workers: int, threads: int, settings: dict, types: str | None = None,
               plain: bool = False) -> list[str]:
    args = ["train", "sketch", "--library", str(LIBRARY), "-o", str(output),
            "--samples", str(settings["samples"]),
            "--classifier-epochs", str(settings["classifier_epochs"]),
            "--regressor-epochs", str(settings["regressor_epochs"]),
            "--seed", "0", "--workers", str(workers), "--threads", str(threads)]
    if plain:
        args += ["--style", "plain", "--classifiers-only"]
    return args + (["--types", types] if types else [])


def run_streaming(cmd: list[str], label: str) -> int:
    """Run `cmd`, printing its output line by line as it comes (prefixed with `label`)."""
    say(f"{label}: started")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            bufsize=1)
    assert proc.stdout is not None
    for line in proc.stdout:
        line = line.rstrip()
        if line:
            say(f"{label}: {line}")
    code = proc.wait()
    say(f"{label}: finished (exit {code})")
    return code


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True,
                    help="models file to write (never defaults to the shipped weights)")
    ap.add_argument("--replace-shipped", action="store_true",
                    help="allow -o to name the shipped weights file")
    ap.add_argument("--quick", action="store_true",
                    help=f"a small run: {QUICK['samples']} samples per snippet, "
                         f"{QUICK['classifier_epochs']} epochs each (to check the pipeline)")
    ap.add_argument("--samples", type=int, default=None)
    ap.add_argument("--classifier-epochs", type=int, default=None)
    ap.add_argument("--regressor-epochs", type=int, default=None)
    ap.add_argument("--jobs", type=int, default=1, help="object types trained at once (processes)")
    ap.add_argument("--workers", type=int, default=1, help="rendering processes per job")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per job")
    ap.add_argument("--plain", action="store_true",
                    help="the paper's Table 3 comparison instead: classifiers only, trained on exact line "
                         "drawings with the same settings (for benchmarks/bench_sketch.py --plain-models)")
    args = ap.parse_args(argv)
    if args.output.resolve() == SHIPPED.resolve() and not args.replace_shipped:
        ap.error(f"{args.output} is the shipped weights file; pass --replace-shipped to write it")
    return args


def settings_of(args: argparse.Namespace) -> dict:
    base = dict(QUICK) if args.quick else {"samples": SAMPLES, "classifier_epochs": CLASSIFIER_EPOCHS,
                                           "regressor_epochs": REGRESSOR_EPOCHS}
    for key in base:
        if getattr(args, key) is not None:
            base[key] = getattr(args, key)
    return base


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    settings = settings_of(args)
    say(f"training the recognizer of {LIBRARY.name} with {settings} into {args.output}")
    if args.jobs <= 1:  # the command itself (through the CLI: plugins use the public API only)
        cmd = [sys.executable, "-m", "grammarkit",
               *train_args(args.output, args.workers, args.threads, settings, plain=args.plain)]
        return run_streaming(cmd, "all types")

    from grammarkit_sketch.library import load_library
    from grammarkit_sketch.models import load_models, merge_models, save_models

    types = list(load_library(LIBRARY).types)
    with tempfile.TemporaryDirectory() as tmp:
        parts = {t: Path(tmp) / f"{t}.pt" for t in types}

        def run(t: str) -> int:
            cmd = [sys.executable, "-m", "grammarkit",
                   *train_args(parts[t], args.workers, args.threads, settings, t, args.plain)]
            return run_streaming(cmd, t)

        with ThreadPoolExecutor(args.jobs) as pool:
            codes = list(pool.map(run, types))
        if any(codes):
            print("some object types failed to train; nothing written", file=sys.stderr)
            return 1
        merged = merge_models([load_models(parts[t]) for t in types])
        save_models(merged, args.output)
    say(f"wrote {args.output} ({args.output.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
