"""Training, saving and loading the edge-category model (`.edges`): categories + the LSTM.

`train_edge_model(dataset, grammar)` learns the categories from the dataset's part frames
(categories.py), draws `strings_per_graph` strings of every graph with known node order,
labels their characters from the geometry and trains the predictor (predictor.py) with the
masked cross-entropy. Graphs are split into training and validation sets; the history records
the validation accuracy per character without voting and per edge with each voting
(predictor.py: the paper's majority, summed log-probabilities, joint per part). The training
graphs' part configurations (which (neighbour type, category) sets each part type has) are kept
for joint voting.

`EdgeTrainConfig(bidirectional=False, graph_features=False, voting="majority")` is the paper's
predictor; the defaults are this project's (bidirectional, summed log-probability votes;
graph features and joint voting on request).

The file is safetensors (network tensors) with metadata: format, version, grammar name and
hash, alphabet, vocabulary, categories, network sizes, training history. Loading checks all of
them like the string-VAE model file does.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from grammarkit.errors import GrammarkitError

from .categories import EdgeCategories, PartLibrary, edge_labels, learn_categories
from .dataset import Dataset
from .modelfile import ModelFileError, _header
from .strings import Alphabet, encode_with_order
from .vocab import Vocab

__all__ = ["EDGE_FORMAT", "EdgeModel", "EdgeTrainConfig", "load_edge_model", "save_edge_model", "train_edge_model"]

EDGE_FORMAT = "grammarkit-edge-categories"
EDGE_FORMAT_VERSION = 2  # 2: direction, graph features, voting and part configurations
READS_VERSIONS = ("1", "2")


@dataclass(frozen=True)
class EdgeTrainConfig:
    epochs: int = 20
    batch_size: int = 64
    lr: float = 3e-3
    hidden: int = 128
    embed: int = 32
    layers: int = 2
    strings_per_graph: int = 8
    vote_strings: int = 8
    bandwidth: float = 0.02
    val_fraction: float = 0.1
    seed: int = 0
    threads: int = 1
    time_limit: float | None = None
    bidirectional: bool = True  # False: the paper's left-to-right LSTM
    # graph features per character: within the benchmark's 10-minute budget they did not help
    # (docs/string-vae.md, "Measured"), so they are an option
    graph_features: bool = False
    # "majority" (the paper's), "logprob" or "joint". Joint voting raises per-edge accuracy a
    # little but its errors are correlated (a part's edges all wrong together), which the
    # instantiation's search repairs less often (docs/string-vae.md, "Measured"): not the default
    voting: str = "logprob"

    def to_json(self) -> dict:
        return dict(self.__dict__)


@dataclass
class EdgeModel:
    model: Any  # CategoryLSTM
    vocab: Vocab
    categories: EdgeCategories
    meta: dict = field(default_factory=dict)
    path: Path | None = None

    @property
    def alphabet(self) -> Alphabet:
        return self.vocab.alphabet

    @property
    def voting(self) -> str:
        """The voting this model was trained for ("logprob" for version-1 files)."""
        return str(self.meta.get("training", {}).get("config", {}).get("voting", "logprob"))

    def predict(self, graph, *, strings: int | None = None, seed: int = 0,  # noqa: ANN001
                voting: str | None = None) -> dict:
        from .predictor import predict_graph

        n = strings or int(self.meta.get("training", {}).get("config", {}).get("vote_strings", 8))
        return predict_graph(self.model, graph, self.vocab, self.categories, strings=n, seed=seed,
                             voting=voting or self.voting, configurations=self.configurations)

    @property
    def configurations(self) -> set:
        return self.meta.get("configurations") or set()

    def rankings(self, graph, *, strings: int | None = None, seed: int = 0,  # noqa: ANN001
                 voting: str | None = None) -> dict:
        """Per edge (u, v), u < v: the categories of its type pair, the chosen one first, then
        the others by their votes."""
        out = {}
        for e, (k, votes) in self.predict(graph, strings=strings, seed=seed, voting=voting).items():
            order = [k] + [int(c) for c in np.argsort(-votes, kind="stable") if votes[c] > -1e8 and c != k]
            out[e] = order
        return out


def _labels(dataset: Dataset, g: int, cats: EdgeCategories, cache: dict | None = None) -> dict:
    """Graph g's edge labels from its frames (computed once per graph with a `cache`)."""
    if cache is not None and g in cache:
        return cache[g]
    out = edge_labels(dataset.graphs[g], dataset.frames[g], cats, dataset.variants[g] if dataset.variants else None)
    if cache is not None:
        cache[g] = out
    return out


