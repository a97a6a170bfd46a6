"""The shape-string commands: `strings`, `dataset`, `train string-vae`, `vae-metrics`.

Only click is imported here; each command imports what it needs when it runs.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import click

from grammarkit.errors import GrammarkitError


def _grammar(path: Path):  # noqa: ANN202
    from grammarkit.dsl import load

    grammar = load(path)
    if grammar.family != "tiling":
        raise GrammarkitError(f"{path}: shape strings describe tiling grammars (parts, docks, neighbour "
                              f"rules); this is a {grammar.family} grammar")
    return grammar


def progress_factory(console):  # noqa: ANN001, ANN201
    """A rich Progress and a `progress(description, total) -> advance(n=1, **fields)` factory,
    the shape `grammarkit.run.Request.progress` has."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                        TimeElapsedColumn(), TextColumn("{task.fields[info]}"), console=console,
                        disable=not console.is_terminal)

    def factory(description: str, total: int | None = None):  # noqa: ANN202
        task = progress.add_task(description, total=total, info="")

        def advance(n: int = 1, **fields) -> None:  # noqa: ANN003
            progress.update(task, advance=n, info=" ".join(f"{k}={v}" for k, v in fields.items()))
        return advance
    return progress, factory


def _pairs(values: tuple[str, ...]) -> dict[str, str]:
    out = {}
    for item in values:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", param_hint="--option")
        out[key.strip()] = value.strip()
    return out


# --------------------------------------------------------------------------------------------
# grammarkit strings
# --------------------------------------------------------------------------------------------
@click.command("strings")
@click.argument("model", required=False, type=click.Path(exists=True, path_type=Path))
@click.option("--grammar", "grammar_file", required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="the tiling grammar (its part types give the letters; its rules check strings)")
@click.option("-n", "count", default=10, show_default=True, type=click.IntRange(1, 100_000),
              help="how many different strings to print")
@click.option("--decode", "text", default=None, metavar="STRING",
              help="decode STRING instead: print its graph or where it breaks the grammar")
@click.option("--format", "fmt", type=click.Choice(["smiles", "string2shape"]), default="smiles",
              show_default=True, help="string format (string2shape: the authors' code's)")
@click.option("--seed", default=0, show_default=True, type=int, help="random roots and orders")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def strings_command(model: Path | None, grammar_file: Path, count: int, text: str | None, fmt: str,
                    seed: int, as_json: bool) -> None:
    """Print shape strings of MODEL's shape graph, or decode one with --decode.

    \b
    grammarkit strings castle_small.glb --grammar castle.grammar -n 20
    grammarkit strings --decode "TW(W1)GW..." --grammar castle.grammar
    """
    from .strings import Alphabet, strings_of
    from .topology import TopologyRules

    if (model is None) == (text is None):
        raise click.UsageError("give a MODEL file to encode, or --decode STRING (one of them)")
    grammar = _grammar(grammar_file)
    rules = TopologyRules.from_grammar(grammar)
    alphabet = Alphabet.for_types(rules.types)
    if fmt == "string2shape":
        alphabet = Alphabet.for_types(rules.types, "index")
    if text is not None:
        _decode_and_report(text, alphabet, rules, fmt, as_json)
        return
    import numpy as np

    from grammarkit.tiling import read_assembly, shape_graph

    from .graphs import TypedGraph

    asm = read_assembly(model, grammar=grammar)
    sg = shape_graph(asm)
    order = {p.id: k for k, p in enumerate(asm.parts)}
    graph = TypedGraph.make([p.type for p in asm.parts], [(order[u], order[v]) for u, v in sg.edges()])
    problems = rules.check(graph)
    found = strings_of(graph, alphabet, count, rng=np.random.default_rng(seed), fmt=fmt)
    if as_json:
        click.echo(json.dumps({"model": str(model), "alphabet": alphabet.to_json(), "format": fmt,
                               "parts": len(graph), "edges": len(graph.edges), "cycles": graph.cycle_rank,
                               "strings": found, "violations": [p.message for p in problems]}, indent=1))
    else:
        for s in found:
            click.echo(s)
    click.echo(f"{model}: {len(graph)} parts, {len(graph.edges)} contacts, {graph.cycle_rank} cycle "
               f"edge(s); letters {alphabet.describe()}", err=True)
    if len(found) < count:
        click.echo(f"note: {len(found)} different strings found (of {count} asked) in {20 * count} random "
                   "traversals; a small graph has few", err=True)
    for p in problems[:5]:
        click.echo(f"warning: the model breaks a topology rule: {p.message}", err=True)


