"""How far each regressed parameter moves the drawing across its range, at the refinement
score's canvas: the basis of what refinement can recover from a sketch.

    python plugins/sketch/scripts/visibility.py [--short 128] [--bases 4] [--types Roof,Window]

For every parameter the shipped regressors estimate: the drawing (exact lines, the stage
camera, the score canvas with its shorter side `--short` pixels) at the bottom and at the top of
the parameter's range, the others at `--bases` points (the middle of the ranges, then random);
printed are the mean over those points of the Hausdorff distance (the largest displacement of a
line, pixels) and of the symmetric mean chamfer distance (the average one) between the two.
"""
from __future__ import annotations

import argparse

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", type=int, default=128, help="score canvas, shorter side (pixels)")
    ap.add_argument("--bases", type=int, default=4, help="values of the other parameters tried")
    ap.add_argument("--types", default=None, help="object types (default: all with models)")
    ap.add_argument("--models", default=None)
    args = ap.parse_args()

    from grammarkit_sketch.dataset import quick_size
    from grammarkit_sketch.image import distance_map
    from grammarkit_sketch.recognizer import get_recognizer
    from grammarkit_sketch.refine import Scorer

    rec = get_recognizer(args.models)
    lib = rec.library
    types = args.types.split(",") if args.types else [t for t in lib.types if t in rec.models.types]
    print(f"{'parameter':<34}{'Hausdorff px':>13}{'chamfer px':>11}")
    for t in types:
        tm = rec.models.type_model(t)
        stage = tm.stage
        print(f"{t} (score canvas {'x'.join(map(str, quick_size(stage, args.short)))})")
        for info in lib.snippets_of(t):
            reg = tm.regressors.get(info.name)
            if reg is None or not reg.params:
                continue
            names = list(reg.params)
            blank = np.zeros(quick_size(stage, args.short)[::-1], bool)
            sc = Scorer(rec.deriver(stage), info, names, dict(info.defaults()), blank, short=args.short)
            rng = np.random.default_rng(0)
            bases = [np.full(len(names), 0.5)] + [rng.random(len(names)) for _ in range(args.bases - 1)]
            for j, n in enumerate(names):
                far, mean = [], []
                for base in bases:
                    lo, hi = base.copy(), base.copy()
                    lo[j], hi[j] = 0.0, 1.0
                    a, b = sc.render(lo), sc.render(hi)
                    if a is None or b is None or not a.any() or not b.any():
                        continue
                    da, db = distance_map(a), distance_map(b)
                    far.append(max(float(db[a].max()), float(da[b].max())))
                    mean.append(0.5 * (float(db[a].mean()) + float(da[b].mean())))
                if far:
                    print(f"  {info.name + '.' + n:<32}{np.mean(far):>13.1f}{np.mean(mean):>11.2f}")
                else:
                    print(f"  {info.name + '.' + n:<32}{'(no drawable pair)':>24}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