def _examples(dataset: Dataset, idx, cats: EdgeCategories, vocab: Vocab, per_graph: int, seed: int,
              types: tuple[str, ...] = (), cache: dict | None = None):
    """Rows (ids, targets, allowed, features, graph index, token edges): `per_graph` random
    strings of each graph in `idx`, labelled from its frames."""
    from .predictor import encode_targets

    rows = []
    for g in idx:
        graph = dataset.graphs[g]
        labels = _labels(dataset, g, cats, cache)
        rng = np.random.default_rng([seed, g])
        for _ in range(per_graph):
            text, order = encode_with_order(graph, vocab.alphabet, rng=rng)
            ids, tg, al, ge, ft = encode_targets(graph, text, order, vocab, cats, labels, types)
            rows.append((ids, tg, al, ft, g, ge))
    return rows


def part_configurations(dataset: Dataset, idx, cats: EdgeCategories, cache: dict | None = None) -> set:
    """Every `node_configuration` of the labelled graphs `idx` (graphs with an edge of no
    category are left out)."""
    from .predictor import node_configuration

    out = set()
    for g in idx:
        graph = dataset.graphs[g]
        labels = _labels(dataset, g, cats, cache)
        if any(labels.get(e) is None for e in graph.edges):
            continue
        adj = graph.adjacency()
        for x in range(len(graph.types)):
            out.add(node_configuration(graph, adj, x, lambda u, v: labels[(u, v)], cats))
    return out


def train_edge_model(dataset: Dataset, grammar: Any, config: EdgeTrainConfig = EdgeTrainConfig(), *,
                     progress: Callable[[dict], None] | None = None) -> EdgeModel:
    import torch

    from grammarkit.run import grammar_hash

    from .predictor import IGNORE, CategoryLSTM, PredictorConfig, _batch

    if dataset.grammar_hash != grammar_hash(grammar):
        raise GrammarkitError(f"{dataset.path}: the dataset was made for grammar {dataset.meta.get('grammar')!r}, "
                              f"not for {grammar.name!r}")
    with_frames = [i for i, f in enumerate(dataset.frames) if f is not None]
    if len(with_frames) < 4:
        raise GrammarkitError(f"{dataset.path}: {len(with_frames)} graph(s) with part frames; edge categories "
                              "need at least 4 (build the dataset without --no-frames)")
    torch.manual_seed(config.seed)
    torch.set_num_threads(max(1, config.threads))
    library = PartLibrary(grammar)
    cats = learn_categories(dataset.graphs, dataset.frames, library, bandwidth=config.bandwidth,
                            variants=dataset.variants if any(v is not None for v in dataset.variants) else None)
    vocab = Vocab(dataset.alphabet, max(1, int(dataset.meta.get("max_ring_label", 1))) + 4)
    rng = np.random.default_rng(config.seed)
    order = rng.permutation(with_frames)
    # at most 100 validation graphs: evaluating (with joint voting) after every epoch costs time
    n_val = min(max(1, int(round(config.val_fraction * len(order)))), 100)
    val_g, train_g = sorted(order[:n_val].tolist()), sorted(order[n_val:].tolist())
    if config.voting not in ("majority", "logprob", "joint"):
        raise GrammarkitError(f"unknown voting {config.voting!r}: majority, logprob or joint")
    types = tuple(vocab.alphabet.types) if config.graph_features else ()
    cache: dict = {}
    train_rows = _examples(dataset, train_g, cats, vocab, config.strings_per_graph, config.seed, types, cache)
    val_rows = _examples(dataset, val_g, cats, vocab, config.vote_strings, config.seed + 1, types, cache)
    configurations = part_configurations(dataset, train_g, cats, cache)
    C = len(cats)
    pcfg = PredictorConfig(vocab_size=len(vocab), n_categories=C, embed=config.embed, hidden=config.hidden,
                           layers=config.layers, bidirectional=config.bidirectional,
                           features=4 * len(types), types=types)
    model = CategoryLSTM(pcfg)
    opt = torch.optim.Adam(model.parameters(), lr=config.lr)
    history = []
    t0 = time.perf_counter()
    stopped = None
    for epoch in range(1, config.epochs + 1):
        model.train()
        tot = n = 0.0
        for batch in _length_batches(train_rows, config.batch_size, rng):
            rows = [train_rows[i][:4] for i in batch]
            X, Y, A, F = _batch(rows, C)
            logits = model(X, A, F)
            # masked categories are -inf: pick finite entries only for the loss
            logits = torch.where(torch.isfinite(logits), logits, torch.full_like(logits, -1e4))
            loss = torch.nn.functional.cross_entropy(logits.reshape(-1, C), Y.reshape(-1), ignore_index=IGNORE)
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += float(loss.detach()) * len(rows)
            n += len(rows)
        row = {"epoch": epoch, "loss": tot / max(n, 1),
               **evaluate(model, val_rows, cats, C, dataset.graphs, configurations),
               "seconds": round(time.perf_counter() - t0, 1)}
        history.append(row)
        if progress is not None:
            progress(row)
        if config.time_limit is not None and time.perf_counter() - t0 > config.time_limit and epoch < config.epochs:
            stopped = f"time limit of {config.time_limit:g} s reached after epoch {epoch} of {config.epochs}"
            break
    model.eval()
    meta = {"grammar": grammar.name, "grammar_hash": grammar_hash(grammar),
            "training": {"config": config.to_json(), "history": history, "train_graphs": len(train_g),
                         "val_graphs": len(val_g), "stopped": stopped,
                         "dataset": str(dataset.path) if dataset.path else None},
            "configurations": configurations}
    return EdgeModel(model, vocab, cats, meta)


