"""Benchmark of the substructure search (Liu et al. 2015; plugins/substructure).

Tables (medians of --runs runs, measured in this process):
1. every tiling example: parts, contacts, symmetries, operations, enumeration time, and the
   brute-force reference (all connected subgraph pairs, networkx VF2) where it finishes;
2. castles grown by tiling to 70, 300 and 1,000 parts (copies of castle_small side by side,
   corner towers touching, cut to N parts breadth-first): enumeration time (wall, and CPU time
   of the child process, which other jobs on the machine disturb less), the fitted exponent
   of time against parts, and the brute force where it finishes (it does not beyond ~20 parts);
3. candidates and valid new variants per minute of the substructure back end (memo on, the
   default) beside the same back end with `memo=false` (the baseline, same candidates and
   variants) and the graph sampler, all through grammarkit.run on the same examples.

Paper: up to 3 s to enumerate all matching subgraphs for 5-70 nodes (2.9 GHz laptop).
Targets: <= 0.3 s at 70 nodes, <= 10 s at 1,000 nodes, exponent <= 2.2.

    python benchmarks/bench_substructure.py [--runs 3] [--variants 20] [--skip-yield] [--only-scaling] [--only-yield --grammars castle facade]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "plugins" / "substructure"))
sys.path.insert(0, str(ROOT / "plugins" / "graph_sampler"))

from grammarkit.tiling import Assembly, read_assembly  # noqa: E402
from grammarkit_substructure.brute_force import brute_force_operations  # noqa: E402
from grammarkit_substructure.operations import find_operations  # noqa: E402
from grammarkit_substructure.search import OrderedGraph, find_symmetries  # noqa: E402
from grammarkit_substructure.shape import Shape  # noqa: E402

EXAMPLES = ROOT / "grammars" / "tiling"


def median_time(fn, runs: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(runs):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def in_child(fn, limit_s: float):
    """(wall seconds, value, CPU seconds) of fn() run in a forked child, or None when it
    passes `limit_s`. The CPU time (time.process_time in the child) is the one to compare
    across runs while other jobs share the machine."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    q = ctx.Queue()

    def work():  # noqa: ANN202
        t, c = time.perf_counter(), time.process_time()
        value = fn()
        q.put((time.perf_counter() - t, value, time.process_time() - c))

    p = ctx.Process(target=work)
    p.start()
    p.join(limit_s)
    if p.is_alive():
        p.kill()
        p.join()
        return None
    return q.get()


def brute(graph: OrderedGraph, limit_s: float) -> str:
    """The brute force (exponential) with a time limit."""
    out = in_child(lambda: len(brute_force_operations(graph)), limit_s)
    return f"> {limit_s:.0f} s" if out is None else f"{out[0]:.3f} s ({out[1]} ops)"


def grown_castle(n_parts: int) -> Shape:
    """Copies of castle_small on a grid (towers touching), cut to n_parts breadth-first."""
    import networkx as nx

    base = read_assembly(EXAMPLES / "castle" / "castle_small.glb")
    (lo, hi) = base.bounds
    dx, dy = hi[0] - lo[0], hi[1] - lo[1]
    side = int(np.ceil(np.sqrt(n_parts / len(base)))) + 1
    parts = []
    for i in range(side):
        for j in range(side):
            for p in base.parts:
                T = np.eye(4)
                T[:3, 3] = [i * dx, j * dy, 0.0]
                parts.append(p.transformed(T, f"{p.type}.{len(parts)}"))
    shape = Shape.from_assembly(Assembly(parts, name="grid"))
    g = nx.Graph(shape.edges)
    keep = sorted(list(nx.bfs_tree(g, 0))[:n_parts])
    idx = {v: k for k, v in enumerate(keep)}
    nbrs = [[idx[w] for w in shape.graph.nbrs[v] if w in idx] for v in keep]
    shape.graph = OrderedGraph([shape.types[v] for v in keep], nbrs)
    shape.types = [shape.types[v] for v in keep]
    shape.edges = sorted({(min(idx[u], idx[v]), max(idx[u], idx[v])) for u, v in shape.edges
                          if u in idx and v in idx})
    return shape


