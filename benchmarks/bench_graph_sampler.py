"""Graph-sampler throughput and growth (Kalojanov 2019, section 4).

    /work/venv/bin/python benchmarks/bench_graph_sampler.py [--runs 3] [--n 300] [--iterations 4]
        [--attempts-per-shape 512] [--growth-attempts 20000] [--quick] [--no-growth]

1. Throughput on the castle example (grammars/tiling/castle): valid *new* variants per minute at
   1 and 2 worker processes, attempts per valid and per new variant, parts per variant. Baseline,
   measured in the same run: the same sampling with the shape graph fully recomputed from the
   geometry (`shape_graph`) and the full `validate` for every candidate (option
   incremental=false); the outputs are identical (same seed), only the time differs.
   Each cell is the median of --runs runs (the same seeds for every configuration).
2. The per-iteration growth table (shapes after each iteration, as the paper's Table 1) for every
   tiling example in grammars/tiling/.

Sampling time only (no GLB writing); the example loading is reported separately, and so is
starting the worker processes (they persist across runs in one Python process).
"""
from __future__ import annotations

import argparse
import statistics
import sys
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
    shapes = list(sampler.run(n, iterations))
    t2 = time.perf_counter()
    attempts = sum(s.attempts for s in sampler.stats)
    valid = sum(s.outcomes["valid"] for s in sampler.stats)
    parts = [len(s) for s in shapes]
    return {"setup": t1 - t0, "seconds": t2 - t1, "new": len(shapes), "valid": valid,
            "attempts": attempts, "parts": parts, "sampler": sampler}


def throughput(grammar, runs: int, n: int, iterations: int, per_shape: int) -> None:
    configs = [("incremental", 1, True), ("incremental", 2, True),
               ("full recompute (baseline)", 1, False), ("full recompute (baseline)", 2, False)]
    results = {}
    for label, workers, incremental in configs:
        rows = [one_run(grammar, workers=workers, seed=100 + r, n=n, iterations=iterations,
                        incremental=incremental, attempts_per_shape=per_shape) for r in range(runs)]
        results[(label, workers)] = rows
    print(f"\n## Throughput: castle, n <= {n}, iterations <= {iterations}, attempts_per_shape="
          f"{per_shape}, median of {runs} run(s) (seeds 100..)\n")
    head = ("| graph update | workers | new variants | attempts | attempts/valid | attempts/new "
            "| parts (min-mean-max) | seconds | attempts/s | new variants/min | speed-up vs baseline |")
    print(head)
    print("|---" * (head.count("|") - 1) + "|")
    for (label, workers), rows in results.items():
        sec = statistics.median(r["seconds"] for r in rows)
        new = statistics.median(r["new"] for r in rows)
        att = statistics.median(r["attempts"] for r in rows)
        val = statistics.median(r["valid"] for r in rows)
        parts = [p for r in rows for p in r["parts"]]
        rate = statistics.median(60.0 * r["new"] / r["seconds"] for r in rows)
        base = results[("full recompute (baseline)", workers)]
        base_rate = statistics.median(60.0 * r["new"] / r["seconds"] for r in base)
        pr = f"{min(parts)}-{statistics.mean(parts):.0f}-{max(parts)}" if parts else "-"
        aps = statistics.median(r["attempts"] / r["seconds"] for r in rows)
        print(f"| {label} | {workers} | {new:.0f} | {att:.0f} | {att / max(val, 1):.1f} | "
              f"{att / max(new, 1):.1f} | {pr} | {sec:.2f} | {aps:.0f} | {rate:.0f} | {rate / base_rate:.2f}x |")
    setup = statistics.median(r["setup"] for rows in results.values() for r in rows)
    print(f"\nsetup (load examples, shape graphs, validate examples): {setup:.2f} s median")
    one = results[("incremental", 1)]
    two = results[("incremental", 2)]
    same = all(a["sampler"].stats[-1].shapes_after == b["sampler"].stats[-1].shapes_after
               for a, b in zip(one, two))
    print(f"workers=1 and workers=2 produced the same pools: {same}")


def growth(paths: list[Path], iterations: int, max_attempts: int) -> None:
    print(f"\n## Growth per iteration (shapes in the collection after each iteration; seed 7, "
          f"histogram dedupe, <= {max_attempts} attempts per iteration)\n")
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--iterations", type=int, default=4)
    ap.add_argument("--growth-attempts", type=int, default=20000)
    ap.add_argument("--attempts-per-shape", type=int, default=512,
                    help="throughput runs: attempts per new shape and iteration")
    ap.add_argument("--quick", action="store_true", help="1 run, n=60, 3 iterations, small growth budget")
    ap.add_argument("--no-growth", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.runs, args.n, args.iterations, args.growth_attempts = 1, 60, 3, 3000
    castle = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
    from grammarkit_graph_sampler import sampler as sampler_mod

    if hasattr(sampler_mod, "_pool_workers"):
        # Worker processes persist across runs; start them once here, timed on their own, so
        # no table row pays for it and the rows stay comparable.
        t0 = time.perf_counter()
        for _, conn in sampler_mod._pool_workers(2):
            conn.send(("init", ([], None, 0, None, 0.0, 0)))
            conn.send(("run", 0, [], []))
        for _, conn in sampler_mod._pool_workers(2):
            conn.recv()
        print(f"worker start-up (2 spawned processes, once per Python process): "
              f"{time.perf_counter() - t0:.2f} s")
    throughput(load(castle), args.runs, args.n, args.iterations, args.attempts_per_shape)
    if not args.no_growth:
        growth(sorted((ROOT / "grammars" / "tiling").glob("*/*.grammar")), 4, args.growth_attempts)
    return 0


if __name__ == "__main__":
    sys.exit(main())