def _length_batches(rows, size: int, rng) -> list:  # noqa: ANN001
    """Batches of row indices in a random order, each of strings of similar length (rows are
    shuffled, sorted by length within windows of 32 batches, cut into batches, and the batches
    shuffled): far less padding for the LSTM to run over than random batches."""
    perm = rng.permutation(len(rows))
    window = 32 * size
    batches = []
    for w in range(0, len(perm), window):
        chunk = sorted(perm[w:w + window].tolist(), key=lambda i: len(rows[i][0]))
        batches += [chunk[b:b + size] for b in range(0, len(chunk), size)]
    return [batches[i] for i in rng.permutation(len(batches))]


def evaluate(model, rows, cats: EdgeCategories, C: int, graphs=None, configurations=None,  # noqa: ANN001
             decoder=None) -> dict:  # noqa: ANN001
    """Validation accuracy per character (no voting) and per edge, voting over each graph's
    strings (`rows` holds several strings per graph): `edge_accuracy_majority` (the paper's
    voting), `edge_accuracy_voted` (summed log-probabilities) and, with `graphs` (indexable by
    the rows' graph index) and `configurations`, `edge_accuracy_joint`; with `graphs` and a
    `decoder` (consistent.ConsistentDecoder), `edge_accuracy_consistent`: the cycle-consistent
    decoding of the summed log-probabilities (a graph for which it finds no consistent
    labelling keeps its voted categories), `consistent_graphs` the share of graphs it found one
    for and `consistent_seconds` its time per graph."""
    import torch

    from .predictor import IGNORE, _batch, assign_jointly, flip, vote

    model.eval()
    right = total = 0
    per_edge: dict[tuple[int, tuple[int, int]], list[np.ndarray]] = {}
    truth: dict[tuple[int, tuple[int, int]], int] = {}
    rows = sorted(rows, key=lambda r: len(r[0]))  # less padding
    with torch.no_grad():
        for b in range(0, len(rows), 128):
            chunk = rows[b:b + 128]
            X, Y, A, F = _batch([r[:4] for r in chunk], C)
            logp = torch.log_softmax(model(X, A, F), dim=2).numpy()
            pred = logp.argmax(axis=2)
            for i, r in enumerate(chunk):
                g, ge = r[4], r[5]
                for k, tg in enumerate(r[1]):
                    if tg == IGNORE:
                        continue
                    total += 1
                    right += int(pred[i, k] == tg)
                    u, v = ge[k]
                    lp = np.where(np.isfinite(logp[i, k]), logp[i, k], -1e9)
                    t = tg
                    if u > v:
                        u, v = v, u
                        lp = flip(lp, cats)
                        t = cats.reverse.get(tg, tg)
                    key = (g, (u, v))
                    per_edge.setdefault(key, []).append(lp)
                    truth[key] = t
    model.train()
    out = {"char_accuracy": right / max(total, 1), "val_edges": len(per_edge)}
    n = max(len(per_edge), 1)
    votes = {k: vote(v, "logprob") for k, v in per_edge.items()}
    out["edge_accuracy_majority"] = sum(int(np.argmax(vote(v, "majority")) == truth[k])
                                        for k, v in per_edge.items()) / n
    out["edge_accuracy_voted"] = sum(int(np.argmax(votes[k]) == truth[k]) for k in votes) / n
    if graphs is not None and configurations:
        by_graph: dict[int, dict] = {}
        for (g, e), v in votes.items():
            by_graph.setdefault(g, {})[e] = v
        right_j = 0
        for g, vs in by_graph.items():
            choice = assign_jointly(graphs[g], vs, cats, configurations)
            right_j += sum(int(choice[e] == truth[(g, e)]) for e in vs)
        out["edge_accuracy_joint"] = right_j / n
    if graphs is not None and decoder is not None:
        by_graph = {}
        for (g, e), v in votes.items():
            by_graph.setdefault(g, {})[e] = v
        right_c = found = 0
        secs = 0.0
        for g, vs in by_graph.items():
            res = decoder.decode(graphs[g], vs)
            found += int(res.consistent)
            secs += res.seconds
            right_c += sum(int(res.categories.get(e) == truth[(g, e)]) for e in vs)
        out["edge_accuracy_consistent"] = right_c / n
        out["consistent_graphs"] = found / max(len(by_graph), 1)
        out["consistent_seconds"] = secs / max(len(by_graph), 1)
    return out


