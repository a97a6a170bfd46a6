"""Train a whole models file for grammars/library.grammar (the base of the shipped weights,
grammarkit_sketch/weights/library.sketch.pt: their regressors started as step 1's; the
shipped file is then tuned by finetune_shipped.py and calibrate_shipped.py, see their
docstrings), in three steps, each a public command:

1. regressors: `grammarkit train sketch --library grammars/library.grammar --samples SAMPLES
   --classifier-epochs CLASSIFIER_EPOCHS --regressor-epochs REGRESSOR_EPOCHS --seed 0`
   (the paper's sketchy training drawings; its parameter regressors are kept);
2. classifiers: `grammarkit train sketch --classifiers-only --style augmented --samples
   CLS_SAMPLES --classifier-epochs CLS_EPOCHS --classifier-input CLS_INPUT --seed 0` (issue
   30: trained from scratch on drawings with the page turned and the view off by up to 6
   degrees and, in 40% of them, 5-30% of the ink cut out; the types in CLS_INPUT read the
   drawing's centre lines, strokes.py), then grafted onto the regressors of step 1
   (`models.graft_regressors`);
3. calibration: `calibrate_shipped.py --n CALIBRATE_N` (temperature and redraw threshold per
   type, fitted on held-out drawings of the training pens).

Same library, settings, seed and torch build give the same file. Rendered training sets are
cached (GRAMMARKIT_SKETCH_CACHE, default ~/.cache/grammarkit/sketch), so a second run only
trains.

    python plugins/sketch/scripts/train_shipped.py -o library.sketch.pt [--jobs 2] [--quick]
        [--regressors-from FILE]

`-o` is required and never defaults to the shipped file: writing over
plugins/sketch/grammarkit_sketch/weights/library.sketch.pt needs `--replace-shipped` as well.
`--regressors-from FILE` skips step 1 and takes the regressors of FILE (the shipped file's
are step 1's output: the run that takes minutes instead of most of an hour). `--quick` trains
with QUICK's small settings (to check the pipeline, not to ship); `--samples`,
`--classifier-epochs`, `--regressor-epochs`, `--cls-samples`, `--cls-epochs` override either
setting. Progress: one line per object type started and finished, with the elapsed time, and
the training command's own output line by line (prefixed with the step and type).

Time on the 2-core machine: step 1 took 42 minutes with `--jobs 2` (2,000 samples, 40
regressor epochs: regressor validation RMSE 0.01-0.12); steps 2 and 3 took TIME_CLASSIFIERS
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
CALIBRATE = Path(__file__).with_name("calibrate_shipped.py")
# step 1: the regressors
SAMPLES = 2000
CLASSIFIER_EPOCHS = 14
REGRESSOR_EPOCHS = 40
# step 2: the classifiers
CLS_SAMPLES = 300
CLS_EPOCHS = 12
CLS_INPUT = "centre-lines"
CALIBRATE_N = 6
TIME_CLASSIFIERS = "see docs/sketch.md"
QUICK = {"samples": 200, "classifier_epochs": 3, "regressor_epochs": 3, "cls_samples": 40, "cls_epochs": 2}

_print_lock = threading.Lock()
_start = time.monotonic()


def say(message: str) -> None:
    """One progress line with the elapsed time (lines of parallel jobs never interleave)."""
    with _print_lock:
        print(f"[{time.monotonic() - _start:7.1f} s] {message}", flush=True)


def train_args(output: Path, workers: int, threads: int, settings: dict, types: str | None = None,
               plain: bool = False, classifiers: bool = False) -> list[str]:
    """The `grammarkit train sketch` arguments of step 1 (or, `classifiers`, of step 2; `plain`:
    the Table 3 comparison, classifiers only on exact drawings with step 1's settings)."""
    samples = settings["cls_samples"] if classifiers else settings["samples"]
    epochs = settings["cls_epochs"] if classifiers else settings["classifier_epochs"]
    args = ["train", "sketch", "--library", str(LIBRARY), "-o", str(output),
            "--samples", str(samples), "--classifier-epochs", str(epochs),
            "--regressor-epochs", str(settings["regressor_epochs"]),
            "--seed", "0", "--workers", str(workers), "--threads", str(threads)]
    if plain:
        args += ["--style", "plain", "--classifiers-only"]
    elif classifiers:
        args += ["--style", "augmented", "--classifiers-only", "--classifier-input", CLS_INPUT]
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
    ap.add_argument("--cls-samples", type=int, default=None, help="step 2's renders per snippet")
    ap.add_argument("--cls-epochs", type=int, default=None, help="step 2's classifier epochs")
    ap.add_argument("--regressors-from", type=Path, default=None,
                    help="skip step 1: take the regressors of this models file (e.g. the shipped one)")
    ap.add_argument("--no-calibrate", action="store_true", help="skip step 3")
    ap.add_argument("--jobs", type=int, default=1, help="object types trained at once (processes)")
    ap.add_argument("--workers", type=int, default=1, help="rendering processes per job")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per job")
    ap.add_argument("--plain", action="store_true",
                    help="the paper's Table 3 comparison instead: classifiers only, trained on exact line "
                         "drawings with step 1's settings (for benchmarks/bench_sketch.py --plain-models)")
    args = ap.parse_args(argv)
    if args.output.resolve() == SHIPPED.resolve() and not args.replace_shipped:
        ap.error(f"{args.output} is the shipped weights file; pass --replace-shipped to write it")
    if args.regressors_from is not None and not args.regressors_from.is_file():
        ap.error(f"--regressors-from {args.regressors_from}: no such models file")
    return args


def settings_of(args: argparse.Namespace) -> dict:
    base = dict(QUICK) if args.quick else {"samples": SAMPLES, "classifier_epochs": CLASSIFIER_EPOCHS,
                                           "regressor_epochs": REGRESSOR_EPOCHS,
                                           "cls_samples": CLS_SAMPLES, "cls_epochs": CLS_EPOCHS}
    for key in base:
        if getattr(args, key, None) is not None:
            base[key] = getattr(args, key)
    return base


def train_step(args: argparse.Namespace, settings: dict, output: Path, step: str, **kw: bool) -> int:
    """One `train sketch` run over every type (in `--jobs` processes, merged) into `output`."""
    if args.jobs <= 1:  # the command itself (through the CLI: plugins use the public API only)
        cmd = [sys.executable, "-m", "grammarkit",
               *train_args(output, args.workers, args.threads, settings, **kw)]
        return run_streaming(cmd, f"{step}, all types")

    from grammarkit_sketch.library import load_library
    from grammarkit_sketch.models import load_models, merge_models, save_models

    types = list(load_library(LIBRARY).types)
    with tempfile.TemporaryDirectory() as tmp:
        parts = {t: Path(tmp) / f"{t}.pt" for t in types}

        def run(t: str) -> int:
            cmd = [sys.executable, "-m", "grammarkit",
                   *train_args(parts[t], args.workers, args.threads, settings, t, **kw)]
            return run_streaming(cmd, f"{step}, {t}")

        with ThreadPoolExecutor(args.jobs) as pool:
            codes = list(pool.map(run, types))
        if any(codes):
            print(f"{step}: some object types failed to train; nothing written", file=sys.stderr)
            return 1
        save_models(merge_models([load_models(parts[t]) for t in types]), output)
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    settings = settings_of(args)
    say(f"training the recognizer of {LIBRARY.name} with {settings} into {args.output}")
    if args.plain:
        code = train_step(args, settings, args.output, "plain classifiers", plain=True)
        if not code:
            say(f"wrote {args.output}")
        return code
    from grammarkit_sketch.models import graft_regressors, load_models, save_models

    with tempfile.TemporaryDirectory() as tmp:
        base = args.regressors_from
        if base is None:
            base = Path(tmp) / "regressors.pt"
            if train_step(args, settings, base, "step 1 (regressors)"):
                return 1
        else:
            say(f"step 1 (regressors): taken from {base}")
        classifiers = Path(tmp) / "classifiers.pt"
        if train_step(args, settings, classifiers, "step 2 (classifiers)", classifiers=True):
            return 1
        grafted = Path(tmp) / "grafted.pt"
        save_models(graft_regressors(load_models(classifiers), load_models(base)), grafted)
        if args.no_calibrate:
            save_models(load_models(grafted), args.output)
        else:
            cmd = [sys.executable, str(CALIBRATE), "--models", str(grafted), "-o", str(args.output),
                   "--n", str(CALIBRATE_N if not args.quick else 1)]
            if args.output.resolve() == SHIPPED.resolve():
                cmd.append("--replace-shipped")
            if run_streaming(cmd, "step 3 (calibration)"):
                return 1
    say(f"wrote {args.output} ({args.output.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
