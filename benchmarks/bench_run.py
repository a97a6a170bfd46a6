"""The run layer's costs: the executor's start-up decision, parallel speed-up, writer overhead.

    python benchmarks/bench_run.py [--runs 3] [--variations 120]

1. Short graph-sampler runs (castle, n=10, 2 iterations), each in a fresh Python process so
   that worker start-up is paid as a user pays it: workers=1 (baseline), workers=2 with the
   executor's default ("auto": workers start only when the remaining work repays them), and
   workers=2 forced to use processes ("always", what the old sampler pool did).
2. Split variations of the Paris building, written to a folder through `run_backend`, in a
   fresh process: workers=1 (baseline) vs workers=2 (auto).
3. Writer overhead per result: `run_backend` (encode + atomic files + manifest line) against
   `iter_results` (derive only, models in memory), in one process.

Each cell is the median of --runs runs; ratios are against the baseline of the same table,
measured in the same run.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
PARIS = ROOT / "grammars" / "paris.grammar"


def fresh_process(code: str) -> float:
    """Wall time of a fresh Python running `code` (imports included)."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", textwrap.dedent(code)], check=True, cwd=ROOT)
    return time.perf_counter() - t0


def sampler_code(workers: int, parallel: str, out: str) -> str:
    return f"""
        from grammarkit.run import LocalExecutor, run_backend
        run_backend({str(CASTLE)!r}, out={out!r}, n=10, iterations=2, seed=7,
                    executor=LocalExecutor({workers}, parallel={parallel!r}))
    """


def variations_code(workers: int, n: int, out: str) -> str:
    return f"""
        from grammarkit.run import run_backend
        run_backend({str(PARIS)!r}, out={out!r}, n={n}, seed=1, workers={workers},
                    options={{"variations": True}})
    """


def table(title: str, rows: list[tuple[str, list[float], str]], unit: str = "s") -> None:
    print(f"\n## {title}\n")
    print(f"| configuration | median {unit} | runs | ratio to baseline |")
    print("|---|---|---|---|")
    base = statistics.median(rows[0][1])
    for label, values, note in rows:
        med = statistics.median(values)
        print(f"| {label} | {med:.3f} | {len(values)} | {med / base:.2f}x {note} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--variations", type=int, default=120)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench_run_"))

    def timed(code_for) -> list[float]:
        out = []
        for r in range(args.runs):
            folder = tmp / f"o{time.perf_counter_ns()}"
            out.append(fresh_process(code_for(str(folder))))
        return out

    bare = timed(lambda o: "pass")
    rows = [("workers=1 (baseline)", timed(lambda o: sampler_code(1, "never", o)), ""),
            ("workers=2, auto (default)", timed(lambda o: sampler_code(2, "auto", o)), ""),
            ("workers=2, always processes", timed(lambda o: sampler_code(2, "always", o)), "")]
    table(f"Short sampler runs, whole processes (bare Python: {statistics.median(bare):.3f} s)", rows)

    n = args.variations
    rows = [("workers=1 (baseline)", timed(lambda o: variations_code(1, n, o)), ""),
            ("workers=2, auto (default)", timed(lambda o: variations_code(2, n, o)), "")]
    table(f"{n} Paris variations written to a folder, whole processes", rows)
    for label, values, _ in rows:
        print(f"- {label}: {n / statistics.median(values):.1f} buildings/s including start-up")

    from grammarkit.run import iter_results, run_backend

    k = 20
    mem, disk = [], []
    for r in range(args.runs):
        t0 = time.perf_counter()
        for _ in iter_results(PARIS, n=k, seed=r, options={"variations": True}):
            pass
        mem.append((time.perf_counter() - t0) / k)
        t0 = time.perf_counter()
        run_backend(PARIS, out=tmp / f"w{r}", n=k, seed=r, workers=1, options={"variations": True})
        disk.append((time.perf_counter() - t0) / k)
    table(f"Per result: derive in memory vs written through the writer ({k} Paris variations)",
          [("iter_results (baseline: derive only)", mem, ""),
           ("run_backend (derive + GLB + atomic file + manifest line)", disk, "")], unit="s/result")
    return 0


if __name__ == "__main__":
    sys.exit(main())
