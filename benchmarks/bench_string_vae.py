"""String VAE (Kalojanov 2019, section 5) with grammar-masked decoding: validity, uniqueness,
novelty, sampling yields and the latent-graph table, on CPU.

    python benchmarks/bench_string_vae.py [--example castle] [--graphs 2000] [--train-seconds 600]
        [--samples 1000] [--runs 3] [--work DIR] [--molecules 500] [--quick]

1. Dataset: `--graphs` shape graphs made by the graph sampler from the example's grammar
   (isomorphism dedupe, plus the examples), 10 strings per graph (`grammarkit dataset`). Kept in
   `--work` and reused when it is there (delete it to rebuild).
2. Training: the sequence VAE, time-limited to `--train-seconds` (the acceptance budget is 10
   minutes on 2 cores), `--threads` torch threads. The trained model is kept in `--work` too.
3. Prior samples (`--samples`, z ~ N(0, I)) decoded freely (the paper's method, the baseline)
   and with the grammar mask: validity, unique@1k, novelty, internal diversity, seconds (median
   of `--runs` decodes of the same samples; the outputs are identical between runs).
4. Sampling modes (perturb, interpolate, path): decoded points, valid points and new graphs per
   decoded point, free and masked.
5. The paper's Table 2: components and path weights of the latent search graph versus the naive
   string-similarity graph.
6. Molecules (needs RDKit; skipped with the reason otherwise): string round trip on
   `--molecules` molecules shipped with RDKit, then a short training run and free/masked validity,
   with RDKit's own sanitisation as an independent check.

The machine may be shared: times are then noisy (the script prints the load average).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_average() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "?"


def table(head: list[str], rows: list[list]) -> str:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        out.append("| " + " | ".join(_fmt(x) for x in r) + " |")
    return "\n".join(out)


def _fmt(x) -> str:  # noqa: ANN001
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.3f}" if abs(x) < 100 else f"{x:.0f}"
    return str(x)


def build_or_load_dataset(args, work: Path):  # noqa: ANN001, ANN201
    from grammarkit.dsl import load
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset

    folder = work / f"{args.example}_ds"
    if (folder / "dataset.json").exists():
        ds = load_dataset(folder)
        print(f"dataset: reused {folder} ({len(ds)} graphs, {ds.meta['strings']} strings)")
        return ds, None
    grammar = load(ROOT / "grammars" / "tiling" / args.example / f"{args.example}.grammar")
    t0 = time.perf_counter()
    ds, report = build_dataset(grammar, source="graph-sampler", n=args.graphs, seed=args.seed,
                               iterations=args.iterations, strings_per_graph=10,
                               options={"dedupe": "isomorphism", "max_attempts": args.max_attempts})
    seconds = time.perf_counter() - t0
    write_dataset(ds, folder, overwrite=True)
    print(f"dataset: built {folder} in {seconds:.0f} s: {report}")
    return load_dataset(folder), seconds


def train_or_load(args, ds, work: Path):  # noqa: ANN001, ANN201
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.train import TrainConfig
    from grammarkit_string_vae.vaefile import train_and_save

    path = work / f"{args.example}.vae"
    if path.exists() and not args.retrain:
        vae = load_vae(path)
        tr = vae.meta["training"]
        print(f"model: reused {path} (trained {tr['seconds']} s, {len(tr['history'])} epochs)")
        return vae, tr
    cfg = TrainConfig(epochs=args.epochs, time_limit=args.train_seconds, threads=args.threads,
                      seed=args.seed, strings_per_epoch=args.strings_per_epoch)

    def show(row: dict) -> None:
        print(f"  epoch {row['epoch']}: loss {row['loss']:.2f} KL {row['kl']:.2f} token acc "
              f"{row['val_token_acc']:.3f} recon {row['val_recon']:.2f} validity {row['validity']:.2f} "
              f"({row['seconds']:.0f} s)", flush=True)

    summary = train_and_save(ds, cfg, path, progress=show)
    vae = load_vae(path)
    print(f"model: trained {summary['epochs']} epochs in {summary['seconds']:.0f} s on {args.threads} "
          f"thread(s) ({summary['train_graphs']} graphs, {summary['train_strings']} strings); "
          f"{summary.get('stopped') or 'all epochs done'}")
    return vae, vae.meta["training"]


def prior_table(vae, args) -> None:  # noqa: ANN001
    import torch

    from grammarkit_string_vae.decoding import decode_latents
    from grammarkit_string_vae.graphs import GraphSet
    from grammarkit_string_vae.metrics import generator_metrics
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    train_graphs = Sampler(vae, SamplingSettings(), seed=args.seed).train_graphs
    train = GraphSet()
    for g in train_graphs:
        train.add(g)
    z = torch.randn(args.samples, vae.model.config.latent, generator=torch.Generator().manual_seed(args.seed))
    rows, times = [], {}
    for mode in ("free", "masked"):
        secs = []
        out = None
        for _ in range(args.runs):
            t0 = time.perf_counter()
            out = decode_latents(vae.model, z, vocab=vae.vocab, rules=vae.rules, mode=mode, seed=args.seed,
                                 temperature=args.temperature)
            secs.append(time.perf_counter() - t0)
        m = generator_metrics(out, train, train_graphs, k=min(1000, args.samples))
        times[mode] = statistics.median(secs)
        rep = m["repaired"]
        rows.append([mode, m["samples"], m["validity"], m[f"unique@{min(1000, args.samples)}"], m["novelty"],
                     m["internal_diversity"], m["mean_parts"], f"{rep['backtrack']}/{rep['resample']}/{rep['rules']}/{rep['failed']}",
                     times[mode], m["valid"] / max(times[mode], 1e-9)])
    base = rows[0][2] or 0
    print(f"\n## Prior samples: {args.samples} latent points z ~ N(0, I), temperature {args.temperature} "
          f"(median of {args.runs} decodes)\n")
    print(table(["decoding", "samples", "validity", f"unique@{min(1000, args.samples)}", "novelty",
                 "internal diversity", "mean parts", "repaired (backtrack/resample/rules/failed)", "seconds",
                 "valid strings/s"], rows))
    if base:
        print(f"\nmasked validity / free validity: {rows[1][2] / base:.1f}x")


def modes_table(vae, args) -> None:  # noqa: ANN001
    from grammarkit_string_vae.metrics import mode_yields

    rows = []
    for decoding in ("free", "masked"):
        y = mode_yields(vae, decoding=decoding, seeds=args.mode_seeds, seed=args.seed)
        for mode, m in y.items():
            rows.append([decoding, mode, m["decoded"], m["valid"], m["validity"], m["found"], m["distinct"],
                         m["novel"], m["yield"], m["novel_yield"], m["seconds"]])
    print(f"\n## Sampling modes ({args.mode_seeds} seeds each: training points for perturb, points for "
          "interpolate and path): yield = new graphs (other than the ones the search started from) per "
          "decoded latent point\n")
    print(table(["decoding", "mode", "decoded", "valid", "validity", "found", "distinct", "novel", "yield",
                 "novel yield", "seconds"], rows))


def table2(vae, args) -> None:  # noqa: ANN001
    from grammarkit_string_vae.metrics import table2 as t2

    r = t2(vae, size=args.graph_size, seed=args.seed)
    rows = [[kind, r[kind]["nodes"], r[kind]["edges"], r[kind]["components"],
             f"{r[kind]['unconnected_pairs']}/{r[kind]['pairs']}", r[kind]["mean_path_weight"],
             r[kind]["max_path_weight"], r[kind]["mean_path_edges"]] for kind in ("naive", "latent")]
    print(f"\n## Latent search graph (the paper's Table 2): {r['size']} valid latent points, k = {r['k']} "
          "nearest neighbours plus equivalent graphs, edge weight E\n")
    print(table(["graph", "nodes", "edges", "connected components", "unconnected pairs", "mean path weight",
                 "max path weight", "mean path edges"], rows))


def molecules(args, work: Path) -> None:  # noqa: ANN001
    print(f"\n## Molecules ({args.molecules} from RDKit's NCI sample)\n")
    try:
        import rdkit  # noqa: F401
    except ImportError:
        print("skipped: RDKit is not installed (python -m pip install rdkit)")
        return
    import numpy as np
    import torch

    from grammarkit_string_vae.dataset import make_dataset, write_dataset, load_dataset
    from grammarkit_string_vae.decoding import decode_latents
    from grammarkit_string_vae.graphs import GraphSet
    from grammarkit_string_vae.molecules import is_valid_molecule, load_molecules, molecule_rules, to_smiles
    from grammarkit_string_vae.strings import Alphabet, decode, strings_of
    from grammarkit_string_vae.train import TrainConfig, train_vae

    mols = load_molecules(args.molecules)
    types = sorted({t for _, g in mols for t in g.types})
    rules = molecule_rules(types)
    alphabet = Alphabet.for_types(types)
    rng = np.random.default_rng(args.seed)
    ok = same_smiles = n = 0
    for _smi, g in mols:
        ref = to_smiles(g)
        for s in strings_of(g, alphabet, 10, rng=rng):
            n += 1
            h = decode(s, alphabet).graph
            gs = GraphSet()
            gs.add(g)
            ok += h in gs
            same_smiles += to_smiles(h) == ref
    print(table(["molecules", "elements", "strings", "decoded graph isomorphic", "same RDKit canonical SMILES"],
                [[len(mols), " ".join(types), n, f"{ok}/{n}", f"{same_smiles}/{n}"]]))
    folder = work / "molecules_ds"
    ds = make_dataset([g for _, g in mols], rules, alphabet, strings_per_graph=10, seed=args.seed,
                      meta={"grammar": "molecule-valences", "grammar_hash": "valences:" + ",".join(types),
                            "source": "rdkit:NCI/first_5K.smi"})
    write_dataset(ds, folder, overwrite=True)
    ds = load_dataset(folder)
    t0 = time.perf_counter()
    res = train_vae(ds, TrainConfig(epochs=200, time_limit=args.molecule_seconds, threads=args.threads,
                                    seed=args.seed, strings_per_epoch=args.strings_per_epoch))
    secs = time.perf_counter() - t0
    z = torch.randn(args.molecule_samples, res.model.config.latent, generator=torch.Generator().manual_seed(1))
    rows = []
    for mode in ("free", "masked"):
        t0 = time.perf_counter()
        out = decode_latents(res.model, z, vocab=res.vocab, rules=res.rules, mode=mode, temperature=args.temperature)
        dt = time.perf_counter() - t0
        valid = [d for d in out if d.valid]
        rd = sum(is_valid_molecule(d.graph) for d in valid)
        uniq = GraphSet()
        distinct = sum(uniq.add(d.graph) for d in valid)
        rows.append([mode, len(out), len(valid) / len(out), f"{rd}/{len(valid)}", distinct, dt])
    print(f"\ntrained {len(res.history)} epochs in {secs:.0f} s; {args.molecule_samples} prior samples\n")
    print(table(["decoding", "samples", "validity (valence rules)", "RDKit accepts (of valid)", "distinct", "seconds"], rows))


def reconstruction(args) -> None:  # noqa: ANN001
    """Encode held-out graphs (a dataset folder the model never saw: e.g. bench_instantiation.py's
    fresh graph-sampler run), decode the posterior means, compare: exact string, the same graph
    (typed isomorphism), histogram distance E; and interpolation between pairs of them: how many
    points decode to a graph that builds in 3D (the consistent search) and is neither endpoint."""
    import numpy as np
    import torch

    from grammarkit.dsl import load
    from grammarkit_string_vae.consistent import ConsistentDecoder, instantiate_consistent
    from grammarkit_string_vae.dataset import load_dataset
    from grammarkit_string_vae.decoding import decode_latents
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.graphs import GraphSet
    from grammarkit_string_vae.instantiate import Instantiator
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.placed import PlacedDecoder
    from grammarkit_string_vae.vaefile import encode_strings

    grammar = load(ROOT / "grammars" / "tiling" / args.example / f"{args.example}.grammar")
    vae = load_vae(args.vae, grammar=grammar)
    em = load_edge_model(args.categories, grammar)
    inst = Instantiator(grammar, em.categories)
    ds = load_dataset(args.reconstruction)
    keep = [i for i in range(len(ds)) if ds.sources[i] != "example"][: args.recon_graphs]
    texts = [ds.strings[i][0] for i in keep]
    graphs = [ds.graphs[i] for i in keep]
    mu = encode_strings(vae.model, vae.vocab, texts)

    def same(a, b) -> bool:  # noqa: ANN001
        gs = GraphSet()
        gs.add(a)
        return b in gs

    def hist_e(a, b) -> float:  # noqa: ANN001
        ha, hb = a.histogram(), b.histogram()
        return sum(abs(ha.get(t, 0) - hb.get(t, 0)) for t in set(ha) | set(hb)) / (len(a) + len(b))

    rows = []
    placed = PlacedDecoder(vae, inst, expansions=args.placed_steps)
    for mode in ("free", "masked", "placed"):
        t0 = time.perf_counter()
        if mode == "placed":
            outs = [placed.decode(mu[i].numpy(), len(texts[i]), seed=i) for i in range(len(texts))]
        else:
            outs = decode_latents(vae.model, mu, vocab=vae.vocab, rules=vae.rules, mode=mode, seed=args.seed)
        valid = [d for d in outs if d.valid]
        exact = sum(d.text == t for d, t in zip(outs, texts))
        iso = sum(bool(d.valid and same(g, d.graph)) for d, g in zip(outs, graphs))
        es = [hist_e(g, d.graph) for d, g in zip(outs, graphs) if d.valid]
        rows.append([f"{mode}{' (paper)' if mode == 'free' else ''}", len(outs), len(valid), exact, iso,
                     f"{statistics.mean(es):.3f}" if es else "-", f"{time.perf_counter() - t0:.0f}"])
    print(f"\n## Reconstruction of {len(texts)} held-out graphs ({args.reconstruction}; {args.vae})\n")
    print(table(["decoding", "graphs", "valid", "exact string", "same graph", "mean histogram distance E",
                 "seconds"], rows))
    # interpolation between held-out pairs: built shapes that are neither endpoint
    decoder = ConsistentDecoder(inst, beam=16)
    rng = np.random.default_rng(args.seed)
    pts = built = new = 0
    t0 = time.perf_counter()
    for _ in range(args.recon_pairs):
        a, b = (int(x) for x in rng.choice(len(texts), size=2, replace=False))
        ts = np.arange(1, 7) / 7.0
        z = mu[a] + torch.from_numpy(ts[:, None].astype(np.float32)) * (mu[b] - mu[a])
        for d in decode_latents(vae.model, z, vocab=vae.vocab, rules=vae.rules, mode="masked", seed=args.seed):
            pts += 1
            if not d.valid or same(graphs[a], d.graph) or same(graphs[b], d.graph):
                continue
            new += 1
            pred = em.predict(d.graph, strings=8, seed=0, voting="logprob")
            res = instantiate_consistent(inst, decoder, d.graph, {e: v for e, (_k, v) in pred.items()}, tries=8)
            built += res.ok
    print(f"\nInterpolation (masked decoding, 6 points between each of {args.recon_pairs} held-out pairs): "
          f"{pts} points, {new} valid graphs other than the endpoints, {built} built in 3D "
          f"(yield {built / max(1, pts):.3f}; {time.perf_counter() - t0:.0f} s)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", default="castle")
    ap.add_argument("--graphs", type=int, default=2200)
    ap.add_argument("--iterations", type=int, default=8)
    ap.add_argument("--max-attempts", type=int, default=8000)
    ap.add_argument("--train-seconds", type=float, default=540.0)
    ap.add_argument("--epochs", type=int, default=200)
    ap.add_argument("--strings-per-epoch", type=int, default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--temperature", type=float, default=0.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mode-seeds", type=int, default=64)
    ap.add_argument("--graph-size", type=int, default=1000)
    ap.add_argument("--molecules", type=int, default=500)
    ap.add_argument("--molecule-seconds", type=float, default=120.0)
    ap.add_argument("--molecule-samples", type=int, default=500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", type=Path, default=Path("/tmp/grammarkit_bench_string_vae"))
    ap.add_argument("--retrain", action="store_true")
    ap.add_argument("--quick", action="store_true", help="small everything (a smoke test)")
    ap.add_argument("--skip", default="", help="comma-separated: prior,modes,table2,molecules")
    ap.add_argument("--reconstruction", type=Path, default=None,
                    help="only the reconstruction part: a dataset folder of held-out graphs to encode and decode")
    ap.add_argument("--vae", default="builtin:castle", help="reconstruction: the model")
    ap.add_argument("--categories", default="builtin:castle", help="reconstruction: the edge-category model")
    ap.add_argument("--recon-graphs", type=int, default=40)
    ap.add_argument("--recon-pairs", type=int, default=10)
    ap.add_argument("--placed-steps", type=int, default=150)
    args = ap.parse_args()
    if args.reconstruction is not None:
        reconstruction(args)
        return 0
    if args.quick:
        args.graphs, args.iterations, args.train_seconds, args.samples, args.runs = 200, 3, 60, 100, 1
        args.mode_seeds, args.graph_size, args.molecules, args.molecule_seconds = 8, 100, 100, 30
        args.molecule_samples = 100
    import torch

    torch.set_num_threads(args.threads)
    args.work.mkdir(parents=True, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    print(f"# bench_string_vae: {args.example}, load average {load_average()} (2 cores; shared machine: "
          "times are noisy)\n")
    if {"prior", "modes", "table2"} - skip:
        ds, _ = build_or_load_dataset(args, args.work)
        vae, training = train_or_load(args, ds, args.work)
    if "prior" not in skip:
        prior_table(vae, args)
    if "modes" not in skip:
        modes_table(vae, args)
    if "table2" not in skip:
        table2(vae, args)
    if "molecules" not in skip:
        molecules(args, args.work)
    print(f"\nload average at the end: {load_average()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
