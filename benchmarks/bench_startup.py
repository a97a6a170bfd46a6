"""Start-up of the `grammarkit` command, measured as whole processes (issue 8).

    python benchmarks/bench_startup.py [--runs 7] [--baseline-src PATH] [--explain]

Each row is the median wall time over --runs of a fresh process, against the baseline measured
in the same run: a bare Python start (`python -c pass`) of the same interpreter. Rows:

- `grammarkit --version`                           target <= 3x bare Python
- `grammarkit check grammars/paris.grammar`
- `grammarkit derive grammars/paris.grammar -o X.glb`  (one building)  target <= 1.0 s
- `grammarkit.derive("grammars/paris.grammar")` in a fresh Python, no file written (the
  difference to the row above is mostly the exporter's imports: trimesh and scipy)

`--baseline-src PATH` also times the same commands with another source tree first on
PYTHONPATH (e.g. a checkout of main before a change), interleaved run by run so that load
changes on the machine affect both alike. `--explain` prints where the one-building derive
spends its import time (`python -X importtime`, the largest top-level imports).

The Lark parser tables are cached on disk (grammarkit.dsl.parser.cache_dir()); the first run
of a new grammarkit version builds them, so the first of the --runs is a warm-up and dropped.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PARIS = ROOT / "grammars" / "paris.grammar"


def _cli(*args: str) -> list[str]:
    # the console script's own entry: `grammarkit ...` is `python -c "...main()"` plus the
    # wrapper script, whose cost is the same for every row
    return [sys.executable, "-c", "import sys; from grammarkit.cli import main; sys.exit(main())", *args]


def commands(out_dir: Path) -> list[tuple[str, list[str], str]]:
    return [
        ("python -c pass (baseline)", [sys.executable, "-c", "pass"], ""),
        ("grammarkit --version", _cli("--version"), "<= 3x"),
        ("grammarkit check paris.grammar", _cli("check", str(PARIS)), ""),
        ("grammarkit derive paris.grammar (1 building)",
         _cli("derive", str(PARIS), "-o", str(out_dir / "paris.glb")), "<= 1.0 s"),
        # the same derivation without writing a file: what the exporter's imports add
        ("python: grammarkit.derive(paris), no file",
         [sys.executable, "-c", f"import grammarkit; grammarkit.derive({str(PARIS)!r})"], ""),
    ]


def _run(cmd: list[str], env: dict, cwd: Path) -> float:
    # cwd is a neutral folder: with `python -c`, the working directory comes first on sys.path
    # and would shadow --baseline-src if it were a source tree
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"command failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr[-2000:]}")
    return dt


def _env(src: Path | None) -> dict:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(src), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def explain(out_dir: Path, top: int = 12) -> None:
    cmd = [sys.executable, "-X", "importtime", *_cli("derive", str(PARIS), "-o", str(out_dir / "x.glb"))[1:]]
    r = subprocess.run(cmd, cwd=out_dir, capture_output=True, text=True)
    rows = []
    for line in r.stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        _, cumulative, name = line.split("|")
        if name.startswith(" ") and not name.startswith("  "):  # imported at top level
            try:
                rows.append((int(cumulative), name.strip()))
            except ValueError:
                continue
    print(f"\nlargest top-level imports of the one-building derive (ms, cumulative):")
    for us, name in sorted(rows, reverse=True)[:top]:
        print(f"  {us / 1000:8.1f}  {name}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--baseline-src", type=Path, default=None,
                    help="another source tree to time the same commands with (PYTHONPATH)")
    ap.add_argument("--explain", action="store_true", help="print the derive's largest imports")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = Path(tmp)
        rows = commands(out_dir)
        trees: list[tuple[str, Path | None]] = [("this tree", None)]
        if args.baseline_src is not None:
            trees.append(("baseline", args.baseline_src.resolve()))
        times: dict[tuple[str, str], list[float]] = {}
        for k in range(args.runs + 1):
            for label, cmd, _ in rows:  # interleaved: every command, every tree, each round
                for tree, src in trees:
                    dt = _run(cmd, _env(src), out_dir)
                    if k > 0:  # round 0 warms the disk caches and the parser-table cache
                        times.setdefault((tree, label), []).append(dt)
        bare = statistics.median(times[("this tree", rows[0][0])])
        head = f"{'command':46s} {'median s':>9s} {'x python':>9s} {'target':>9s}"
        if len(trees) > 1:
            head += f" {'baseline s':>11s} {'x python':>9s}"
        print(head)
        for label, _, target in rows:
            med = statistics.median(times[("this tree", label)])
            line = f"{label:46s} {med:9.3f} {med / bare:9.2f} {target:>9s}"
            if len(trees) > 1:
                b = statistics.median(times[("baseline", label)])
                bare_b = statistics.median(times[("baseline", rows[0][0])])
                line += f" {b:11.3f} {b / bare_b:9.2f}"
            print(line)
        print(f"(runs={args.runs}, median; cpu_count={os.cpu_count()}, "
              f"load average={os.getloadavg()[0]:.2f}: numbers are noisy when the machine is shared)")
        if args.explain:
            explain(out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
