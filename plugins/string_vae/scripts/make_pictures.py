"""Pictures for docs/string-vae.md: shapes instantiated from strings, parts coloured by type.

    python plugins/string_vae/scripts/make_pictures.py --vae castle.vae --edges castle.edges \
        [--grammar grammars/tiling/castle/castle.grammar] [--out docs/images] [--count 3] [--seed 0]

Samples valid strings (masked decoding, perturbation; training graphs allowed), predicts their
edge categories, instantiates them (`derive --backend string-vae` with categories) and writes
docs/images/string_instantiated.png (the shapes side by side); prints each string with its
predicted and used categories for the caption.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
PALETTE = [(200, 170, 120), (150, 150, 160), (170, 80, 60), (90, 130, 170), (110, 160, 90), (220, 200, 90)]


def coloured(asm):  # noqa: ANN001, ANN201
    from grammarkit.tiling import Assembly, Part

    types = sorted({p.type for p in asm.parts})
    parts = []
    for p in asm.parts:
        m = p.mesh.copy()
        m.visual.face_colors = (*PALETTE[types.index(p.type) % len(PALETTE)], 255)
        parts.append(Part(p.id, p.type, m, p.transform))
    return Assembly(parts)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vae", type=Path, required=True)
    ap.add_argument("--edges", type=Path, required=True)
    ap.add_argument("--grammar", type=Path, default=ROOT / "grammars/tiling/castle/castle.grammar")
    ap.add_argument("--out", type=Path, default=ROOT / "docs/images")
    ap.add_argument("--count", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mode", default="perturb")
    ap.add_argument("--dataset", type=Path, default=None,
                    help="instantiate strings of this dataset's graphs (from its end) instead of sampling the VAE")
    args = ap.parse_args()
    from PIL import Image

    if args.dataset is not None:
        tiles = from_dataset(args)
    else:
        tiles = from_vae(args)
    out = Image.new("RGB", (360 * max(1, len(tiles)), 300), "white")
    for i, t in enumerate(tiles):
        out.paste(t.convert("RGB"), (360 * i, 0))
    args.out.mkdir(parents=True, exist_ok=True)
    out.save(args.out / "string_instantiated.png", optimize=True)
    print(f"wrote {args.out / 'string_instantiated.png'}")
    return 0


def from_dataset(args):  # noqa: ANN001, ANN201
    """Strings of the dataset's last graphs, their predicted categories, the instantiated shapes."""
    import numpy as np

    from grammarkit.dsl import load
    from grammarkit.geometry.render import render
    from grammarkit_string_vae.dataset import load_dataset
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.generate import token_categories
    from grammarkit_string_vae.instantiate import Instantiator
    from grammarkit_string_vae.strings import decode, strings_of

    grammar = load(args.grammar)
    em = load_edge_model(args.edges, grammar)
    ds = load_dataset(args.dataset)
    inst = Instantiator(grammar, em.categories)
    tiles = []
    for gi in range(len(ds) - 1, -1, -1):
        if len(tiles) >= args.count:
            break
        text = strings_of(ds.graphs[gi], em.alphabet, 1, rng=np.random.default_rng(args.seed))[0]
        g = decode(text, em.alphabet).graph
        ranks = em.rankings(g, seed=args.seed)
        res = inst.instantiate(g, ranks, seed=args.seed)
        if not res.ok:
            continue
        pred = token_categories(text, em.alphabet, em.categories, {e: r[0] for e, r in ranks.items() if r})
        print(f"{ds.ids[gi]}: {text}\n  predicted categories: {pred}\n  tries {res.tries}, "
              f"{res.monte_carlo} edge(s) not by the first predicted category")
        tiles.append(render(coloured(res.assembly), size=(360, 300)))
    return tiles


def from_vae(args):  # noqa: ANN001, ANN201
    from grammarkit.geometry.render import render
    from grammarkit.run import iter_results

    opts = {"model": str(args.vae), "categories": str(args.edges), "mode": args.mode,
            "include_training": "true", "max_decodes": "4000"}
    tiles = []
    for res in iter_results(str(args.grammar), backend="string-vae", n=args.count, seed=args.seed, options=opts):
        print(f"{res.id}: {res.extra['string']}  (novel: {res.extra['novel']})\n"
              f"  categories used: {res.extra['categories']}\n  predicted:       {res.extra['predicted']}\n"
              f"  {res.extra['instantiation']}")
        tiles.append(render(coloured(res.model), size=(360, 300)))
    return tiles


if __name__ == "__main__":
    sys.exit(main())
