"""Graph-sampler throughput and growth (Kalojanov 2019, section 4).

    python benchmarks/bench_graph_sampler.py [--runs 3] [--n 200] [--quick] [--no-growth]
        [--no-derive] [--no-throughput] [--iterations 4] [--attempts-per-shape 512]

1. `derive`, start-up included (the issue-33 figure): `grammarkit derive castle.grammar
   --backend graph-sampler -n N` with the defaults, as a user runs it (a fresh process that
   loads the grammar and examples, starts its workers, writes the files), at 1 and 2 workers;
   new valid variants per minute of wall time and per CPU minute (children included), and
   the ratio against the baseline in the same run: the same command with
   `--option geometric-keys=false` (duplicates found by the graph test after validation, as
   before issue 33). The written variants are the same (same seed), only the time differs.
   The -n rows use `--option counts=grammar`: with the default counts=examples the castle's
   count range admits few variants (one row shows how many the defaults make).
2. Throughput in one process on the castle: as 1. without start-up, also against the
   full-recompute baseline (incremental=false: shape graph and full `validate` per candidate).
3. The per-iteration growth table (shapes after each iteration, as the paper's Table 1) for every
   tiling example in grammars/tiling/.

Each cell is the median of --runs runs. The machine is shared: ratios in one run are the figure
to read; CPU minutes are less sensitive to load than wall minutes.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load(path: Path):
    from grammarkit_graph_sampler import geometry

    return geometry.as_grammar(path)


def one_run(grammar, *, workers: int, seed: int, n: int, iterations: int, **options):
    from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions

    t0 = time.perf_counter()
    sampler = GraphSampler(grammar, seed=seed, workers=workers, options=SamplerOptions(**options))
    t1 = time.perf_counter()
    c1 = time.process_time()
    shapes = list(sampler.run(n, iterations))
    t2 = time.perf_counter()
    cpu = time.process_time() - c1
    sampler.executor.close()
    attempts = sum(s.attempts for s in sampler.stats)
    valid = sum(s.outcomes["valid"] for s in sampler.stats)
    parts = [len(s) for s in shapes]
    return {"setup": t1 - t0, "seconds": t2 - t1, "cpu": cpu, "new": len(shapes), "valid": valid,
            "attempts": attempts, "parts": parts, "sampler": sampler, "shapes": shapes}


def derive_once(workers: int, n: int, seed: int, options: list[str]) -> dict:
    """One `grammarkit derive` in a fresh process: wall seconds, CPU seconds, files written."""
    out = Path(tempfile.mkdtemp(prefix="bench_gs_"))
    cmd = [sys.executable, "-m", "grammarkit", "derive", str(CASTLE), "--backend", "graph-sampler",
           "-n", str(n), "--seed", str(seed), "--workers", str(workers), "--json", "-o", str(out / "v")]
    for o in options:
        cmd += ["--option", o]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"derive failed: {proc.stderr[-2000:]}")
    written = len(list((out / "v").glob("variant_*.glb")))
    stats = json.loads(proc.stdout).get("stats", {})
    shutil.rmtree(out, ignore_errors=True)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "new": written, "attempts": stats.get("attempts")}


def measure(configs, runs: int, once) -> dict:
    """{(label, workers): [once(workers, seed, options) for each run]} (the same seeds everywhere)."""
    return {(label, workers): [once(workers, 100 + r, opts) for r in range(runs)]
            for label, workers, opts in configs}


def table_head(title: str, head: str) -> None:
    print(f"\n## {title}\n")
    print(head)
    print("|---" * (head.count("|") - 1) + "|")


def derive_table(runs: int, n: int) -> None:
    # the defaults keep the examples' count range (counts=examples, issue 28), in which the castle
    # has few variants (13 for seed 0): the -n rows use counts=grammar, the defaults get one row
    configs = [("defaults (counts=examples)", 1, []),
               ("counts=grammar", 1, ["counts=grammar"]), ("counts=grammar", 2, ["counts=grammar"]),
               ("baseline: counts=grammar geometric-keys=false", 1, ["counts=grammar", "geometric-keys=false"])]
    rows = measure(configs, runs, lambda w, seed, opts: derive_once(w, n, seed, opts))
    table_head(f"derive castle.grammar --backend graph-sampler -n {n}, start-up included, "
               f"median of {runs} run(s) (seeds 100..)",
               "| code path | workers | written | attempts | wall s | CPU s | new/min (wall) | "
               "new/min (CPU) | vs baseline (wall) | vs 1 worker (wall) |")

    def rate(rs, key):
        return statistics.median(60.0 * r["new"] / r[key] for r in rs)

    base = rate(rows[("baseline: counts=grammar geometric-keys=false", 1)], "wall")
    one = rate(rows[("counts=grammar", 1)], "wall")
    for (label, workers), rs in rows.items():
        w = rate(rs, "wall")
        print(f"| {label} | {workers} | {statistics.median(r['new'] for r in rs):.0f} | "
              f"{statistics.median(r['attempts'] or 0 for r in rs):.0f} | "
              f"{statistics.median(r['wall'] for r in rs):.1f} | {statistics.median(r['cpu'] for r in rs):.1f} | "
              f"{w:.0f} | {rate(rs, 'cpu'):.0f} | {w / base:.2f}x | {w / one:.2f}x |")


def throughput(grammar, runs: int, n: int, iterations: int, per_shape: int) -> None:
    configs = [("issue 33", 1, {}), ("issue 33", 2, {}),
               ("geometric-keys=false", 1, {"geometric_keys": False}),
               ("full recompute (baseline)", 1, {"geometric_keys": False, "incremental": False})]
    results = measure(configs, runs, lambda w, seed, opts: one_run(
        grammar, workers=w, seed=seed, n=n, iterations=iterations, attempts_per_shape=per_shape, **opts))
    table_head(f"Throughput in one process: castle, n <= {n}, iterations <= {iterations}, "
               f"attempts_per_shape={per_shape}, median of {runs} run(s) (seeds 100..)",
               "| code path | workers | new variants | attempts | attempts/new | parts (min-mean-max) "
               "| seconds | CPU s (this process) | attempts/s | new variants/min | vs baseline |")
    base = results[("full recompute (baseline)", 1)]
    base_rate = statistics.median(60.0 * r["new"] / r["seconds"] for r in base)
    for (label, workers), rows in results.items():
        sec = statistics.median(r["seconds"] for r in rows)
        new = statistics.median(r["new"] for r in rows)
        att = statistics.median(r["attempts"] for r in rows)
        parts = [p for r in rows for p in r["parts"]]
        rate = statistics.median(60.0 * r["new"] / r["seconds"] for r in rows)
        pr = f"{min(parts)}-{statistics.mean(parts):.0f}-{max(parts)}" if parts else "-"
        aps = statistics.median(r["attempts"] / r["seconds"] for r in rows)
        cpu = statistics.median(r["cpu"] for r in rows)
        print(f"| {label} | {workers} | {new:.0f} | {att:.0f} | {att / max(new, 1):.1f} | {pr} | "
              f"{sec:.2f} | {cpu:.2f} | {aps:.0f} | {rate:.0f} | {rate / base_rate:.2f}x |")
    setup = statistics.median(r["setup"] for rows in results.values() for r in rows)
    print(f"\nsetup (load examples, shape graphs, validate examples): {setup:.2f} s median")
    same = all([s.key for s in a["shapes"]] == [s.key for s in b["shapes"]]
               and [len(s) for s in a["shapes"]] == [len(s) for s in b["shapes"]]
               for a, b in zip(results[("issue 33", 1)], results[("full recompute (baseline)", 1)]))
    print(f"same variants in every row: {same}")


def growth(paths: list[Path], iterations: int, max_attempts: int) -> None:
    print(f"\n## Growth per iteration (shapes in the collection after each iteration; seed 7, "
          f"default options (isomorphism dedupe), <= {max_attempts} attempts per iteration)\n")
    for path in paths:
        grammar = load(path)
        r = one_run(grammar, workers=2, seed=7, n=10**9, iterations=iterations, max_attempts=max_attempts)
        table = r["sampler"].growth_table()
        cols = " | ".join(str(row["shapes"]) for row in table)
        print(f"### {path.parent.name} ({', '.join(f'{len(e)} parts' for e in r['sampler'].examples)})\n")
        print("| iteration | " + " | ".join(str(row["iteration"]) for row in table) + " |")
        print("|---" * (len(table) + 1) + "|")
        print(f"| shapes | {cols} |")
        print("| new | " + " | ".join(str(row["new"]) for row in table) + " |")
        print("| attempts | - | " + " | ".join(str(row["attempts"]) for row in table[1:]) + " |")
        parts = r["parts"]
        if parts:
            print(f"\nvariant sizes {min(parts)}-{max(parts)} parts; {r['seconds']:.1f} s at 2 workers "
                  f"({60 * len(parts) / r['seconds']:.0f} new variants/min)\n")


CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--iterations", type=int, default=4)
    ap.add_argument("--growth-attempts", type=int, default=20000)
    ap.add_argument("--attempts-per-shape", type=int, default=512,
                    help="throughput runs: attempts per new shape and iteration")
    ap.add_argument("--quick", action="store_true", help="1 run, n=40, 3 iterations, small growth budget")
    ap.add_argument("--no-growth", action="store_true")
    ap.add_argument("--no-derive", action="store_true")
    ap.add_argument("--no-throughput", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.runs, args.n, args.iterations, args.growth_attempts = 1, 40, 3, 3000
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores)")
    if not args.no_derive:
        derive_table(args.runs, args.n)
    if not args.no_throughput:
        throughput(load(CASTLE), args.runs, args.n, args.iterations, args.attempts_per_shape)
    if not args.no_growth:
        growth(sorted((ROOT / "grammars" / "tiling").glob("*/*.grammar")), 4, args.growth_attempts)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
