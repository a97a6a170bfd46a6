"""Large tiling models: many round, finely tessellated parts (issue 19) and 100k box parts (issue 11).

    python benchmarks/bench_tiling_large.py [--columns 500] [--sections 500] [--runs 1]
    python benchmarks/bench_tiling_large.py --boxes 100000

Round model (`--columns C`): C columns on a grid, each a cylinder "Post" (2 x sections x 2
triangles) carrying a UV sphere "Ball" (about as many triangles) on top; neighbouring posts
touch along a line. The defaults give 1,000 parts and about 2M triangles (the issue-19 target:
`validate` and `learn` in <= 30 s each, progress shown). Reported per stage: wall time (median
of --runs) and the process's peak resident memory. Per-part analysis (frames, turn symmetries,
mirror planes) works on a bounded vertex sample of each part (grammarkit.tiling.frames:
SAMPLE_CAP vertices, matched within 1e-5 x the part's size against all of its vertices).

Box model (`--boxes N`): the cube-and-beam lattice of benchmarks/bench_tiling.py with about N
parts; the issue-11 target is 100k parts validated in <= 6 s and <= 600 MB. The baseline is
the same validate on a 10x smaller lattice (ratio ~10 means linear growth).

The machine is shared (2 cores, several agents): numbers measured while others run are noisy.
"""
from __future__ import annotations

import argparse
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tiling"))
from _timing import median_time  # noqa: E402 - benchmarks/ is on sys.path

from grammarkit.tiling import Assembly, Part, learn, validate  # noqa: E402


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def current_mb() -> float:
    """Resident memory now (Linux /proc; the peak where that is missing)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() / 2**20
    except OSError:
        return peak_mb()


def round_model(columns: int, sections: int, name: str = "round") -> Assembly:
    post = trimesh.creation.cylinder(radius=0.5, height=1.0, sections=sections)
    post.apply_translation((0, 0, 0.5))
    n = max(8, int(round(math.sqrt(sections / 2))))
    ball = trimesh.creation.uv_sphere(radius=0.45, count=(n, 2 * n))  # balls of neighbours stay apart
    ball.apply_translation((0, 0, 1.45))
    side = max(1, int(math.ceil(math.sqrt(columns))))
    parts = []
    for k in range(columns):
        i, j = divmod(k, side)
        T = np.eye(4)
        T[:3, 3] = (i * 1.0, j * 1.0, 0.0)
        for t, m in (("Post", post), ("Ball", ball)):
            parts.append(Part(f"{t}.{k}", t, trimesh.Trimesh(m.vertices + T[:3, 3], m.faces, process=False), T))
    return Assembly(parts, name=f"{name}{columns}")


def run_round(args) -> None:  # noqa: ANN001
    small = round_model(4, args.sections, "small")
    big = round_model(args.columns, args.sections)
    tris = sum(len(p.mesh.faces) for p in big.parts)
    print(f"round model: {len(big)} parts, {tris:,} triangles; grammar learned from {len(small)} parts")
    stages = []

    def say(stage: str) -> None:
        stages.append((time.perf_counter(), stage))
        if args.progress:
            print(f"  .. {stage}", file=sys.stderr)

    t = time.perf_counter()
    g = learn([small], name="round", neighbors="none", progress=say)
    t_small = time.perf_counter() - t
    rows = [("learn (4 columns)", t_small, peak_mb())]
    t_val = median_time(lambda: validate(g, big, progress=say), args.runs)
    r = validate(g, big)
    rows.append((f"validate ({len(big)} parts)", t_val, peak_mb()))
    t_learn = median_time(lambda: learn([big], name="big", progress=say), args.runs)
    rows.append((f"learn ({len(big)} parts)", t_learn, peak_mb()))
    print(f"{'stage':<26} {'seconds':>8} {'peak MB':>8}")
    for name, s, mb in rows:
        print(f"{name:<26} {s:8.2f} {mb:8.0f}")
    print(f"validate ok: {r.ok} ({r.contacts} contacts); target <= 30 s each: "
          f"{'met' if max(t_val, t_learn) <= 30 else 'NOT met'}")


def run_boxes(args) -> None:  # noqa: ANN001
    from bench_tiling import lattice_of_about
    from _tiling_helpers import lattice

    g = learn([lattice(3, 3, 3)], name="lattice")
    rows = []
    for n in (args.boxes // 10, args.boxes):
        model = lattice_of_about(n)
        before = current_mb()  # the model itself (100k trimesh parts) is part of the process
        s = median_time(lambda: validate(g, model), args.runs)
        rows.append((len(model), s, before, peak_mb()))
        del model
    print(f"{'parts':>8} {'validate s':>10} {'model MB':>9} {'peak MB':>8}")
    for parts, s, before, mb in rows:
        print(f"{parts:8d} {s:10.2f} {before:9.0f} {mb:8.0f}")
    print(f"ratio {rows[1][0] / rows[0][0]:.1f}x parts -> {rows[1][1] / rows[0][1]:.1f}x time; "
          f"target 100k <= 6 s and <= 600 MB: {'met' if rows[1][1] <= 6 and rows[1][3] <= 600 else 'NOT met'}")


def main(argv=None) -> int:  # noqa: ANN001
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--columns", type=int, default=500)
    ap.add_argument("--sections", type=int, default=500)
    ap.add_argument("--boxes", type=int, default=0)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--progress", action="store_true")
    args = ap.parse_args(argv)
    if args.boxes:
        run_boxes(args)
    else:
        run_round(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
