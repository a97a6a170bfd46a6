"""Strings to 3D shapes (Kalojanov 2019, section 6): edge-category accuracy, instantiation success,
end-to-end yield against the graph sampler.

    python benchmarks/bench_instantiation.py [--example castle] [--work DIR] [--graphs 300]
        [--train-seconds 300] [--test-graphs 40] [--e2e-seconds 120] [--quick]
        [--default-model castle.edges] [--paper-model castle_paper.edges] [--skip-features]

1. Edge categories and three LSTM predictors, trained on the example's dataset (the one
   bench_string_vae.py builds in --work, else a new one of --graphs graphs) for the same time
   limit: the paper's (a left-to-right LSTM on the letters), this project's default (a
   bidirectional one on the letters) and a bidirectional one with graph features per
   character; accuracy on held-out graphs per character (no voting) and per
   edge with each voting over 8 strings of each graph: majority (the paper's), summed
   log-probabilities, joint per part, and the cycle-consistent decoding of the summed
   log-probabilities (consistent.py, beyond the paper: categories whose placements close every
   cycle without collisions) (the paper reports 90% validation accuracy; the target is >= 97%
   with voting). Models given with --default-model / --paper-model / --features-model (e.g.
   trained longer by plugins/string_vae/scripts/train_castle_edges.py, which holds out the same
   graphs) are evaluated instead of training new ones; the default model's training history
   gives its validation accuracy per epoch.
2. Instantiation of held-out graphs (graphs the sampler made, so they can be built): success rate
   and average tries by size (parts) and by cycle edges, with the predicted categories
   (backtracking insertion, the paper's; the consistent search; the consistent search and
   backtracking when it fails) and, as the naive baseline, with no prediction (pure Monte-Carlo
   edge insertion). The paper's estimate for naive assembly of a 15-part cycle with 6
   configurations per edge is 1/6^15.
3. End-to-end: valid 3D shapes per minute from `derive --backend string-vae` (--vae, default the
   shipped builtin:castle; masked decoding, perturbation, with the categories): the paper's
   predictor with backtracking insertion (8 tries of 400 insertions), the default predictor with
   backtracking (graphs larger than the largest training graph skipped) and with the consistent
   search, beside the graph sampler's new variants per minute on the same
   example, for the same wall-clock budget, in the same run.

Every instantiated shape is validated against the grammar (the instantiation refuses others);
the script re-validates the written ones and checks that each part is watertight.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def table(head, rows) -> str:  # noqa: ANN001
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        out.append("| " + " | ".join(f"{x:.3f}" if isinstance(x, float) else str(x) for x in r) + " |")
    return "\n".join(out)


def dataset(args):  # noqa: ANN001, ANN201
    from grammarkit.dsl import load
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset

    folder = args.work / f"{args.example}_ds"
    if (folder / "dataset.json").exists():
        ds = load_dataset(folder)
        if any(v is not None for v in ds.variants) or args.example == "castle":
            return ds
    grammar = load(ROOT / "grammars" / "tiling" / args.example / f"{args.example}.grammar")
    ds, _ = build_dataset(grammar, n=args.graphs, iterations=args.iterations, seed=args.seed,
                          options={"dedupe": "isomorphism", "max_attempts": 8000})
    write_dataset(ds, folder, overwrite=True)
    return load_dataset(folder)


def bin_of(x: int, edges: list[int]) -> str:
    lo = 0
    for e in edges:
        if x <= e:
            return f"{lo}-{e}"
        lo = e + 1
    return f">{edges[-1]}"


def e2e_rows(args, grammar, rows_out, runs) -> None:  # noqa: ANN001
    from grammarkit.run import iter_results
    from grammarkit.tiling import validate

    for label, backend, opts in runs:
        t0, c0 = time.perf_counter(), time.process_time()
        made = 0
        shapes = []
        deadline = t0 + args.e2e_seconds
        try:
            # the run's own time budget ends it (a string-vae run yields only built shapes, so
            # the loop cannot check the clock between failures)
            for res in iter_results(grammar, backend=backend, n=100000, seed=args.seed, iterations=20, options=opts,
                                    workers=1, timeout=args.e2e_seconds):
                if res.model is not None:
                    made += 1
                    shapes.append(res.model)
                if time.perf_counter() > deadline:
                    break
        except Exception as exc:  # noqa: BLE001 - the time budget ends the run: report what was made
            print(f"  ({label}: {type(exc).__name__}: {str(exc)[:200]})")
        secs, cpu = time.perf_counter() - t0, time.process_time() - c0
        for shape in shapes:  # checked after the clock stops, for every back end alike
            assert validate(grammar, shape).ok and all(p.mesh.is_watertight for p in shape.parts), label
        parts = statistics.mean(len(sh.parts) for sh in shapes) if shapes else "-"
        rows_out.append([label, made, secs, 60.0 * made / secs, parts, " ".join(f"{x:.1f}" for x in os.getloadavg()),
                         60.0 * made / max(cpu, 1e-9)])
        print(f"  {label}: {made} shapes in {secs:.0f} s", flush=True)


# long: the argument list of every part of the benchmark, then the parts in order
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", default="castle")
    ap.add_argument("--work", type=Path, default=Path("/tmp/grammarkit_bench_string_vae"))
    ap.add_argument("--graphs", type=int, default=400)
    ap.add_argument("--iterations", type=int, default=5)
    ap.add_argument("--train-graphs", type=int, default=600, help="dataset graphs used to train the predictor")
    ap.add_argument("--train-seconds", type=float, default=300)
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--test-graphs", type=int, default=40)
    ap.add_argument("--tries", type=int, default=8)
    ap.add_argument("--beam", type=int, default=16, help="the consistent search's beam")
    ap.add_argument("--e2e-seconds", type=float, default=120)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reuse", action="store_true", help="reuse the predictors saved in --work by an earlier run "
                    "(EXAMPLE_paper.edges, EXAMPLE_bidir.edges, EXAMPLE_features.edges)")
    ap.add_argument("--default-model", type=Path, default=None, help="this project's predictor to evaluate "
                    "(trained on graphs other than the first --test-graphs of the seed-0 permutation)")
    ap.add_argument("--paper-model", type=Path, default=None, help="the paper's predictor to evaluate")
    ap.add_argument("--features-model", type=Path, default=None, help="a predictor with graph features")
    ap.add_argument("--skip-features", action="store_true", help="no graph-features predictor")
    ap.add_argument("--strings-per-graph", type=int, default=4)
    ap.add_argument("--fast-tries", type=int, default=8, help="backtracking rows: tries per graph")
    ap.add_argument("--fast-budget", type=int, default=400, help="backtracking rows: insertions per try")
    ap.add_argument("--skip-e2e", action="store_true")
    ap.add_argument("--parts", default="accuracy,instantiation,sampled,e2e",
                    help="comma-separated parts to run: accuracy, instantiation, sampled, e2e; or `fresh` alone "
                         "(accuracy on a new sampler run), `shipped` alone (end to end from the shipped models) or "
                         "`decodings` alone (free, masked and placed decoding side by side)")
    ap.add_argument("--sampled-graphs", type=int, default=30, help="sampled part: VAE samples instantiated")
    ap.add_argument("--sampler-seconds", type=float, default=None,
                    help="end-to-end: the graph sampler's row (default: --e2e-seconds)")
    ap.add_argument("--e2e-rows", default="paper,backtracking,consistent,sampler",
                    help="comma-separated end-to-end rows to run")
    ap.add_argument("--inst-graphs", type=int, default=None, help="instantiate only the first N held-out graphs")
    ap.add_argument("--vae", default="builtin:castle", help="string-VAE model for the end-to-end rows "
                    "(default: the shipped builtin:castle)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--fresh-seed", type=int, default=None,
                    help="the `fresh` part: held-out graphs from a new graph-sampler run with this seed (the "
                         "shipped dataset used seed 1), scored with --default-model (default: builtin:castle)")
    ap.add_argument("--fresh-iterations", type=int, default=4, help="the `fresh` part: sampler iterations")
    ap.add_argument("--shipped-rows", default="consistent,placed,placed-small,default,sampler",
                    help="the `shipped` part's rows (the graph sampler last: the ratios are against it)")
    ap.add_argument("--max-tokens", type=int, default=40, help="the `shipped` part's placed-small row")
    ap.add_argument("--decode-points", type=int, default=20, help="the `decodings` part: latent points per decoding")
    ap.add_argument("--max-length", default="40", help="the `decodings` part: the placed rows' length priors, "
                    "comma-separated (`none`: the start string's length)")
    ap.add_argument("--past-known", choices=("on", "off", "both"), default="on",
                    help="the `decodings` part: perturbation grows its offset past training graphs and repeats "
                    "(the back end's search_past_known), or stops at any other graph (off), or both rows")
    ap.add_argument("--decodings", default="free,masked,placed", help="the `decodings` part: which decodings")
    ap.add_argument("--reference", default=None, help="the `decodings` part: dataset folders (comma-separated) "
                    "of graph-sampler outputs (other seeds) for novelty against the sampler")
    ap.add_argument("--min-length", type=int, default=None, help="the `decodings` part: the placed rows' length "
                    "bucket's lower end (the shipped setting: 41 with --max-length 56)")
    ap.add_argument("--max-open", type=int, default=None, help="the `decodings` part: the placed rows' open-ring "
                    "limit (the shipped setting: 2)")
    ap.add_argument("--novel-only", choices=("on", "off", "both"), default="off",
                    help="the `decodings` part: placed search treats a finished known graph as a dead end "
                    "(the back end's novel_search), or not, or both rows")
    ap.add_argument("--per-point", type=int, default=1, help="the `decodings` part: the dead-end rows search "
                    "this many new graphs per latent point (the back end's per_point)")
    ap.add_argument("--placed-temperature", type=float, default=0.0,
                    help="the `decodings` part: the placed row's temperature")
    args = ap.parse_args()
    if args.quick:
        args.graphs, args.iterations, args.train_seconds, args.test_graphs, args.e2e_seconds = 60, 2, 40, 10, 30
        args.train_graphs, args.epochs, args.e2e_seconds = 60, 2, 30
    import numpy as np
    import torch

    from grammarkit.dsl import load
    from grammarkit_string_vae.consistent import ConsistentDecoder
    from grammarkit_string_vae.dataset import Dataset
    from grammarkit_string_vae.edgemodel import (EdgeTrainConfig, load_edge_model,
                                                 save_edge_model, train_edge_model)
    from grammarkit_string_vae.instantiate import Instantiator

    torch.set_num_threads(args.threads)
    args.work.mkdir(parents=True, exist_ok=True)
    load_avg = " ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"# bench_instantiation: {args.example}, load average {load_avg} (2 cores, shared: times are noisy)\n")
    grammar = load(ROOT / "grammars" / "tiling" / args.example / f"{args.example}.grammar")
    if set(args.parts.split(",")) == {"fresh"}:
        fresh_accuracy(args, grammar)
        return 0
    if set(args.parts.split(",")) == {"decodings"}:
        decodings_table(args, grammar)
        return 0
    if set(args.parts.split(",")) == {"shipped"}:
        shipped_end_to_end(args, grammar)
        return 0
    full = dataset(args)
    rng = np.random.default_rng(args.seed)
    idx = [i for i in rng.permutation(len(full)) if full.frames[i] is not None]
    test_idx = idx[: args.test_graphs]
    train_idx = idx[args.test_graphs: args.test_graphs + args.train_graphs]
    pick = lambda ids: Dataset(dict(full.meta), [full.graphs[i] for i in ids], [full.strings[i] for i in ids],  # noqa: E731
                               [full.ids[i] for i in ids], [full.sources[i] for i in ids],
                               [full.frames[i] for i in ids], full.path, [full.variants[i] for i in ids])
    train_ds = pick(train_idx)
    models = {}
    specs = [("paper", dict(bidirectional=False, graph_features=False, voting="majority"), "_paper", args.paper_model),
             ("bidirectional", {}, "_bidir", args.default_model)]
    if not args.skip_features:
        specs.append(("bidirectional + graph features", dict(graph_features=True), "_features", args.features_model))
    for name, kw, suffix, given in specs:
        model_path = given or args.work / f"{args.example}{suffix}.edges"
        if given is not None or (args.reuse and model_path.exists()):
            em = load_edge_model(model_path, grammar)
            train_s = float(em.meta["training"]["history"][-1]["seconds"])
        else:
            print(f"training the {name} predictor", flush=True)
            t0 = time.perf_counter()
            em = train_edge_model(train_ds, grammar, EdgeTrainConfig(epochs=args.epochs, time_limit=args.train_seconds,
                                                                     threads=args.threads, seed=args.seed,
                                                                     val_fraction=0.1,
                                                                     strings_per_graph=args.strings_per_graph, **kw),
                                  progress=lambda r: print(f"  epoch {r['epoch']}: loss {r['loss']:.3f} char "
                                                           f"{r['char_accuracy']:.3f} voted {r['edge_accuracy_voted']:.3f} "
                                                           f"({r['seconds']:.0f} s)", flush=True))
            train_s = time.perf_counter() - t0
            save_edge_model(em, model_path)
        models[name] = (em, model_path, train_s)
    em = models["bidirectional"][0]
    cats = em.categories
    inst = Instantiator(grammar, cats)
    decoder = ConsistentDecoder(inst, beam=args.beam)
    print(f"\ncategories: {len(cats)} ("
          + ", ".join(f"{a}-{b} {len(v)}" for (a, b), v in sorted(cats.by_pair.items()))
          + f"); {len(test_idx)} held-out graphs")
    parts = set(args.parts.split(","))
    if args.skip_e2e:
        parts.discard("e2e")
    # 1. accuracy on held-out graphs
    test_ds = pick(test_idx)
    if "accuracy" in parts:
        accuracy_tables(args, grammar, models, test_ds, decoder, cats)
    if "instantiation" in parts:
        instantiation_tables(args, grammar, models, test_ds, inst, decoder, cats)
    if "sampled" in parts:
        sampled_table(args, grammar, models, inst, decoder)
    if "e2e" in parts:
        end_to_end(args, grammar, models, full)
    return 0


def sampled_table(args, grammar, models, inst, decoder) -> None:  # noqa: ANN001
    """The same VAE samples (perturbation, masked decoding) instantiated by each search: how many
    are built and what a graph costs, the sampling included."""
    import numpy as np

    from grammarkit_string_vae.consistent import instantiate_consistent
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    em = models["bidirectional"][0]
    vae = load_vae(args.vae, grammar=grammar)
    sampler = Sampler(vae, SamplingSettings(), seed=args.seed)
    graphs = []
    t0 = time.perf_counter()
    while len(graphs) < args.sampled_graphs:
        for s in sampler.run("perturb", 1):
            if s.valid and len(graphs) < args.sampled_graphs:
                graphs.append(s.decoded.graph)
    sample_s = (time.perf_counter() - t0) / len(graphs)
    rows = {"cycle-consistent search": [], "backtracking, 8 tries x 400 insertions": []}
    for j, g in enumerate(graphs):
        t = time.perf_counter()
        votes = {e: v for e, (_k, v) in em.predict(g, strings=8, seed=j, voting="logprob").items()}
        predict_s = time.perf_counter() - t
        r = instantiate_consistent(inst, decoder, g, votes, tries=args.tries)
        rows["cycle-consistent search"].append((r.ok, predict_s + r.seconds))
        ranked = {e: [int(c) for c in np.argsort(-v, kind="stable") if v[c] > -1e8] for e, v in votes.items()}
        b = inst.instantiate(g, ranked, seed=j, max_tries=args.tries)
        rows["backtracking, 8 tries x 400 insertions"].append((b.ok, predict_s + b.seconds))
    parts = [len(g) for g in graphs]
    print(f"\n## {len(graphs)} VAE samples (perturbation; {statistics.mean(parts):.0f} parts on average, "
          f"{min(parts)}-{max(parts)}), default predictor; sampling {sample_s:.2f} s per graph\n")
    out = []
    for name, rs in rows.items():
        built = sum(ok for ok, _ in rs)
        per = statistics.mean(sec for _, sec in rs)
        out.append([name, f"{built}/{len(rs)}", per, 60.0 / (per + sample_s)])
    print(table(["search", "built", "seconds per graph (prediction + search)",
                 "graphs tried per minute (sampling included)"], out))


def fresh_accuracy(args, grammar) -> None:  # noqa: ANN001
    """Edge-category accuracy of a trained predictor on graphs it has never seen: a new graph-sampler
    run with another seed than the training data's (per character, voted: majority, log-prob sum,
    joint per part, and the cycle-consistent decoding)."""
    from grammarkit_string_vae.consistent import ConsistentDecoder
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset
    from grammarkit_string_vae.edgemodel import _examples, evaluate, load_edge_model
    from grammarkit_string_vae.instantiate import Instantiator

    seed = 7 if args.fresh_seed is None else args.fresh_seed
    model = str(args.default_model) if args.default_model else f"builtin:{args.example}"
    em = load_edge_model(model, grammar)
    train_seed = em.meta.get("training", {}).get("dataset_seed", em.meta.get("dataset", {}).get("seed", "?"))
    folder = args.work / f"{args.example}_fresh_seed{seed}_{args.test_graphs}"
    if not (folder / "dataset.json").exists():
        t0 = time.perf_counter()
        ds, _ = build_dataset(grammar, n=args.test_graphs, iterations=args.fresh_iterations, seed=seed,
                              options={"dedupe": "isomorphism", "max_attempts": 8000})
        write_dataset(ds, folder, overwrite=True)
        print(f"fresh dataset: {len(ds)} graphs, sampler seed {seed}, {time.perf_counter() - t0:.0f} s")
    ds = load_dataset(folder)
    keep = [i for i in range(len(ds)) if ds.frames[i] is not None and ds.sources[i] != "example"]
    cfg = em.model.config
    types = cfg.types if cfg.features else ()
    rows = _examples(ds, keep, em.categories, em.vocab, 8, args.seed + 7, types)
    dec = ConsistentDecoder(Instantiator(grammar, em.categories), beam=args.beam)
    acc = evaluate(em.model, rows, em.categories, len(em.categories), [ds.graphs[i] for i in keep],
                   em.configurations, dec)
    sizes = [len(ds.graphs[i]) for i in keep]
    print(f"\n## Edge-category accuracy on fresh graphs ({len(keep)} graphs of a graph-sampler run with seed {seed}, "
          f"{statistics.mean(sizes):.0f} parts on average, {min(sizes)}-{max(sizes)}; model {model}, "
          f"trained on seed {train_seed}; votes over 8 strings per graph)\n")
    print(table(["edges", "per character (no voting)", "voted: majority (paper)", "voted: log-prob sum",
                 "voted: joint per part", "cycle-consistent", "graphs consistent (s per graph)"],
                [[acc["val_edges"], acc["char_accuracy"], acc["edge_accuracy_majority"], acc["edge_accuracy_voted"],
                  acc.get("edge_accuracy_joint", "-"), acc["edge_accuracy_consistent"],
                  f"{acc['consistent_graphs']:.3f} ({acc['consistent_seconds']:.2f} s)"]]))
    print("\n(paper: 0.90 per character on its validation set; target of issue 29: >= 0.90 on fresh graphs)")


def accuracy_tables(args, grammar, models, test_ds, decoder, cats) -> None:  # noqa: ANN001
    from grammarkit_string_vae.consistent import ConsistentDecoder
    from grammarkit_string_vae.edgemodel import _examples, evaluate
    from grammarkit_string_vae.instantiate import Instantiator

    em = models["bidirectional"][0]
    print("\n## Edge-category accuracy on held-out graphs\n")
    rows_ = []
    for name, (m, _p, secs) in models.items():
        cfg = m.model.config
        types = cfg.types if cfg.features else ()
        rows = _examples(test_ds, list(range(len(test_ds))), m.categories, m.vocab, 8, args.seed + 7, types)
        m_dec = decoder if m.categories.to_json() == cats.to_json() else \
            ConsistentDecoder(Instantiator(grammar, m.categories), beam=args.beam)
        acc = evaluate(m.model, rows, m.categories, len(m.categories), test_ds.graphs, m.configurations, m_dec)
        hist = m.meta["training"]["history"]
        tr = m.meta["training"]
        rows_.append([f"{name}: {'bidirectional' if cfg.bidirectional else 'left-to-right'} LSTM, "
                      f"{'letters + graph features' if cfg.features else 'letters'}",
                      f"{tr.get('train_graphs', '?')} graphs x {tr['config'].get('strings_per_graph', '?')} strings",
                      len(hist), f"{secs:.0f}", acc["val_edges"], acc["char_accuracy"], acc["edge_accuracy_majority"],
                      acc["edge_accuracy_voted"], acc.get("edge_accuracy_joint", "-"), acc["edge_accuracy_consistent"],
                      f"{acc['consistent_graphs']:.3f} ({acc['consistent_seconds']:.2f} s)"])
    print(table(["predictor", "training data", "epochs", "training s", "edges", "per character (no voting)",
                 "voted: majority (paper)", "voted: log-prob sum", "voted: joint per part",
                 "cycle-consistent (log-prob priors)", "graphs consistent (s per graph)"], rows_))
    print("\n(paper: 0.90 validation accuracy per character; target: >= 0.97 with voting)")
    hist = em.meta["training"]["history"]
    print(f"\nThe default predictor's validation accuracy by epoch ({em.meta['training'].get('val_graphs')} "
          "validation graphs of its own split, votes over 8 strings):\n")
    print(table(["epoch", "seconds", "per character", "majority", "log-prob sum", "joint"],
                [[r["epoch"], r["seconds"], r["char_accuracy"], r["edge_accuracy_majority"], r["edge_accuracy_voted"],
                  r.get("edge_accuracy_joint", "-")] for r in hist]))


def instantiation_tables(args, grammar, models, test_ds, inst, decoder, cats) -> None:  # noqa: ANN001
    import numpy as np

    from grammarkit.tiling import validate
    from grammarkit_string_vae.categories import edge_labels
    from grammarkit_string_vae.consistent import instantiate_consistent

    em = models["bidirectional"][0]

    def backtrack(m, voting=None):  # noqa: ANN001, ANN202
        return lambda g, j: inst.instantiate(g, m.rankings(g, strings=8, seed=j, voting=voting), seed=j,
                                             max_tries=args.tries)

    def consistent(m, then_backtrack=False):  # noqa: ANN001, ANN202
        def run(g, j):  # noqa: ANN001, ANN202
            votes = {e: v for e, (_k, v) in m.predict(g, strings=8, seed=j, voting="logprob").items()}
            r = instantiate_consistent(inst, decoder, g, votes, tries=args.tries)
            if r.ok or not then_backtrack:
                return r
            ranked = {e: [int(c) for c in np.argsort(-v, kind="stable") if v[c] > -1e8] for e, v in votes.items()}
            b = inst.instantiate(g, ranked, seed=j, max_tries=args.tries)
            b.seconds += r.seconds
            return b
        return run

    methods = {}
    for name, (m, _p, _s) in models.items():
        if m.categories.to_json() != cats.to_json():
            continue
        methods[f"predicted ({name}, {m.voting} votes), backtracking (paper's search)"] = backtrack(m)
    methods["predicted (bidirectional), cycle-consistent search"] = consistent(em)
    methods["predicted (bidirectional), cycle-consistent, then backtracking"] = consistent(em, True)
    methods["naive (no categories)"] = lambda g, j: inst.instantiate(g, {}, seed=j, max_tries=args.tries)
    results = {k: [] for k in list(methods) + ["true categories"]}
    n_inst = len(test_ds) if args.inst_graphs is None else min(args.inst_graphs, len(test_ds))
    for j, g in enumerate(test_ds.graphs[:n_inst]):
        labels = edge_labels(g, test_ds.frames[j], cats, test_ds.variants[j])
        truth = {(u, v): labels[(u, v)] for u, v in g.edges}
        for name, fn in list(methods.items()) + [("true categories",
                                                   lambda g, j: inst.instantiate(g, truth, seed=j, max_tries=args.tries))]:
            r = fn(g, j)
            if r.ok:
                assert validate(grammar, r.assembly).ok and all(pt.mesh.is_watertight for pt in r.assembly.parts)
            results[name].append((len(g), g.cycle_rank, r.ok, r.tries, r.monte_carlo, r.seconds))
    print(f"\n## Instantiation of {n_inst} held-out graphs (at most {args.tries} tries each)\n")
    head = ["categories", "graphs", "success", "mean tries (successes)",
            "edges not at the first predicted category (successes, mean)", "seconds per graph (mean)"]
    rows_ = []
    for name, rs in results.items():
        ok = [r for r in rs if r[2]]
        rows_.append([name, len(rs), len(ok) / max(1, len(rs)), statistics.mean(r[3] for r in ok) if ok else "-",
                      statistics.mean(r[4] for r in ok) if ok else "-", statistics.mean(r[5] for r in rs)])
    print(table(head, rows_))
    for key, edges, label in ((0, [20, 40, 60], "parts"), (1, [1, 3, 6], "cycle edges")):
        print(f"\nBy {label} (success rate / mean tries of successes):\n")
        bins = sorted({bin_of(r[key], edges) for r in results["true categories"]},
                      key=lambda b: int(b.strip(">").split("-")[0]))
        head = [label] + list(results)
        rows_ = []
        for b in bins:
            row = [b]
            for name, rs in results.items():
                sel = [r for r in rs if bin_of(r[key], edges) == b]
                ok = [r for r in sel if r[2]]
                row.append(f"{len(ok)}/{len(sel)}" + (f" ({statistics.mean(r[3] for r in ok):.1f})" if ok else ""))
            rows_.append(row)
        print(table(head, rows_))
    n_cat = statistics.mean(len(v) for v in cats.by_pair.values())
    print(f"\nNaive estimate (the paper's): a cycle of L parts with c configurations per edge closes with "
          f"probability (1/c)^L; here c = {n_cat:.1f} on average per type pair, so a 15-part cycle: "
          f"{(1 / n_cat) ** 15:.2e} (paper: 1/6^15 = {6.0 ** -15:.2e}).")


def reference_graphs(paths):  # noqa: ANN001, ANN201
    """The graphs of dataset folders (comma-separated; e.g. 1,000 graph-sampler outputs of
    another seed) as one GraphSet, for novelty against the sampler; None without --reference."""
    from grammarkit_string_vae.dataset import load_dataset
    from grammarkit_string_vae.graphs import GraphSet

    if not paths:
        return None
    ref = GraphSet()
    for path in paths.split(","):
        for g in load_dataset(path).graphs:
            ref.add(g)
    return ref


# long: one measurement loop per decoding row with its counters (valid, built, new, new to the
# sampler, CPU per shape), printed as one table
def decodings_table(args, grammar) -> None:  # noqa: ANN001
    """The paper's free decoding, the masked decoding and the placed decoding side by side, from
    the same models, on the same perturbation budget: validity, the share of valid decoded
    graphs built in 3D, novelty of the built shapes against the training graphs and against
    `--reference` (graph-sampler outputs), distinct shapes, and what a new shape costs (wall
    clock and this process's CPU time, since the machine is shared). Free and masked strings are
    built by the cycle-consistent search with the predictor's votes; placed strings by their own
    placement. Every valid decoded graph is built, training graphs and repeats too, so the build
    rate is of all of them; only graphs new to the training set and the run count as shapes."""
    from grammarkit.tiling import validate
    from grammarkit_string_vae.consistent import ConsistentDecoder, instantiate_consistent
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.graphs import GraphSet
    from grammarkit_string_vae.instantiate import Instantiator
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.placed import PlacedDecoder
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    vae = load_vae(args.vae, grammar=grammar)
    em = load_edge_model(f"builtin:{args.example}", grammar)
    inst = Instantiator(grammar, em.categories)
    consistent = ConsistentDecoder(inst, beam=args.beam)
    train = GraphSet()
    for s in vae.train_strings:
        train.add(vae_graph(vae, s))
    ref = reference_graphs(args.reference)
    rows_ = []
    specs = []
    for dec in args.decodings.split(","):
        if dec in ("free", "masked"):
            specs.append(("free (paper)" if dec == "free" else "masked", SamplingSettings(decoding=dec, batch=2)))
    for lim in (args.max_length.split(",") if "placed" in args.decodings else []):
        m = None if lim == "none" else int(lim)
        lo = f"{args.min_length}-" if args.min_length and m else ("<= " if m else "")
        for novel in {"on": [True], "off": [False], "both": [False, True]}[args.novel_only]:
            specs.append((f"placed, length prior {lo + str(m) + ' tokens' if m else 'the start string'}"
                          f", temperature {args.placed_temperature}"
                          + (f", at most {args.max_open} open rings" if args.max_open else "")
                          + (", known graphs are dead ends" if novel else "")
                          + (f", {args.per_point} per point" if novel and args.per_point > 1 else ""),
                          SamplingSettings(decoding="placed", batch=2, max_length=m, min_length=args.min_length,
                                           temperature=args.placed_temperature), novel))
    specs = [(s_[0], s_[1], s_[2] if len(s_) > 2 else False) for s_ in specs]
    past = {"on": [True], "off": [False], "both": [False, True]}[args.past_known]
    specs = [(f"{label}{', past known graphs' if p else ''}", st, p, nov)
             for label, st, nov in specs for p in past]
    print(f"\n## Decodings side by side: {args.decode_points} perturbed latent points each, model {args.vae}"
          f" ({len(vae.train_strings)} training graphs; reference: {len(ref) if ref is not None else 0} sampler graphs)\n")
    for label, st, past_known, novel in specs:
        sampler = Sampler(vae, st, seed=args.seed)
        if st.decoding == "placed":
            sampler.placed = PlacedDecoder(vae, inst, temperature=st.temperature, max_open=args.max_open)
        seen = GraphSet()
        if past_known or novel:  # as the back end does (search_past_known): grow the offset past known graphs
            sampler.known = lambda g, seen=seen: g in train or g in seen
        sampler.novel_only = novel
        sampler.per_point = args.per_point if novel else 1
        valid_graphs = built_graphs = new = new_ref = 0
        parts, per_shape = [], []
        w0, c0 = time.perf_counter(), time.process_time()
        last = c0
        while sampler.decoded_points < args.decode_points:
            for smp in sampler.run("perturb", 1):
                if not smp.valid:
                    continue
                g = smp.decoded.graph
                valid_graphs += 1
                if smp.decoded.placement is not None:
                    asm, _why = inst.build(g, smp.decoded.placement.frames, smp.decoded.placement.variants)
                else:
                    votes = {e: v for e, (_k, v) in em.predict(g, strings=8, seed=valid_graphs,
                                                              voting="logprob").items()}
                    asm = instantiate_consistent(inst, consistent, g, votes, tries=args.tries).assembly
                if asm is None:
                    continue
                assert validate(grammar, asm).ok
                built_graphs += 1
                if g in train or not seen.add(g):
                    continue
                new += 1
                new_ref += ref is not None and g not in ref
                parts.append(len(g))
                now = time.process_time()
                per_shape.append(now - last)
                last = now
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        n = sampler.decoded_points
        rows_.append([label, n, f"{sampler.valid_points / n:.3f}",
                      f"{built_graphs}/{valid_graphs}" if valid_graphs else "0/0", new,
                      f"{new_ref}/{new}" if ref is not None else "-",
                      statistics.median(parts) if parts else "-", 60.0 * new / wall, 60.0 * new / cpu,
                      statistics.median(per_shape) if per_shape else "-"])
        print(f"  {label}: {new} new shapes from {n} points in {wall:.0f} s ({cpu:.0f} s CPU)", flush=True)
    print(table(["decoding", "latent points", "validity", "valid graphs built in 3D",
                 "new shapes (built, not training, not repeated)", "of them not among the sampler's",
                 "median parts", "new shapes per minute (wall)", "per CPU minute", "median CPU s per new shape"],
                rows_))
    print(f"\nload average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


def vae_graph(vae, text):  # noqa: ANN001, ANN201
    from grammarkit_string_vae.strings import decode

    return decode(text, vae.alphabet).graph


def shipped_end_to_end(args, grammar) -> None:  # noqa: ANN001
    """Valid 3D shapes per minute from the shipped models (no training, no dataset): masked
    decoding with the cycle-consistent search, placed decoding, and the graph sampler, in one run."""
    ship = {"model": args.vae, "mode": "perturb", "categories": f"builtin:{args.example}"}  # --vae: another model
    catalogue = {
        "consistent": ("string-vae: masked decoding, default predictor, cycle-consistent search", "string-vae",
                       {**ship, "search": "consistent"}),
        "placed": (f"string-vae: placed decoding (string and categories together, width 16), {args.vae}", "string-vae",
                   {**ship, "decoding": "placed"}),
        "default": ("string-vae: no options (the shipped models: placed decoding, length prior <= 40 tokens)",
                    "string-vae", {}),
        "placed-small": (f"string-vae: placed decoding, started from training strings of <= {args.max_tokens} tokens",
                         "string-vae", {**ship, "decoding": "placed", "max_tokens": str(args.max_tokens)}),
        "sampler": ("graph sampler (isomorphism dedupe)", "graph-sampler", {"dedupe": "isomorphism"}),
    }
    runs = [catalogue[k] for k in args.shipped_rows.split(",")]
    print(f"\n## End to end from the shipped models: valid 3D shapes per minute, {args.e2e_seconds:.0f} s per row\n")
    rows_: list = []
    e2e_rows(args, grammar, rows_, runs)
    base_rate = (rows_[-1][3] or None) if runs[-1][1] == "graph-sampler" else None
    for r in rows_:
        r.append(f"{r[3] / base_rate:.4f}x" if base_rate else "-")
    print(table(["back end", "valid shapes", "seconds", "shapes per minute", "mean parts", "load average after",
                 "shapes per CPU minute (this process)", "vs graph sampler"], rows_))


def end_to_end(args, grammar, models, full) -> None:  # noqa: ANN001
    vae = str(args.vae)
    if not vae.startswith("builtin:") and not Path(vae).exists():
        print(f"\n(end-to-end skipped: no string-VAE model {vae})")
        return
    print(f"\n## End to end: valid 3D shapes per minute, {args.e2e_seconds:.0f} s per string-vae row, "
          f"{args.sampler_seconds or args.e2e_seconds:.0f} s for the graph sampler\n")
    largest = max(len(g) for g in full.graphs)
    paper_p, default_p = str(models["paper"][1]), str(models["bidirectional"][1])
    base = {"model": vae, "mode": "perturb"}
    catalogue = {
        "paper": ("string-vae: paper's predictor (majority votes), backtracking, "
                  f"{args.tries} tries x 400 insertions", "string-vae",
                  {**base, "categories": paper_p, "search": "backtracking", "tries": str(args.tries)}),
        "backtracking": (f"string-vae: default predictor (log-prob votes), backtracking, {args.fast_tries} tries x "
                         f"{args.fast_budget} insertions, graphs over {largest} parts skipped", "string-vae",
                         {**base, "categories": default_p, "search": "backtracking", "tries": str(args.fast_tries),
                          "budget": str(args.fast_budget), "max_parts": str(largest)}),
        "consistent": (f"string-vae: default predictor, cycle-consistent search (beam {args.beam})", "string-vae",
                       {**base, "categories": default_p, "search": "consistent", "beam": str(args.beam)}),
        "sampler": ("graph sampler (isomorphism dedupe)", "graph-sampler", {"dedupe": "isomorphism"}),
    }
    runs = [catalogue[k] for k in args.e2e_rows.split(",") if k in catalogue]
    rows_ = []
    e2e_rows(args, grammar, rows_, [r for r in runs if r[1] != "graph-sampler"])
    if any(r[1] == "graph-sampler" for r in runs):
        import copy

        a2 = copy.copy(args)
        a2.e2e_seconds = args.sampler_seconds or args.e2e_seconds
        e2e_rows(a2, grammar, rows_, [r for r in runs if r[1] == "graph-sampler"])
    base_rate = rows_[-1][3] if runs and runs[-1][1] == "graph-sampler" else None
    for r in rows_:
        r.append(f"{r[3] / base_rate:.4f}x" if base_rate else "-")
    print(table(["back end", "valid shapes", "seconds", "shapes per minute", "mean parts", "load average after",
                 "shapes per CPU minute (this process)", "vs graph sampler"], rows_))
    print(f"\nload average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    sys.exit(main())
