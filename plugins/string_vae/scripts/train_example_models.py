"""Reproduce the small shipped string-VAE models of the tiling examples other than the castle:
grammarkit_string_vae/weights/NAME.vae and NAME.edges for NAME in balltrack, facade, coast.

    python plugins/string_vae/scripts/train_example_models.py balltrack [--work DIR] [--out-dir DIR]

1. A dataset of the example's grammar from the graph sampler: 400 results asked for, 12
   iterations, isomorphism dedupe, seed 1, 10 strings per graph, plus the grammar's examples (the
   sampler runs dry early on these grammars: balltrack 12 graphs, facade 4, coast 2).
2. The string VAE on it: small (latent 32, decoder GRU 96), 60 epochs, KL weight 0.2 (the
   default), every string every epoch, seed 0, one torch thread.
3. The edge-category predictor: bidirectional LSTM of 64 units, 20 epochs, seed 0, one thread.

Everything is seeded and runs on one thread (torch.set_num_threads(1)), so the same inputs give
the same tensors. The time limits only guard a very busy machine: the runs measured for the
shipped files finished their epochs before them. The grammar hash is printed and stored in both
files (loading them checks it).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
GRAMMARS = {"balltrack": "grammars/tiling/balltrack/balltrack.grammar",
            "facade": "grammars/tiling/facade/facade.grammar",
            "coast": "grammars/tiling/wfc/coast.grammar"}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("name", choices=sorted(GRAMMARS))
    ap.add_argument("--work", type=Path, default=Path("example_models_work"))
    ap.add_argument("--out-dir", type=Path, default=ROOT / "plugins/string_vae/grammarkit_string_vae/weights")
    ap.add_argument("--time-limit", type=float, default=300.0, help="per training step (s)")
    args = ap.parse_args()
    import torch

    from grammarkit.dsl import load
    from grammarkit.run import grammar_hash
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset
    from grammarkit_string_vae.edgemodel import EdgeTrainConfig, save_edge_model, train_edge_model
    from grammarkit_string_vae.train import TrainConfig
    from grammarkit_string_vae.vaefile import train_and_save

    torch.set_num_threads(1)
    grammar = load(ROOT / GRAMMARS[args.name])
    print(f"grammar {grammar.name}: hash {grammar_hash(grammar)}", flush=True)
    folder = args.work / f"{args.name}_ds"
    t0 = time.perf_counter()
    if not (folder / "dataset.json").exists():
        ds, report = build_dataset(grammar, source="graph-sampler", n=400, seed=1, iterations=12,
                                   options={"dedupe": "isomorphism"}, strings_per_graph=10)
        write_dataset(ds, folder, overwrite=True)
        print(f"dataset: {report} ({time.perf_counter() - t0:.0f} s)", flush=True)
    ds = load_dataset(folder)
    t1 = time.perf_counter()
    cfg = TrainConfig(epochs=60, latent=32, hidden=96, seed=0, threads=1, time_limit=args.time_limit)
    summary = train_and_save(ds, cfg, args.out_dir / f"{args.name}.vae", progress=lambda r: print(r, flush=True))
    print(f"wrote {args.name}.vae: {summary} ({time.perf_counter() - t1:.0f} s)", flush=True)
    t2 = time.perf_counter()
    ecfg = EdgeTrainConfig(epochs=20, hidden=64, seed=0, threads=1, time_limit=args.time_limit)
    em = train_edge_model(ds, grammar, ecfg, progress=lambda r: print(r, flush=True))
    save_edge_model(em, args.out_dir / f"{args.name}.edges")
    print(f"wrote {args.name}.edges ({time.perf_counter() - t2:.0f} s); total {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