def table_examples(runs: int, brute_limit: float) -> None:
    print("\n### Tiling examples (donor = host = the example, q = 0)\n")
    print("| example | parts | contacts | symmetries | operations | recursive | enumerate | brute force |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for path in sorted(EXAMPLES.glob("*/*.glb")):
        shape = Shape.from_assembly(read_assembly(path))
        t, ops = median_time(lambda: find_operations(shape.graph), runs)
        syms = find_symmetries(shape.graph)  # noqa: F841 - counted below
        rec = sum(1 for o in ops if o.recursive)
        bf = brute(shape.graph, brute_limit)
        print(f"| {path.stem} | {len(shape)} | {len(shape.edges)} | {len(syms)} | {len(ops)} | {rec} "
              f"| {t:.3f} s | {bf} |")


def table_scaling(runs: int, brute_limit: float, limit: float, sizes=(20, 70, 300, 1000)) -> None:
    print("\n### Grown castles (copies of castle_small, cut breadth-first)\n")
    print("| parts | contacts | operations | enumerate (median wall) | CPU (median) | per operation (CPU) "
          "| brute force |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    xs, ys, ycs = [], [], []
    for n in sizes:
        shape = grown_castle(n)
        times, cpus, count = [], [], None
        for _ in range(runs):
            out = in_child(lambda: len(find_operations(shape.graph)), limit)
            if out is None:
                break
            times.append(out[0])
            count = out[1]
            cpus.append(out[2])
        bf = brute(shape.graph, brute_limit) if n <= 70 else "not run (exponential)"
        if not times:
            print(f"| {n} | {len(shape.edges)} | ? | > {limit:.0f} s | | | {bf} |")
            continue
        t, c = statistics.median(times), statistics.median(cpus)
        print(f"| {n} | {len(shape.edges)} | {count} | {t:.3f} s | {c:.3f} s | {1e6 * c / max(count, 1):.1f} us "
              f"| {bf} |")
        if n >= 70:
            xs.append(np.log(n))
            ys.append(np.log(t))
            ycs.append(np.log(c))
    if len(xs) >= 2:
        k, kc = np.polyfit(xs, ys, 1)[0], np.polyfit(xs, ycs, 1)[0]
        print(f"\nfitted exponent (time ~ parts^k over the sizes >= 70 that finished): k = {k:.2f} (wall), "
              f"{kc:.2f} (CPU)")


def _rate(g, backend: str, n: int, timeout: float, iterations: int, options: dict, workers: int = 1) -> dict:
    """One run through grammarkit.run (files written to a temporary folder, as a user's run):
    variants and candidates per minute of wall time, start-up included."""
    import tempfile

    from grammarkit.run import run_backend

    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        summary = run_backend(g, out=Path(tmp) / "v", backend=backend, n=n, seed=7, iterations=iterations,
                              workers=workers, time_limit=timeout, options=options)
        dt = time.perf_counter() - t
    stats = summary.stats or {}
    return {"made": summary.total, "seconds": dt, "variants": 60.0 * summary.total / dt,
            "candidates": 60.0 * stats.get("candidates", 0) / dt, "count": stats.get("candidates", 0),
            "embeddings": stats.get("embeddings_tried", 0), "stopped": stats.get("stopped_by", "")}


def table_yield(n: int, timeout: float, grammars: list[str] | None = None, runs: int = 1,
                graph_sampler: bool = True) -> None:
    from grammarkit.dsl import load

    print(f"\n### Valid new variants per minute (grammarkit.run, 1 worker, up to {n} variants or {timeout:.0f} s, "
          f"seed 7, median of {runs})\n")
    print("(baseline: the substructure back end with `memo=false`, each candidate evaluated afresh; "
          "the same candidates, embeddings and variants in the same run)\n")
    print("| grammar | variants | candidates | candidates/min memo | baseline | speed-up | variants/min memo "
          "| baseline | graph sampler | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for gpath in sorted(EXAMPLES.glob("*/*.grammar")):
        if grammars and gpath.stem not in grammars:
            continue
        g = load(gpath)
        memo, base, gs = [], [], []
        for _ in range(runs):
            memo.append(_rate(g, "substructure", n, timeout, 1, {}))
            base.append(_rate(g, "substructure", n, timeout, 1, {"memo": False}))
            if graph_sampler:
                gs.append(_rate(g, "graph-sampler", n, timeout, 4, {}))
        for a, b in zip(memo, base):  # same seed and candidates: the memo changes no result
            if a["count"] == b["count"] and (a["made"], a["embeddings"]) != (b["made"], b["embeddings"]):
                raise SystemExit(f"{gpath.stem}: memo and baseline differ on the same candidates")

        def med(rows, key):  # noqa: ANN001, ANN202
            return statistics.median(r[key] for r in rows)

        c_m, c_b = med(memo, "candidates"), med(base, "candidates")
        v_m, v_b = med(memo, "variants"), med(base, "variants")
        v_g = med(gs, "variants") if gs else float("nan")
        print(f"| {gpath.stem} | {memo[0]['made']} | {memo[0]['count']} ({memo[0]['stopped']}) | {c_m:.0f} | {c_b:.0f} "
              f"| {c_m / c_b if c_b else float('nan'):.2f} | {v_m:.1f} | {v_b:.1f} | {v_g:.1f} "
              f"| {v_m / v_g if v_g else float('nan'):.2f} |")


def table_workers(n: int, timeout: float, grammars: list[str] | None = None, runs: int = 1) -> None:
    """Wall time of the same run (seed 7, memo on) on 1 worker and on 2 (the executor's
    "auto" rule starts the second when the work left repays its start-up); the outputs must
    be the same whatever the number of workers (checked here by the counts, by the files in
    tests/substructure/test_backend.py)."""
    from grammarkit.dsl import load

    print(f"\n### Workers (grammarkit.run, up to {n} variants or {timeout:.0f} s, seed 7, median of {runs})\n")
    print("| grammar | variants | candidates | 1 worker | 2 workers | speed-up |")
    print("|---|---:|---:|---:|---:|---:|")
    for gpath in sorted(EXAMPLES.glob("*/*.grammar")):
        if grammars and gpath.stem not in grammars:
            continue
        g = load(gpath)
        one, two = [], []
        for _ in range(runs):
            one.append(_rate(g, "substructure", n, timeout, 1, {}, workers=1))
            two.append(_rate(g, "substructure", n, timeout, 1, {}, workers=2))
        for a, b in zip(one, two):
            if a["stopped"] != "time" and b["stopped"] != "time" and \
                    (a["made"], a["count"], a["embeddings"]) != (b["made"], b["count"], b["embeddings"]):
                raise SystemExit(f"{gpath.stem}: 1 and 2 workers differ")
        t1 = statistics.median(r["seconds"] for r in one)
        t2 = statistics.median(r["seconds"] for r in two)
        print(f"| {gpath.stem} | {one[0]['made']} | {one[0]['count']} | {t1:.1f} s | {t2:.1f} s | {t1 / t2:.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--brute-limit", type=float, default=60.0, help="seconds before the brute force is stopped")
    ap.add_argument("--limit", type=float, default=600.0, help="seconds before an enumeration is stopped")
    ap.add_argument("--variants", type=int, default=20)
    ap.add_argument("--yield-timeout", type=float, default=120.0)
    ap.add_argument("--skip-yield", action="store_true")
    ap.add_argument("--yield-runs", type=int, default=1, help="runs per back end in the yield table (median)")
    ap.add_argument("--no-graph-sampler", action="store_true", help="leave the graph sampler out of the yield table")
    ap.add_argument("--only-yield", action="store_true")
    ap.add_argument("--only-scaling", action="store_true", help="only the grown castles (table 2)")
    ap.add_argument("--only-workers", action="store_true", help="only the 1-against-2-workers table")
    ap.add_argument("--grammars", nargs="+", help="the example grammars of the yield table (default: all)")
    args = ap.parse_args()
    import os

    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores, shared with other jobs)")
    if args.only_scaling:
        table_scaling(args.runs, args.brute_limit, args.limit)
    elif args.only_workers:
        table_workers(args.variants, args.yield_timeout, args.grammars, args.yield_runs)
    else:
        if not args.only_yield:
            table_examples(args.runs, args.brute_limit)
            table_scaling(args.runs, args.brute_limit, args.limit)
        if not args.skip_yield:
            table_yield(args.variants, args.yield_timeout, args.grammars, args.yield_runs,
                        not args.no_graph_sampler)
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
