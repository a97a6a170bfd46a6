"""Shape-graph extraction and validation time vs. number of box parts (tiling grammars).

    /work/venv/bin/python benchmarks/bench_tiling.py [--runs 5] [--sizes 100 1000 10000]

Models: lattices of unit cubes ("Node") joined by thin boxes ("Beam") touching face to face,
sized to about 100, 1,000 and 10,000 parts (each cube has up to 6 beams; contacts = 2 x beams).
For each size, the median of `--runs` runs (3 at 10,000) of:
- graph:     `shape_graph` (rtree broad phase + exact box-box narrow phase);
- general:   the same graph with the box fast path switched off, i.e. every candidate pair goes
             through manifold3d `min_gap` (what non-box parts cost; 100 and 1,000 only);
- brute:     the all-pairs baseline: every pair's bounding boxes tested (numpy, vectorised, so a
             fair baseline rather than a Python double loop), same narrow phase (100 and 1,000 only);
- validate:  `validate(grammar, model)` end to end (graph + neighbour, pair, docking and global
             constraint checks) with the grammar learned from a 3x3x3 lattice.
The growth exponent is the slope of a least-squares line through log(time) vs log(parts).
Target: 1,000 parts in under 1 s.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tiling"))
from _tiling_helpers import lattice  # noqa: E402

from grammarkit.tiling import learn, shape_graph, validate  # noqa: E402
from grammarkit.tiling.contacts import candidate_pairs_bruteforce, contacts, default_tolerance, prepare  # noqa: E402
from _timing import median_time  # noqa: E402 - benchmarks/ is on sys.path


def lattice_of_about(n: int):
    """The cube-and-beam lattice whose part count is closest to n (parts ~ 4 k^3 for k^3 cubes)."""
    best = None
    for a in range(1, 40):
        for b in range(a, a + 2):
            for c in range(b, b + 2):
                parts = a * b * c + (a - 1) * b * c + a * (b - 1) * c + a * b * (c - 1)
                if best is None or abs(parts - n) < abs(best[0] - n):
                    best = (parts, (a, b, c))
    return lattice(*best[1])




def general_graph(model):
    geom = prepare(model.parts)
    geom.boxy[:] = False
    return contacts(model, default_tolerance(geom), geom=geom)


def brute_graph(model):
    geom = prepare(model.parts)
    tol = default_tolerance(geom)
    return contacts(model, tol, geom=geom, pairs=candidate_pairs_bruteforce(geom, tol))


def main(argv=None) -> int:  # noqa: ANN001
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000])
    args = ap.parse_args(argv)
    grammar = learn([lattice(3, 3, 3)], name="lattice")
    rows = []
    for n in args.sizes:
        model = lattice_of_about(n)
        runs = args.runs if len(model) <= 2000 else max(1, min(args.runs, 3))
        g = shape_graph(model)
        assert validate(grammar, model, graph=g).ok
        row = {"parts": len(model), "contacts": g.number_of_edges(),
               "graph": median_time(lambda: shape_graph(model), runs),
               "validate": median_time(lambda: validate(grammar, model), runs)}
        if len(model) <= 2000:
            assert len(general_graph(model)) == len(brute_graph(model)) == g.number_of_edges()
            row["general"] = median_time(lambda: general_graph(model), runs)
            row["brute"] = median_time(lambda: brute_graph(model), runs)
        rows.append(row)
    head = f"{'parts':>7} {'contacts':>8} {'graph s':>9} {'validate s':>10} {'general s':>10} {'brute s':>9} {'brute/graph':>11}"
    print(head)
    print("-" * len(head))
    for r in rows:
        general = f"{r['general']:10.4f}" if "general" in r else f"{'-':>10}"
        brute = f"{r['brute']:9.4f}" if "brute" in r else f"{'-':>9}"
        ratio = f"{r['brute'] / r['graph']:11.2f}" if "brute" in r else f"{'-':>11}"
        print(f"{r['parts']:7d} {r['contacts']:8d} {r['graph']:9.4f} {r['validate']:10.4f} {general} {brute} {ratio}")
    if len(rows) >= 2:
        x = np.log([r["parts"] for r in rows])
        for key in ("graph", "validate"):
            slope = np.polyfit(x, np.log([r[key] for r in rows]), 1)[0]
            print(f"growth exponent ({key}): {slope:.2f}  (time ~ parts^{slope:.2f})")
        both = [r for r in rows if "brute" in r]
        if len(both) >= 2:
            xb = np.log([r["parts"] for r in both])
            print(f"growth exponent (brute): {np.polyfit(xb, np.log([r['brute'] for r in both]), 1)[0]:.2f}")
    k = next((r for r in rows if 800 <= r["parts"] <= 1200), None)
    if k:
        print(f"target 1,000 parts < 1 s: graph {k['graph']:.3f} s, validate {k['validate']:.3f} s -> "
              f"{'met' if k['validate'] < 1 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