def _decode_and_report(text: str, alphabet, rules, fmt: str, as_json: bool) -> None:  # noqa: ANN001
    from .strings import ShapeStringError, decode

    parsed = decode(text, alphabet, fmt)
    g = parsed.graph
    problems = rules.check(g)
    if problems:
        located = []
        for p in problems:
            if p.edge is not None:
                at = parsed.edge_index.get(p.edge)
            elif p.node is not None:
                at = parsed.node_index[p.node]
            else:
                at = None
            where = f"the part at character {at + 1}: " if at is not None and p.edge is None and p.node is not None else ""
            located.append((f"[{p.rule}] {where}{p.message}", at))
        head, *more = located
        raise ShapeStringError(head[0], parsed.text, head[1], more=more,
                               hint=None if not rules.deferred else
                               f"not checked on strings (needs geometry): {', '.join(rules.deferred)}")
    if as_json:
        click.echo(json.dumps({"string": parsed.text, "format": fmt, "valid": True,
                               "nodes": [{"id": i, "type": t, "character": parsed.node_index[i] + 1}
                                         for i, t in enumerate(g.types)],
                               "edges": [list(e) for e in g.edges], "histogram": g.histogram(),
                               "cycles": g.cycle_rank, "deferred": list(rules.deferred)}, indent=1))
        return
    click.echo(f"{len(g)} parts, {len(g.edges)} edges ({g.cycle_rank} cycle edge(s)); histogram "
               + ", ".join(f"{t} {c}" for t, c in g.histogram().items()))
    for i, t in enumerate(g.types):
        nbrs = sorted(b if a == i else a for a, b in g.edges if i in (a, b))
        click.echo(f"  {i:3d} {t:<12} (character {parsed.node_index[i] + 1}): neighbours "
                   + ", ".join(f"{j} {g.types[j]}" for j in nbrs))
    click.echo("valid: the graph obeys the grammar's topology rules"
               + (f" ({', '.join(rules.deferred)} need geometry and are checked in 3D)" if rules.deferred else ""))


# --------------------------------------------------------------------------------------------
# grammarkit dataset
# --------------------------------------------------------------------------------------------
@click.command("dataset")
@click.argument("grammar_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--from", "source", default="graph-sampler", show_default=True,
              help="the back end whose results become training shapes")
@click.option("-n", "count", default=1000, show_default=True, type=click.IntRange(1, 1_000_000),
              help="results to ask the back end for")
@click.option("-o", "--out", required=True, type=click.Path(path_type=Path), help="dataset folder")
@click.option("--iterations", default=4, show_default=True, type=click.IntRange(1), help="back-end iterations")
@click.option("--option", "options", multiple=True, metavar="KEY=VALUE", help="back-end option; repeatable")
@click.option("--strings-per-graph", default=10, show_default=True, type=click.IntRange(1, 1000),
              help="different strings drawn per graph")
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--workers", default=1, show_default=True, type=click.IntRange(1, 64),
              help="back-end worker processes")
@click.option("--no-examples", is_flag=True, help="leave the grammar's examples out")
@click.option("--no-frames", is_flag=True, help="do not store part frames (they are needed to learn "
              "edge categories for instantiation)")
