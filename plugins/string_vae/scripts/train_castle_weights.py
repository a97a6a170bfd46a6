"""Reproduce the shipped string-VAE weights: grammarkit_string_vae/weights/castle.vae.

    python plugins/string_vae/scripts/train_castle_weights.py [--work DIR] [--out PATH]

1. A dataset of the castle grammar (grammars/tiling/castle) from the graph sampler: 2,500
   results asked for, 8 iterations, isomorphism dedupe, at most 8,000 attempts per iteration,
   seed 1, 10 strings per graph (about 20 minutes on one core; `grammarkit dataset` does the
   same from the command line).
2. The string VAE on it: 40 scheduled epochs (KL warm-up over 20), stopped after EPOCHS, two
   strings per graph per epoch, KL weight 0.1, word dropout 0.25, seed 0, one torch thread
   (about 70 minutes on one free core).

Everything is seeded, so the same inputs give the same file (torch's CPU kernels with one
thread are deterministic).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
EPOCHS = 40  # scheduled epochs
STOP_AFTER = None  # set to the epoch the shipped model stopped at (see its training history)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("castle_weights_work"))
    ap.add_argument("--out", type=Path, default=ROOT / "plugins/string_vae/grammarkit_string_vae/weights/castle.vae")
    ap.add_argument("--stop-after", type=int, default=STOP_AFTER)
    args = ap.parse_args()
    from grammarkit.dsl import load
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset
    from grammarkit_string_vae.train import TrainConfig
    from grammarkit_string_vae.vaefile import train_and_save

    folder = args.work / "castle_ds"
    if not (folder / "dataset.json").exists():
        grammar = load(ROOT / "grammars/tiling/castle/castle.grammar")
        ds, report = build_dataset(grammar, source="graph-sampler", n=2500, seed=1, iterations=8,
                                   options={"dedupe": "isomorphism", "max_attempts": 8000}, strings_per_graph=10)
        write_dataset(ds, folder, overwrite=True)
        print(f"dataset: {report}")
    ds = load_dataset(folder)
    cfg = TrainConfig(epochs=EPOCHS, strings_per_epoch=2, beta=0.1, seed=0, threads=1, stop_after=args.stop_after)
    summary = train_and_save(ds, cfg, args.out, progress=lambda r: print(r, flush=True))
    print(f"wrote {args.out}: {summary}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
