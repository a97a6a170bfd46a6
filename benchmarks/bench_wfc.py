"""Issue 28's acceptance matrix: learned from valid WFC tilings, held-out valid tilings accepted
and corrupted ones rejected, per tile set (grammars/tiling/wfc/wfc_sets.py: tile sets that
are not the project's own examples) and learn mode.

    python benchmarks/bench_wfc.py [--sets knots circuit summer pipes3d] [--per-kind 2]
                                   [--modes default observed multisets]
    python benchmarks/bench_wfc.py --foreign [roads hexes town] [--modes ... turned-training]

`--foreign` runs the tile sets of grammars/tiling/wfc/foreign_sets.py instead (square plates
with corner contacts and a chiral tile, hexagonal plates, a stacked town under gravity; a
backtracking generator and an independent checker; held-out tilings also turned by 30 degrees;
ten corruption kinds). Mode `turned-training` learns from training tilings turned off the
world axes, `few-training` from the first 3 training tilings only.

Modes: `default` is `learn`'s defaults; `observed` is `sockets=False` (only the site pairs the
examples show); `multisets` is Kalojanov's exact neighbour multisets (`neighbors="multisets"`).
Each cell is rejected/total (accepted/total for held-out valid tilings)."""
from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("wfc_sets", ROOT / "grammars" / "tiling" / "wfc" / "wfc_sets.py")
W = importlib.util.module_from_spec(_spec)
sys.modules["wfc_sets"] = W
_spec.loader.exec_module(W)

_fspec = importlib.util.spec_from_file_location("foreign_sets", ROOT / "grammars" / "tiling" / "wfc" / "foreign_sets.py")
F = importlib.util.module_from_spec(_fspec)
sys.modules["foreign_sets"] = F
_fspec.loader.exec_module(F)

MODES = {"default": {}, "observed": {"sockets": False}, "multisets": {"neighbors": "multisets"},
         "turned-training": {"turn_train": True}, "few-training": {"train": 3}}


def foreign(names: list[str], modes: list[str], per_kind: int, held_out: int | None) -> int:
    """The matrix on foreign_sets' tile sets."""
    kinds = list(F.KINDS)
    cols = ["tile set", "mode", "held-out valid", "turned 30°", "notched", *kinds, "seconds"]
    rows, failures = [], []
    with tempfile.TemporaryDirectory() as d:
        for name in names:
            for mode in modes:
                t0 = time.perf_counter()
                try:
                    r = F.acceptance(name, Path(d) / f"{name}_{mode}", held_out=held_out, per_kind=per_kind,
                                     **MODES[mode])
                except Exception as exc:  # a row that could not be measured says why
                    rows.append([name, mode, *(["error"] * (len(cols) - 3)), f"{time.perf_counter() - t0:.1f}"])
                    failures.append(f"{name}/{mode}: {type(exc).__name__}: {str(exc).splitlines()[0][:300]}")
                    print(" | ".join(rows[-1]), failures[-1], file=sys.stderr, flush=True)
                    continue
                cells = [f"{a}/{b}" if b else "–" for a, b in (r["valid"], r["turned"], r["notched"],
                                                              *(r[k] for k in kinds))]
                rows.append([name, mode, *cells, f"{time.perf_counter() - t0:.1f}"])
                failures += [f"{name}/{mode}: {f.splitlines()[0]}" for f in r["failures"]]
                print(" | ".join(rows[-1]), file=sys.stderr, flush=True)
    _table(cols, rows)
    for f in failures[:20]:
        print("  " + f)
    return 0


def _table(cols: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    print("| " + " | ".join(c.ljust(w) for c, w in zip(cols, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="+", default=sorted(W.SETS), choices=sorted(W.SETS))
    ap.add_argument("--modes", nargs="+", default=["default"], choices=sorted(MODES))
    ap.add_argument("--per-kind", type=int, default=2)
    ap.add_argument("--foreign", nargs="*", choices=["roads", "hexes", "town"], default=None,
                    help="foreign_sets' tile sets (all three when given without names)")
    ap.add_argument("--held-out", type=int, default=None, help="held-out tilings per set (default: all)")
    args = ap.parse_args(argv)
    if args.foreign is not None:
        return foreign(args.foreign or ["roads", "hexes", "town"], args.modes, args.per_kind, args.held_out)
    if {"turned-training", "few-training"} & set(args.modes):
        ap.error("modes turned-training and few-training are for --foreign tile sets")
    cols = ["tile set", "mode", "tiles", "train", "held-out valid accepted", *(f"{k} rejected" for k in W.KINDS), "seconds"]
    rows = []
    failures = []
    with tempfile.TemporaryDirectory() as d:
        for name in args.sets:
            ts = W.SETS[name]
            for mode in args.modes:
                t0 = time.perf_counter()
                r = W.acceptance(ts, Path(d) / f"{name}_{mode}", per_kind=args.per_kind, **MODES[mode])
                cells = [f"{a}/{b}" for a, b in (r["accepted"], *(r[k] for k in W.KINDS))]
                rows.append([name, mode, str(len(ts.tiles)), str(len(W.TRAINING_SIZES[ts.dims])), *cells,
                             f"{time.perf_counter() - t0:.1f}"])
                failures += [f"{name}/{mode}: {f.splitlines()[0]}" for f in r["failures"]]
                print(" | ".join(rows[-1]), file=sys.stderr, flush=True)
    _table(cols, rows)
    for f in failures[:20]:
        print("  " + f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