@click.option("--overwrite", is_flag=True, help="replace an existing dataset in the folder")
def dataset_command(grammar_file: Path, source: str, count: int, out: Path, iterations: int,
                    options: tuple[str, ...], strings_per_graph: int, seed: int, workers: int,
                    no_examples: bool, no_frames: bool, overwrite: bool) -> None:
    """Build a training set of shape graphs and strings from a back end's output.

    \b
    grammarkit dataset castle.grammar --from graph-sampler -n 5000 -o castle_ds/
    """
    from rich.console import Console

    from .dataset import build_dataset, write_dataset

    if out.exists() and not out.is_dir():
        raise GrammarkitError(f"{out}: is a file; a dataset is a folder (e.g. -o castle_ds/)")
    if out.is_dir() and (out / "dataset.json").exists() and not overwrite:
        raise GrammarkitError(f"{out}: holds a dataset already; use --overwrite to replace it")
    grammar = _grammar(grammar_file)
    console = Console(stderr=True)
    progress, factory = progress_factory(console)
    with progress:
        ds, report = build_dataset(grammar, source=source, n=count, seed=seed, iterations=iterations,
                                   options=_pairs(options), strings_per_graph=strings_per_graph,
                                   include_examples=not no_examples, frames=not no_frames,
                                   workers=workers, progress=factory, grammar_file=str(grammar_file))
    if len(ds) == 0:
        raise GrammarkitError(f"{grammar_file}: no valid graph to write (skipped: {report})")
    write_dataset(ds, out, overwrite=overwrite)
    click.echo(f"wrote {out}: {len(ds)} graphs, {ds.meta['strings']} strings (up to {strings_per_graph} per "
               f"graph; {report['graphs_with_fewer_strings']} graph(s) have fewer), longest "
               f"{ds.meta['max_tokens']} tokens, ring labels up to {ds.meta['max_ring_label']}; skipped "
               f"{report['duplicates']} duplicate(s), {report['invalid']} invalid")
    if report["shortfall"]:
        click.echo(f"note: {report['shortfall']}", err=True)
    for msg in report["invalid_examples"]:
        click.echo(f"warning: example left out: {msg}", err=True)