def edge_model_bytes(em: EdgeModel) -> bytes:
    from safetensors.torch import save

    tensors = {f"model.{k}": v.detach().contiguous().clone() for k, v in em.model.state_dict().items()}
    meta = {"format": EDGE_FORMAT, "format_version": str(EDGE_FORMAT_VERSION),
            "grammar": em.meta["grammar"], "grammar_hash": em.meta["grammar_hash"],
            "alphabet": json.dumps(em.vocab.alphabet.to_json()), "vocab": json.dumps(em.vocab.to_json()),
            "categories": json.dumps(em.categories.to_json()), "config": json.dumps(em.model.config.to_json()),
            "training": json.dumps(em.meta.get("training", {})),
            "configurations": json.dumps(sorted([t, [list(p) for p in parts]]
                                                for t, parts in em.meta.get("configurations") or ()))}
    return save(tensors, metadata=meta)


def save_edge_model(em: EdgeModel, path: str | Path) -> Path:
    from grammarkit.run import write_files

    path = Path(path)
    write_files({path: edge_model_bytes(em)})
    em.path = path
    return path


def load_edge_model(path: str | Path, grammar: Any = None) -> EdgeModel:
    """Load an `.edges` file (or `builtin:NAME`, a shipped one); with `grammar`, refuse one
    trained for another grammar."""
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    from grammarkit.run import grammar_hash

    from .modelfile import resolve
    from .predictor import CategoryLSTM, PredictorConfig

    path = resolve(path, ".edges")
    if not path.exists():
        raise ModelFileError(f"{path}: no such model file")
    if path.is_dir():
        raise ModelFileError(f"{path}: is a folder, not a model file")
    try:
        raw = _header(path, expect=EDGE_FORMAT)
    except ModelFileError:
        raise
    if raw.get("format_version") not in READS_VERSIONS:
        raise ModelFileError(f"{path}: edge-category model version {raw.get('format_version')!r}; this grammarkit "
                             f"reads versions {', '.join(READS_VERSIONS)} (train it again)")
    if grammar is not None and raw.get("grammar_hash") != grammar_hash(grammar):
        raise ModelFileError(f"{path}: this edge-category model was trained for grammar {raw.get('grammar')!r} "
                             f"(hash {raw.get('grammar_hash')}), not for {grammar.name!r} (hash {grammar_hash(grammar)})")
    try:
        vocab = Vocab.from_json(json.loads(raw["vocab"]))
        cats = EdgeCategories.from_json(json.loads(raw["categories"]))
        cfg = json.loads(raw["config"])
        cfg["types"] = tuple(cfg.get("types", ()))
        config = PredictorConfig(**cfg)
        training = json.loads(raw.get("training", "{}"))
        configurations = {(str(t), tuple((str(a), int(c)) for a, c in parts))
                          for t, parts in json.loads(raw.get("configurations", "[]"))}
    except (KeyError, TypeError, ValueError, GrammarkitError) as exc:
        raise ModelFileError(f"{path}: damaged metadata ({exc})") from None
    try:
        tensors = load_file(str(path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise ModelFileError(f"{path}: damaged model file ({exc})") from None
    model = CategoryLSTM(config)
    try:
        model.load_state_dict({k[len("model."):]: v for k, v in tensors.items() if k.startswith("model.")})
    except RuntimeError as exc:
        raise ModelFileError(f"{path}: the tensors do not fit the network ({str(exc).splitlines()[0]})") from None
    model.eval()
    return EdgeModel(model, vocab, cats, {"grammar": raw.get("grammar"), "grammar_hash": raw.get("grammar_hash"),
                                          "training": training, "configurations": configurations}, path)
