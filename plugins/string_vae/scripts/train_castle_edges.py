"""Reproduce the shipped edge-category predictor, grammarkit_string_vae/weights/castle.edges
(`builtin:castle`), and record how its accuracy grows with epochs.

    python plugins/string_vae/scripts/train_castle_edges.py [--dataset castle_weights_work/castle_ds]
        [--out PATH] [--epochs 40] [--held-out 40] [--paper]

The dataset is the one `train_castle_weights.py` builds (the shipped VAE's: 2,502 castle graphs;
run that script first, or its dataset step).
The first `--held-out` graphs of the seed-0 permutation (the same graphs
`benchmarks/bench_instantiation.py` evaluates on) are left out; the predictor trains on the
others (at most 100 of them are its validation graphs), `--strings-per-graph` strings per graph
per epoch, one torch thread, seed 0. Every epoch's validation accuracy (per character, voted by
majority, log-prob sum and jointly) is printed and kept in the model file's training history.

Everything is seeded and runs on one thread, so the same inputs give the same network tensors
(the shipped file: the defaults, 40 epochs of the bidirectional predictor, 3,270 s on one core
under a load average of 5-9; its metadata also records the time limit of 3,600 s it was run
with, which it did not reach). `--paper` trains the paper's left-to-right LSTM instead (the
benchmark's baseline; not shipped).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", type=Path, default=Path("castle_weights_work/castle_ds"))
    ap.add_argument("--out", type=Path, default=ROOT / "plugins/string_vae/grammarkit_string_vae/weights/castle.edges")
    ap.add_argument("--epochs", type=int, default=40)
    ap.add_argument("--time-limit", type=float, default=None, help="stop after the epoch that passes this (s)")
    ap.add_argument("--held-out", type=int, default=40)
    ap.add_argument("--strings-per-graph", type=int, default=4)
    ap.add_argument("--paper", action="store_true", help="the paper's predictor (left-to-right LSTM, majority votes)")
    args = ap.parse_args()
    import numpy as np

    from grammarkit.dsl import load
    from grammarkit_string_vae.dataset import Dataset, load_dataset
    from grammarkit_string_vae.edgemodel import EdgeTrainConfig, save_edge_model, train_edge_model

    grammar = load(ROOT / "grammars/tiling/castle/castle.grammar")
    full = load_dataset(args.dataset)
    rng = np.random.default_rng(0)
    idx = [int(i) for i in rng.permutation(len(full)) if full.frames[i] is not None]
    keep = sorted(idx[args.held_out:])
    ds = Dataset(dict(full.meta), [full.graphs[i] for i in keep], [full.strings[i] for i in keep],
                 [full.ids[i] for i in keep], [full.sources[i] for i in keep], [full.frames[i] for i in keep],
                 full.path, [full.variants[i] for i in keep])
    kw = dict(bidirectional=False, voting="majority") if args.paper else {}
    cfg = EdgeTrainConfig(epochs=args.epochs, time_limit=args.time_limit, threads=1, seed=0,
                          strings_per_graph=args.strings_per_graph, **kw)
    t0 = time.perf_counter()
    em = train_edge_model(ds, grammar, cfg, progress=lambda r: print(json.dumps(r), flush=True))
    save_edge_model(em, args.out)
    print(f"wrote {args.out} ({len(keep)} graphs, {time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