# --------------------------------------------------------------------------------------------
# grammarkit train string-vae
# --------------------------------------------------------------------------------------------
@click.command("string-vae")
@click.argument("dataset_dir", type=click.Path(path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="model file to write (.vae)")
@click.option("--epochs", default=50, show_default=True, type=click.IntRange(1, 100_000))
@click.option("--batch-size", default=128, show_default=True, type=click.IntRange(1, 65536))
@click.option("--lr", default=2e-3, show_default=True, type=click.FloatRange(min=0, min_open=True))
@click.option("--latent", default=56, show_default=True, type=click.IntRange(1, 4096))
@click.option("--hidden", default=192, show_default=True, type=click.IntRange(8, 8192), help="decoder GRU size")
@click.option("--beta", default=None, type=click.FloatRange(min=0), help="final KL weight (default: TrainConfig's)")
@click.option("--word-dropout", default=None, type=click.FloatRange(0, 1), help="decoder input dropout")
@click.option("--strings-per-epoch", default=None, type=click.IntRange(1),
              help="strings of each graph used per epoch (default: all)")
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--threads", default=1, show_default=True, type=click.IntRange(1, 256), help="torch threads")
@click.option("--time-limit", default=None, type=click.FloatRange(min=1), help="stop after the epoch "
              "that passes this many seconds (the model is still written)")
def train_string_vae(dataset_dir: Path, out: Path, epochs: int, batch_size: int, lr: float, latent: int,
                     hidden: int, beta: float | None, word_dropout: float | None, strings_per_epoch: int | None,
                     seed: int, threads: int, time_limit: float | None) -> None:
    """Train the string VAE on DATASET_DIR (from `grammarkit dataset`), on the CPU.

    \b
    grammarkit train string-vae castle_ds/ -o castle.vae --epochs 50
    """
    from .requires import require_learning

    require_learning("grammarkit train string-vae")
    from dataclasses import replace

    from .dataset import load_dataset
    from .train import TrainConfig
    from .vaefile import train_and_save

    if out.suffix.lower() in (".glb", ".json", ".grammar"):
        raise click.BadParameter(f"{out.name!r} does not look like a model file; use a name ending in .vae",
                                 param_hint="-o")
    from grammarkit.fileio import check_outputs

    check_outputs({"-o": out}, inputs=[dataset_dir])  # refused before training, not after it
    ds = load_dataset(dataset_dir)
    cfg = TrainConfig(epochs=epochs, batch_size=batch_size, lr=lr, latent=latent, hidden=hidden,
                      seed=seed, threads=threads, time_limit=time_limit, strings_per_epoch=strings_per_epoch)
    if beta is not None:
        cfg = replace(cfg, beta=beta)
    if word_dropout is not None:
        cfg = replace(cfg, word_dropout=word_dropout)
    progress, report = _epoch_progress(epochs, lambda row: (
        f"loss {row['loss']:.2f} KL {row['kl']:.2f} (beta {row['beta']:.2f}) "
        f"recon {row['val_recon']:.2f} validity {row['validity']:.2f}"))
    with progress:
        summary = train_and_save(ds, cfg, out, progress=report)
    click.echo(f"wrote {out}: {summary['train_graphs']} training graphs ({summary['train_strings']} strings), "
               f"{summary['epochs']} epochs in {summary['seconds']:.0f} s; last epoch: loss "
               f"{summary['last']['loss']:.2f}, KL {summary['last']['kl']:.2f}, validation reconstruction "
               f"{summary['last']['val_recon']:.2f}, prior validity (free decoding) {summary['last']['validity']:.2f}")
    if summary.get("stopped"):
        click.echo(f"note: {summary['stopped']}", err=True)


# --------------------------------------------------------------------------------------------
# grammarkit vae-metrics
# --------------------------------------------------------------------------------------------
@click.command("vae-metrics")
@click.argument("model", type=click.Path(path_type=Path))
@click.option("--samples", default=1000, show_default=True, type=click.IntRange(1, 1_000_000),
              help="prior samples decoded per decoding mode")
@click.option("--grammar", "grammar_file", default=None, type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="check the model against this grammar (its hash) first")
@click.option("--decoding", type=click.Choice(["both", "free", "masked"]), default="both", show_default=True)
@click.option("--mode-seeds", default=128, show_default=True, type=click.IntRange(0),
              help="training points (perturb) / points (interpolate, path) per sampling mode; 0: skip")
@click.option("--graph-size", default=1000, show_default=True, type=click.IntRange(0),
              help="nodes of the latent search graph (Table 2); 0: skip")
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--threads", default=1, show_default=True, type=click.IntRange(1, 256), help="torch threads")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def vae_metrics_command(model: Path, samples: int, grammar_file: Path | None, decoding: str, mode_seeds: int,
                        graph_size: int, seed: int, threads: int, as_json: bool) -> None:
    """Validity, unique@1k, novelty, diversity, sampling yields and latent-graph statistics of MODEL.

    \b
    grammarkit vae-metrics castle.vae --samples 1000
    """
    from .requires import require_learning

    require_learning("grammarkit vae-metrics")
    import torch

    from .metrics import vae_metrics
    from .modelfile import load_vae

    torch.set_num_threads(threads)
    vae = load_vae(model, grammar=_grammar(grammar_file) if grammar_file else None)
    decodings = ("free", "masked") if decoding == "both" else (decoding,)
    result = vae_metrics(vae, samples=samples, seed=seed, modes=mode_seeds > 0, graph_size=graph_size,
                         decodings=decodings, mode_seeds=max(1, mode_seeds))
    if as_json:
        click.echo(json.dumps(result, indent=1, default=str))
        return
    click.echo(format_metrics(result, samples))


