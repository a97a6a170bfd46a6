"""Benchmark of the split engine (issue 3).

1. Derive the Paris building (grammars/paris.grammar: >= 10 floors, >= 200 terminals): median
   wall time over --runs runs (default 20) of `grammarkit.split.derive` (interpretation of the
   grammar + the manifold3d booleans + mesh extraction), and of derive + the coloured trimesh.
2. The floor: the same solids (recorded from one derivation) built directly with manifold3d
   calls, united and cut with the same batched booleans and turned into a mesh, in the same run.
   The ratio derive / floor is the engine's overhead factor.
3. --variations N (default 1000) variations (`grammarkit derive --variations`): buildings per
   second, in one process and with --workers processes (default: all cores).

4. Per building (issue 10): every example split grammar (grammars/*.grammar) and every CGA
   corpus file that imports and derives (grammars/cga/*.cga, on a 20 x 16 m lot, assets
   dropped): median derive time over --building-runs runs, split into the final booleans
   (`grammarkit.split.model.compose`: union, cuts, mesh) and the rest (Python derivation),
   with terminals, triangles (solid + surface layer) and the ratio Python / booleans; and the
   booleans' baseline measured in the same run, one union of every solid (`1-union ms`,
   grouping off), with its ratio to the grouped booleans (`x grouped`: > 1 is a speed-up).
   --only-buildings skips 1-3.

Targets (issue 3): median <= 30 ms per Paris building and <= 2x the floor.

    python benchmarks/bench_derive.py [--runs 20] [--variations 1000] [--workers 2]
    python benchmarks/bench_derive.py --only-buildings [--building-runs 5]
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import statistics
import sys
import time
from pathlib import Path

import manifold3d

ROOT = Path(__file__).resolve().parents[1]
PARIS = ROOT / "grammars" / "paris.grammar"
M = manifold3d.Manifold


def _load():
    from grammarkit.dsl import load

    return load(PARIS)


def record_recipe(grammar):
    """Derive once with a recording Derivation: which solids, where (the floor's input)."""
    from grammarkit.split import compile as compile_split
    from grammarkit.split.engine import CUT_OUTSET, Derivation, Limits, frame, welded_frame
    from grammarkit.split.shape import FACE, Shape

    adds, cuts = [], []

    class Recorder(Derivation):
        def _add(self, s, tag):
            if s.solid is not None:
                # roofs / inserted meshes: a hand-written script would build the same solid;
                # we hand it the finished local mesh (cheaper than rebuilding: favours the floor)
                adds.append(("mesh", s.solid.to_mesh(), welded_frame(s.o, s.ax, s.sz)))
            elif s.poly is None:
                adds.append(("box", s.sz, welded_frame(s.o, s.ax, s.sz)))
            else:
                adds.append(("prism", (s.poly, s.sz[2]), welded_frame(s.o, s.ax, s.sz)))
            super()._add(s, tag)

        def add_cut(self, s, depth):
            z = s.ax[2]
            o = (s.o[0] - z[0] * depth, s.o[1] - z[1] * depth, s.o[2] - z[2] * depth)
            size = (s.sz[0], s.sz[1], depth + CUT_OUTSET)
            cuts.append(("box", size, frame(o, s.ax)) if s.poly is None else
                        ("prism", (s.poly, size[2]), frame(o, s.ax)))
            return super().add_cut(s, depth)

    from grammarkit.plugins import default_registries

    registries = default_registries()
    compiled = compile_split(grammar, registries=registries)
    values = compiled.evaluate_values(None, 0)
    ctx = Recorder(compiled, 0, Limits(), values, registries, compiled.base_dir)
    ctx.start(compiled.axiom, Shape((0.0, 0.0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
                                    (10.0, 10.0, 0.0), FACE))
    ctx.run()
    return adds, cuts


def floor(recipe):
    """The same geometry with direct manifold3d calls: construct, transform, batch booleans, mesh."""
    from grammarkit.geometry.footprints import cross_section

    adds, cuts = recipe

    def build(kind, data, mat):
        if kind == "box":
            return M.cube(data).transform(mat)
        if kind == "prism":
            return M.extrude(cross_section(data[0]), data[1]).transform(mat)
        return M(data).transform(mat)
    solids = [build(*a) for a in adds]
    body = M.batch_boolean(solids, manifold3d.OpType.Add)
    if cuts:
        body = M.batch_boolean([body, *[build(*c) for c in cuts]], manifold3d.OpType.Subtract)
    return body.to_mesh()


def _timed(fn, runs):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return times


def _variation_chunk(args):
    start, n, seed = args
    from grammarkit.split import variations

    g = _load()
    tris = 0
    for _, model in variations(g, n, seed=seed, start=start):
        tris += model.triangle_count
    return n, tris


LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def _buildings():
    """(label, grammar, lot) of every example split grammar and derivable corpus file."""
    import grammarkit
    from grammarkit.cga import translate_cga

    out = []
    for path in sorted((ROOT / "grammars").glob("*.grammar")):
        if path.name == "library.grammar":  # snippets only, no start rule of its own
            continue
        out.append((path.name, grammarkit.parse(path), None))
    for path in sorted((ROOT / "grammars" / "cga").glob("*.cga")):
        result = translate_cga(path, missing_assets="drop")
        if result.ok:
            out.append((path.name, grammarkit.parse(result.text, filename=str(path.with_suffix(".grammar"))), LOT))
    return out


def per_building(runs: int) -> None:
    """Median derive time per building, split into booleans (compose) and Python derivation."""
    import grammarkit
    from grammarkit.split import model as split_model

    compose = split_model.compose
    spent = []

    def timed_compose(*a, **kw):
        t = time.perf_counter()
        try:
            return compose(*a, **kw)
        finally:
            spent.append(time.perf_counter() - t)
    split_model.compose = timed_compose
    grouped_min = split_model.MIN_GROUPED
    try:
        print(f"\n{'building':34s} {'terminals':>9s} {'triangles':>9s} {'derive ms':>9s} "
              f"{'boolean ms':>10s} {'python ms':>9s} {'py/bool':>7s} {'1-union ms':>10s} {'x grouped':>9s}  note")
        for label, g, lot in _buildings():
            try:
                kw = {"lot": lot} if lot else {}
                m = grammarkit.derive(g, seed=0, **kw)  # warm-up (compile cache, assets)
            except Exception as exc:  # noqa: BLE001 - the reason goes into the table
                print(f"{label:34s} {'-':>9s} {'-':>9s} {'-':>9s} {'-':>10s} {'-':>9s} {'-':>7s}  "
                      f"does not derive: {type(exc).__name__}")
                continue
            totals, booleans, single = [], [], []
            for _ in range(runs):
                spent.clear()
                t = time.perf_counter()
                grammarkit.derive(g, seed=0, **kw)
                totals.append(time.perf_counter() - t)
                booleans.append(sum(spent))
                # the baseline in the same run: one union of every solid (no grouping)
                split_model.MIN_GROUPED = 10 ** 9
                spent.clear()
                try:
                    grammarkit.derive(g, seed=0, **kw)
                finally:
                    split_model.MIN_GROUPED = grouped_min
                single.append(sum(spent))
            d = statistics.median(totals) * 1e3
            b = statistics.median(booleans) * 1e3
            b1 = statistics.median(single) * 1e3
            py = max(d - b, 0.0)
            print(f"{label:34s} {len(m.parts):9d} {m.triangle_count:9d} {d:9.1f} {b:10.1f} {py:9.1f} "
                  f"{py / b if b > 0 else float('inf'):7.2f} {b1:10.1f} {b1 / b if b > 0 else 1.0:9.2f}")
    finally:
        split_model.compose = compose
        split_model.MIN_GROUPED = grouped_min
    print(f"(building runs={runs}, load average={os.getloadavg()[0]:.2f}; the machine is shared: "
          "numbers are noisy)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--variations", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--building-runs", type=int, default=5)
    ap.add_argument("--only-buildings", action="store_true")
    args = ap.parse_args(argv)

    if args.only_buildings:
        per_building(args.building_runs)
        return 0
    from grammarkit.split import derive

    g = _load()
    model = derive(g, seed=0)  # warm-up: compile (cached), part meshes, imports
    model.mesh
    recipe = record_recipe(g)
    floor(recipe)

    # interleave engine and floor runs so that load changes affect both alike
    t_derive, t_mesh, t_floor = [], [], []
    for _ in range(args.runs):
        t_derive += _timed(lambda: derive(g, seed=0), 1)
        t_mesh += _timed(lambda: derive(g, seed=0).mesh, 1)
        t_floor += _timed(lambda: floor(recipe), 1)
    med_d, med_m, med_f = (statistics.median(t) * 1e3 for t in (t_derive, t_mesh, t_floor))

    n = args.variations
    seq = par = None
    if n > 0:
        t = time.perf_counter()
        _variation_chunk((0, n, 1))
        seq = time.perf_counter() - t
    if n > 0 and args.workers > 1:
        chunks = [(i * n // args.workers, (i + 1) * n // args.workers - i * n // args.workers, 1)
                  for i in range(args.workers)]
        t = time.perf_counter()
        with mp.get_context("spawn").Pool(args.workers) as pool:
            pool.map(_variation_chunk, chunks)
        par = time.perf_counter() - t

    print(f"Paris building: {len(model.parts)} terminals, {model.shape_count} shapes, "
          f"{model.triangle_count} triangles, {len(recipe[0])} added + {len(recipe[1])} cut solids")
    print(f"{'measure':44s} {'median ms':>10s} {'target':>10s}")
    print(f"{'derive (engine: rules + booleans + mesh)':44s} {med_d:10.1f} {'<= 30':>10s}")
    print(f"{'derive + coloured trimesh':44s} {med_m:10.1f} {'':>10s}")
    print(f"{'floor (same solids, direct manifold3d)':44s} {med_f:10.1f} {'':>10s}")
    print(f"{'ratio derive / floor':44s} {med_d / med_f:10.2f} {'<= 2.0':>10s}")
    if seq is not None:
        print(f"{'variations: buildings/s, 1 process':44s} {n / seq:10.1f} {f'({n} in {seq:.1f} s)':>10s}")
    if par is not None:
        print(f"{f'variations: buildings/s, {args.workers} processes':44s} {n / par:10.1f} "
              f"{f'({n} in {par:.1f} s)':>10s}")
    print(f"(runs={args.runs}, cpu_count={os.cpu_count()}, load average={os.getloadavg()[0]:.2f})")
    per_building(args.building_runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
