"""How far each regressed parameter moves the drawing across its range, at the refinement
score's canvas: the basis of what refinement can recover from a sketch.

    python plugins/sketch/scripts/visibility.py [--short 128] [--bases 4] [--types Roof,Window]

For every parameter the shipped regressors estimate: the drawing (exact lines, the stage
camera, the score canvas with its shorter side `--short` pixels) at the bottom and at the top of
the parameter's range, the others at `--bases` points (the middle of the ranges, then random);
printed are the mean over those points of the Hausdorff distance (the largest displacement of a
line) and of the symmetric mean chamfer distance (the average one) between the two, in pixels of
the 128 px canvas (grammarkit_sketch.visibility).
"""
from __future__ import annotations

import argparse


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", type=int, default=128, help="score canvas, shorter side (pixels)")
    ap.add_argument("--bases", type=int, default=4, help="values of the other parameters tried")
    ap.add_argument("--types", default=None, help="object types (default: all with models)")
    ap.add_argument("--models", default=None)
    args = ap.parse_args()

    from grammarkit_sketch.dataset import quick_size
    from grammarkit_sketch.recognizer import get_recognizer
    from grammarkit_sketch.visibility import WEAK_REACH, parameter_reach

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
            for r in parameter_reach(rec.deriver(stage), info, reg.params, args.bases, args.short):
                note = "  weak" if r.weak else ""
                print(f"  {info.name + '.' + r.parameter:<32}{r.hausdorff:>13.1f}{r.chamfer:>11.2f}{note}")
    print(f"weak: moves its lines less than {WEAK_REACH:g} px (of the 128 px canvas) over its whole range")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
