"""Measure placed decoding on the castle with the shipped models (docs/string-vae.md, "Placed
decoding"): perturbation samples decoded with the placement masks and the length prior, each
built and validated; and the training strings placed as written (do the masks let buildable
strings through, and does the beam keep the right placement?).

    python plugins/string_vae/scripts/measure_placed.py --samples 8 --strings 8 --width 8 --steps 150
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--strings", type=int, default=8, help="training strings placed as written")
    ap.add_argument("--width", type=int, default=8)
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-tokens", type=int, default=None, help="perturb only training points whose string is at "
                    "most this long")
    a = ap.parse_args()

    from grammarkit.dsl import load
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.instantiate import Instantiator
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.placed import PlacedDecoder

    g = load(ROOT / "grammars/tiling/castle/castle.grammar")
    vae = load_vae("builtin:castle", grammar=g)
    inst = Instantiator(g, load_edge_model("builtin:castle", g).categories)
    dec = PlacedDecoder(vae, inst, width=a.width, expansions=a.steps)
    rng = np.random.default_rng(a.seed)
    mu = vae.train_mu.numpy()
    built = valid = 0
    t0 = time.perf_counter()
    seeds = [j for j, t in enumerate(vae.train_strings) if a.max_tokens is None or len(t) <= a.max_tokens]
    for i in range(a.samples):
        j = seeds[int(rng.integers(len(seeds)))]
        d = dec.decode(mu[j] + rng.uniform(-0.25, 0.25, size=mu.shape[1]), len(vae.train_strings[j]), seed=i)
        if d.valid:
            valid += 1
            asm, _problem = inst.build(d.graph, d.placement.frames, d.placement.variants)
            built += asm is not None
    dt = time.perf_counter() - t0
    print(f"samples: {a.samples}, valid placed strings {valid}, built and validated {built}, "
          f"{dt / max(1, a.samples):.1f} s per latent point; masked placements {dec.stats}")
    placed = 0
    t0 = time.perf_counter()
    strings = sorted(vae.train_strings[:a.strings], key=len)
    for s in strings:
        d = dec.place_text(s, steps=3000)
        placed += bool(d.valid and inst.build(d.graph, d.placement.frames, d.placement.variants)[0] is not None)
    print(f"training strings placed as written and built: {placed}/{len(strings)} "
          f"({(time.perf_counter() - t0) / max(1, len(strings)):.1f} s each, width {a.width})")


if __name__ == "__main__":
    main()
