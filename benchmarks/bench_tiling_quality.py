"""Graph-sampler output quality under the stricter tiling checks (issue 11).

    python benchmarks/bench_tiling_quality.py [--n 30] [--iterations 4] [--seed 0] [--examples castle ...]

For each example grammar (grammars/tiling: castle, balltrack, facade, wfc/coast) the graph
sampler makes up to --n variants; each written variant is then re-read through the public
path (`to_assembly`) and checked by the full `validate` (contacts rebuilt from the geometry).
Table 1, per example, the share of variants that are
- upright:        no `orientation` / `mirrored` violation,
- supported:      no `constraint grounded` violation (carried down to the examples' ground),
- count-correct:  no `constraint count` violation,
- site-valid:     no `dock` / `site` violation (allowed site pairs and placements, required
                  sites filled),
- valid:          no violation at all. Target: 100% in every column.
Table 2: the share of the sampler's attempts rejected, per rule that rejected them first
(`orientation`, `constraint grounded`, `site`, ...; "pair": a contact no dock allows).
Table 3: the growth table (shapes in the pool per iteration).

Deterministic for a seed. The machine is shared (2 cores, several agents): the seconds column
is noisy; the shares are not.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "plugins" / "graph_sampler"))

from grammarkit.dsl import load  # noqa: E402
from grammarkit.tiling import validate  # noqa: E402
from grammarkit_graph_sampler import GraphSampler  # noqa: E402

EXAMPLES = {
    "castle": ROOT / "grammars/tiling/castle/castle.grammar",
    "balltrack": ROOT / "grammars/tiling/balltrack/balltrack.grammar",
    "facade": ROOT / "grammars/tiling/facade/facade.grammar",
    "coast": ROOT / "grammars/tiling/wfc/coast.grammar",
}
COLUMNS = {
    "upright": {"orientation", "mirrored"},
    "supported": {"constraint grounded"},
    "count-correct": {"constraint count"},
    "site-valid": {"dock", "site"},
}


def measure(name: str, n: int, iterations: int, seed: int) -> dict:
    g = load(EXAMPLES[name])
    sampler = GraphSampler(g, seed=seed, workers=1)
    t = time.perf_counter()
    variants = [sampler.to_assembly(s) for s in sampler.run(n, iterations)]
    seconds = time.perf_counter() - t
    good = {k: 0 for k in (*COLUMNS, "valid")}
    for a in variants:
        rules = {v.rule for v in validate(g, a).violations}
        for col, bad in COLUMNS.items():
            good[col] += not (rules & bad)
        good["valid"] += not rules
    attempts = sum(s.attempts for s in sampler.stats)
    reasons: dict[str, int] = {}
    for s in sampler.stats:
        for k, v in s.reasons.items():
            reasons[k] = reasons.get(k, 0) + v
    return {"name": name, "variants": len(variants), "good": good, "attempts": attempts,
            "reasons": reasons, "growth": sampler.growth_table(), "seconds": seconds}


def main(argv=None) -> int:  # noqa: ANN001
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--iterations", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--examples", nargs="+", default=list(EXAMPLES), choices=list(EXAMPLES))
    args = ap.parse_args(argv)
    rows = [measure(name, args.n, args.iterations, args.seed) for name in args.examples]

    cols = [*COLUMNS, "valid"]
    print(f"Table 1: share of written variants passing each check (N = {args.n} asked, seed {args.seed})")
    print(f"{'example':<10} {'variants':>8} " + " ".join(f"{c:>13}" for c in cols) + f" {'seconds':>8}")
    for r in rows:
        v = max(1, r["variants"])
        print(f"{r['name']:<10} {r['variants']:8d} " + " ".join(f"{100 * r['good'][c] / v:12.1f}%" for c in cols)
              + f" {r['seconds']:8.1f}")
    print()
    print("Table 2: share of attempts rejected, by the rule that rejected them first")
    reasons = sorted({k for r in rows for k in r["reasons"]})
    print(f"{'example':<10} {'attempts':>8} " + " ".join(f"{k[:20]:>20}" for k in reasons))
    for r in rows:
        a = max(1, r["attempts"])
        print(f"{r['name']:<10} {r['attempts']:8d} "
              + " ".join(f"{100 * r['reasons'].get(k, 0) / a:19.1f}%" for k in reasons))
    print()
    print("Table 3: growth (shapes in the pool after each iteration; new variants)")
    for r in rows:
        cells = ", ".join(f"it{x['iteration']}: {x['shapes']} (+{x['new']})" for x in r["growth"])
        print(f"{r['name']:<10} {cells}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