def _f(x: Any, digits: int = 3) -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def format_metrics(r: dict, samples: int) -> str:
    """The metrics as Markdown tables."""
    k = min(1000, samples)
    lines = [f"model {r['model']} (grammar {r['grammar']}): {r['training_graphs']} training graphs, "
             f"training-set internal diversity {_f(r['training_internal_diversity'])}", "",
             f"| decoding | samples | validity | unique@{k} | novelty | internal diversity | "
             "nearest-training similarity | mean parts | repaired (backtrack/resample/rules/failed) | seconds |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for dec in ("free", "masked"):
        m = r.get(f"prior_{dec}")
        if m is None:
            continue
        rep = m["repaired"]
        lines.append(f"| {dec} | {m['samples']} | {_f(m['validity'])} | {_f(m[f'unique@{k}'])} | "
                     f"{_f(m['novelty'])} | {_f(m['internal_diversity'])} | {_f(m['nearest_training_similarity'])} | "
                     f"{_f(m['mean_parts'], 1)} | {rep['backtrack']}/{rep['resample']}/{rep['rules']}/{rep['failed']} | {m['seconds']} |")
    for dec in ("free", "masked"):
        modes = r.get(f"modes_{dec}")
        if not modes:
            continue
        lines += ["", f"Sampling modes ({dec} decoding): yield = new graphs found / latent points decoded",
                  "", "| mode | decoded | valid | found | distinct | novel | yield | novel yield | seconds |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for mode, m in modes.items():
            lines.append(f"| {mode} | {m['decoded']} | {m['valid']} | {m['found']} | {m['distinct']} | {m['novel']} | "
                         f"{_f(m['yield'])} | {_f(m['novel_yield'])} | {m['seconds']} |")
    t = r.get("table2")
    if t:
        lines += ["", f"Latent search graph (the paper's Table 2): {t['size']} valid points, k = {t['k']}", "",
                  "| graph | nodes | edges | connected components | unconnected pairs | mean path weight | "
                  "max path weight | mean path edges |", "|---|---|---|---|---|---|---|---|"]
        for kind in ("naive", "latent"):
            s = t[kind]
            lines.append(f"| {kind} | {s['nodes']} | {s['edges']} | {s['components']} | {s['unconnected_pairs']}/"
                         f"{s['pairs']} | {_f(s['mean_path_weight'], 2)} | {_f(s['max_path_weight'], 2)} | "
                         f"{_f(s['mean_path_edges'], 1)} |")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# instantiation: grammarkit train edge-categories / instantiate / compress / decompress
# --------------------------------------------------------------------------------------------
def _dataset_grammar(ds, grammar_file: Path | None):  # noqa: ANN001, ANN202
    if grammar_file is None:
        stored = ds.meta.get("grammar_file")
        if not stored or not Path(stored).exists():
            raise click.UsageError("give --grammar GRAMMAR (the dataset does not name a grammar file that exists)")
        grammar_file = Path(stored)
    return _grammar(grammar_file)


@click.command("edge-categories")
@click.argument("dataset_dir", type=click.Path(path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="model file to write (.edges)")
@click.option("--grammar", "grammar_file", default=None, type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="the grammar (default: the one the dataset was made from)")
@click.option("--epochs", default=20, show_default=True, type=click.IntRange(1, 100_000))
@click.option("--strings-per-graph", default=8, show_default=True, type=click.IntRange(1, 1000),
              help="training strings drawn per graph")
@click.option("--votes", default=8, show_default=True, type=click.IntRange(1, 1000),
              help="strings per graph that vote on each edge's category")
@click.option("--bandwidth", default=0.02, show_default=True, type=click.FloatRange(min=1e-6),
              help="Mean Shift bandwidth, as a fraction of the parts' size")
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--threads", default=1, show_default=True, type=click.IntRange(1, 256))
@click.option("--time-limit", default=None, type=click.FloatRange(min=1))
@click.option("--paper", is_flag=True, help="the paper's predictor: a left-to-right LSTM on the letters only, "
              "majority voting (default: bidirectional, summed log-probability votes)")
@click.option("--graph-features", is_flag=True, help="give the LSTM each character's graph features (neighbour "
              "types at distance 1 and 2 of the edge's parts) besides its letter")
@click.option("--voting", type=click.Choice(["majority", "logprob", "joint"]), default=None,
              help="how the strings' predictions are combined (default: logprob; with --paper: majority)")
def train_edge_categories(dataset_dir: Path, out: Path, grammar_file: Path | None, epochs: int, strings_per_graph: int,
                          votes: int, bandwidth: float, seed: int, threads: int, time_limit: float | None,
                          paper: bool, graph_features: bool, voting: str | None) -> None:
    """Learn edge categories (Mean Shift) from DATASET_DIR and train the LSTM that predicts them.

    \b
    grammarkit train edge-categories castle_ds/ -o castle.edges
    """
    from .requires import require_learning

    require_learning("grammarkit train edge-categories")
    from .dataset import load_dataset
    from .edgemodel import EdgeTrainConfig, save_edge_model, train_edge_model

    ds = load_dataset(dataset_dir)
    grammar = _dataset_grammar(ds, grammar_file)
    cfg = EdgeTrainConfig(epochs=epochs, strings_per_graph=strings_per_graph, vote_strings=votes,
                          bandwidth=bandwidth, seed=seed, threads=threads, time_limit=time_limit,
                          bidirectional=not paper, graph_features=graph_features and not paper,
                          voting=voting or ("majority" if paper else "logprob"))
    progress, report = _epoch_progress(epochs, lambda row: (
        f"loss {row['loss']:.3f} accuracy {row['char_accuracy']:.3f} "
        f"voted {row['edge_accuracy_voted']:.3f}"))
    with progress:
        em = train_edge_model(ds, grammar, cfg, progress=report)
    save_edge_model(em, out)
    last = em.meta["training"]["history"][-1]
    pairs = ", ".join(f"{a}-{b} {len(v)}" for (a, b), v in sorted(em.categories.by_pair.items()))
    click.echo(f"wrote {out}: {len(em.categories)} edge categories ({pairs}); validation accuracy "
               f"{last['char_accuracy']:.3f} per character, {last['edge_accuracy_voted']:.3f} per edge with voting")


def _edge_model(path: Path, grammar):  # noqa: ANN001, ANN202
    from .requires import require_learning

    require_learning("instantiation")
    from .edgemodel import load_edge_model

    return load_edge_model(path, grammar)


@click.command("instantiate")
@click.argument("text", metavar="STRING")
@click.option("--grammar", "grammar_file", required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--model", "model_file", required=True, type=click.Path(path_type=Path), help="edge-category model (.edges)")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False, path_type=Path), help="shape file (.glb)")
@click.option("--format", "fmt", type=click.Choice(["smiles", "string2shape"]), default="smiles", show_default=True)
@click.option("--tries", default=8, show_default=True, type=click.IntRange(1, 10_000), help="start edges tried")
@click.option("--votes", default=8, show_default=True, type=click.IntRange(1, 1000))
@click.option("--voting", type=click.Choice(["majority", "logprob", "joint"]), default=None,
              help="how the strings' predictions are combined (default: the model's)")
@click.option("--search", type=click.Choice(["consistent", "backtracking", "consistent+backtracking"]),
              default="consistent+backtracking", show_default=True,
              help="consistent: beam search for categories that close every cycle (beyond the paper); "
              "backtracking: the paper's insertion with Monte-Carlo fallback")
@click.option("--beam", default=16, show_default=True, type=click.IntRange(1, 100_000),
              help="consistent search: placements kept per part")
@click.option("--seed", default=0, show_default=True, type=int)
def instantiate_command(text: str, grammar_file: Path, model_file: Path, out: Path, fmt: str, tries: int, votes: int,
                        voting: str | None, search: str, beam: int, seed: int) -> None:
    """Turn one shape STRING into a 3D shape, or say why it could not.

    \b
    grammarkit instantiate "T1WWTWWTWWTWW1" --grammar castle.grammar --model castle.edges -o shape.glb
    """
    from grammarkit.tiling import write_assembly

    from .instantiate import Instantiator
    from .strings import Alphabet, convert

    grammar = _grammar(grammar_file)
    em = _edge_model(model_file, grammar)
    if fmt == "string2shape":
        text = convert(text, Alphabet.for_types(em.alphabet.types, "index"), source="string2shape",
                       target="smiles", target_alphabet=em.alphabet)
    from .topology import TopologyRules

    _decode_and_check(text, em.alphabet, TopologyRules.from_grammar(grammar))
    from .strings import decode

    from types import SimpleNamespace

    from .consistent import ConsistentDecoder
    from .generate import instantiate_graph

    graph = decode(text, em.alphabet).graph
    inst = Instantiator(grammar, em.categories)
    opts = SimpleNamespace(voting=voting, search=search, votes=votes, tries=tries)
    result, _ = instantiate_graph(em, inst, ConsistentDecoder(inst, beam=beam), graph, opts, seed, None)
    if not result.ok:
        raise GrammarkitError(f"could not instantiate the string ({search} search, {result.tries} "
                              f"tr{'y' if result.tries == 1 else 'ies'}): {result.reason}")
    result.assembly.name = out.stem
    write_assembly(result.assembly, out)
    click.echo(f"wrote {out}: {len(graph)} parts; {search} search, {result.tries} tr{'y' if result.tries == 1 else 'ies'}, "
               f"{result.insertions} placements tested, {result.monte_carlo} edge(s) not at their best voted category")


def _decode_and_check(text: str, alphabet, rules) -> None:  # noqa: ANN001
    """Raise the located error of an invalid string (as `strings --decode` prints it)."""
    import io
    import contextlib

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        _decode_and_report(text, alphabet, rules, "smiles", True)


@click.command("compress")
@click.argument("shape", type=click.Path(exists=True, path_type=Path))
@click.option("--grammar", "grammar_file", required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--model", "model_file", required=True, type=click.Path(path_type=Path), help="edge-category model (.edges)")
@click.option("-o", "--out", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="record file (default: print it)")
def compress_command(shape: Path, grammar_file: Path, model_file: Path, out: Path | None) -> None:
    """Write SHAPE as its string and edge categories (rebuilt by `grammarkit decompress`)."""
    from grammarkit.run import grammar_hash, write_files
    from grammarkit.tiling import read_assembly

    from .compress import compress, dumps

    grammar = _grammar(grammar_file)
    em = _edge_model(model_file, grammar)
    asm = read_assembly(shape, grammar=grammar)
    record = compress(asm, em.categories, em.alphabet, grammar_name=grammar.name, grammar_hash=grammar_hash(grammar))
    text = dumps(record)
    if out is None:
        click.echo(text, nl=False)
        return
    write_files({out: text})
    size = shape.stat().st_size
    click.echo(f"wrote {out}: {len(text)} bytes for {record['parts']} parts ({size} bytes of {shape.suffix[1:]})",
               err=True)


@click.command("decompress")
@click.argument("record_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--grammar", "grammar_file", required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--model", "model_file", required=True, type=click.Path(path_type=Path), help="edge-category model (.edges)")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False, path_type=Path), help="shape file (.glb)")
def decompress_command(record_file: Path, grammar_file: Path, model_file: Path, out: Path) -> None:
    """Rebuild a shape from a record of `grammarkit compress`."""
    from grammarkit.run import grammar_hash
    from grammarkit.tiling import validate, write_assembly

    from .compress import decompress
    from .instantiate import Instantiator

    grammar = _grammar(grammar_file)
    em = _edge_model(model_file, grammar)
    try:
        record = json.loads(record_file.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise GrammarkitError(f"{record_file}: not a compressed shape record ({exc})") from None
    if isinstance(record, dict) and record.get("grammar_hash") not in (None, grammar_hash(grammar)):
        raise GrammarkitError(f"{record_file}: compressed for grammar {record.get('grammar')!r}, not {grammar.name!r}")
    try:
        asm = decompress(record, em.categories, em.alphabet, Instantiator(grammar, em.categories))
    except GrammarkitError as exc:
        raise GrammarkitError(f"{record_file}: {exc}") from None
    report = validate(grammar, asm)
    if not report.ok:
        raise GrammarkitError(f"{record_file}: the rebuilt shape breaks the grammar ({report.violations[0].format()}); "
                              "nothing written")
    asm.name = out.stem
    write_assembly(asm, out)
    click.echo(f"wrote {out}: {len(asm)} parts")


def _epoch_progress(epochs: int, describe: Callable[[dict], str]) -> tuple[Any, Callable[[dict], None]]:
    """A progress bar over training epochs, and the callback that advances it with a line of
    metrics (also printed per epoch when stderr is not a terminal, e.g. in logs)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True)
    progress = Progress(TextColumn("[bold]training"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                        TextColumn("{task.fields[info]}"), console=console, disable=not console.is_terminal)
    task = progress.add_task("train", total=epochs, info="")

    def report(row: dict) -> None:
        info = describe(row)
        progress.update(task, advance=1, info=info)
        if not console.is_terminal:
            click.echo(f"epoch {row['epoch']}/{epochs}: {info}", err=True)

    return progress, report
