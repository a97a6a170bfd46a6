"""Training, saving and loading the edge-category model (`.edges`): categories + the LSTM.

`train_edge_model(dataset, grammar)` learns the categories from the dataset's part frames
(categories.py), draws `strings_per_graph` strings of every graph with known node order,
labels their characters from the geometry and trains the predictor (predictor.py) with the
masked cross-entropy. Graphs are split into training and validation sets; the history records
the validation accuracy per character without voting and per edge with voting.

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
EDGE_FORMAT_VERSION = 1


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

    def predict(self, graph, *, strings: int | None = None, seed: int = 0) -> dict:  # noqa: ANN001
        from .predictor import predict_graph

        n = strings or int(self.meta.get("training", {}).get("config", {}).get("vote_strings", 8))
        return predict_graph(self.model, graph, self.vocab, self.categories, strings=n, seed=seed)

    def rankings(self, graph, *, strings: int | None = None, seed: int = 0) -> dict:  # noqa: ANN001
        """Per edge (u, v), u < v: the categories of its type pair, most likely first (votes)."""
        out = {}
        for e, (_k, votes) in self.predict(graph, strings=strings, seed=seed).items():
            order = [int(c) for c in np.argsort(-votes, kind="stable") if votes[c] > -1e8]
            out[e] = order
        return out


def _examples(dataset: Dataset, idx, cats: EdgeCategories, vocab: Vocab, per_graph: int, seed: int):
    from .predictor import encode_targets

    rows = []
    for g in idx:
        graph = dataset.graphs[g]
        labels = edge_labels(graph, dataset.frames[g], cats, dataset.variants[g] if dataset.variants else None)
        rng = np.random.default_rng([seed, g])
        for _ in range(per_graph):
            text, order = encode_with_order(graph, vocab.alphabet, rng=rng)
            ids, tg, al, ge = encode_targets(graph, text, order, vocab, cats, labels)
            rows.append((ids, tg, al, g, ge))
    return rows


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
    n_val = max(1, int(round(config.val_fraction * len(order))))
    val_g, train_g = sorted(order[:n_val].tolist()), sorted(order[n_val:].tolist())
    train_rows = _examples(dataset, train_g, cats, vocab, config.strings_per_graph, config.seed)
    val_rows = _examples(dataset, val_g, cats, vocab, config.vote_strings, config.seed + 1)
    C = len(cats)
    pcfg = PredictorConfig(vocab_size=len(vocab), n_categories=C, embed=config.embed, hidden=config.hidden,
                           layers=config.layers)
    model = CategoryLSTM(pcfg)
    opt = torch.optim.Adam(model.parameters(), lr=config.lr)
    history = []
    t0 = time.perf_counter()
    stopped = None
    for epoch in range(1, config.epochs + 1):
        model.train()
        perm = rng.permutation(len(train_rows))
        tot = n = 0.0
        for b in range(0, len(perm), config.batch_size):
            rows = [train_rows[i][:3] for i in perm[b:b + config.batch_size]]
            X, Y, A = _batch(rows, C)
            logits = model(X, A)
            # masked categories are -inf: pick finite entries only for the loss
            logits = torch.where(torch.isfinite(logits), logits, torch.full_like(logits, -1e4))
            loss = torch.nn.functional.cross_entropy(logits.reshape(-1, C), Y.reshape(-1), ignore_index=IGNORE)
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += float(loss.detach()) * len(rows)
            n += len(rows)
        row = {"epoch": epoch, "loss": tot / max(n, 1), **evaluate(model, val_rows, cats, C),
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
                         "dataset": str(dataset.path) if dataset.path else None}}
    return EdgeModel(model, vocab, cats, meta)


def evaluate(model, rows, cats: EdgeCategories, C: int) -> dict:  # noqa: ANN001
    """Validation accuracy per character (no voting) and per edge (votes over each graph's
    strings): `rows` holds several strings per graph."""
    import torch

    from .predictor import IGNORE, _batch

    model.eval()
    right = total = 0
    votes: dict[tuple[int, tuple[int, int]], np.ndarray] = {}
    truth: dict[tuple[int, tuple[int, int]], int] = {}
    with torch.no_grad():
        for b in range(0, len(rows), 128):
            chunk = rows[b:b + 128]
            X, Y, A = _batch([r[:3] for r in chunk], C)
            logp = torch.log_softmax(model(X, A), dim=2).numpy()
            pred = logp.argmax(axis=2)
            for i, r in enumerate(chunk):
                g, ge = r[3], r[4]
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
                        flipped = np.full_like(lp, -1e9)
                        for c in range(C):
                            rc = cats.reverse.get(c, c)
                            flipped[rc] = max(flipped[rc], lp[c])
                        lp = flipped
                        t = cats.reverse.get(tg, tg)
                    key = (g, (u, v))
                    votes[key] = votes.get(key, 0) + lp
                    truth[key] = t
    model.train()
    voted = sum(int(np.argmax(votes[k]) == truth[k]) for k in votes)
    return {"char_accuracy": right / max(total, 1), "edge_accuracy_voted": voted / max(len(votes), 1),
            "val_edges": len(votes)}


def edge_model_bytes(em: EdgeModel) -> bytes:
    from safetensors.torch import save

    tensors = {f"model.{k}": v.detach().contiguous().clone() for k, v in em.model.state_dict().items()}
    meta = {"format": EDGE_FORMAT, "format_version": str(EDGE_FORMAT_VERSION),
            "grammar": em.meta["grammar"], "grammar_hash": em.meta["grammar_hash"],
            "alphabet": json.dumps(em.vocab.alphabet.to_json()), "vocab": json.dumps(em.vocab.to_json()),
            "categories": json.dumps(em.categories.to_json()), "config": json.dumps(em.model.config.to_json()),
            "training": json.dumps(em.meta.get("training", {}))}
    return save(tensors, metadata=meta)


def save_edge_model(em: EdgeModel, path: str | Path) -> Path:
    from grammarkit.run import write_files

    path = Path(path)
    write_files({path: edge_model_bytes(em)})
    em.path = path
    return path


def load_edge_model(path: str | Path, grammar: Any = None) -> EdgeModel:
    """Load an `.edges` file; with `grammar`, refuse one trained for another grammar."""
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    from grammarkit.run import grammar_hash

    from .predictor import CategoryLSTM, PredictorConfig

    path = Path(path)
    if not path.exists():
        raise ModelFileError(f"{path}: no such model file")
    if path.is_dir():
        raise ModelFileError(f"{path}: is a folder, not a model file")
    try:
        raw = _header(path, expect=EDGE_FORMAT)
    except ModelFileError:
        raise
    if raw.get("format_version") != str(EDGE_FORMAT_VERSION):
        raise ModelFileError(f"{path}: edge-category model version {raw.get('format_version')!r}; this grammarkit "
                             f"reads version {EDGE_FORMAT_VERSION} (train it again)")
    if grammar is not None and raw.get("grammar_hash") != grammar_hash(grammar):
        raise ModelFileError(f"{path}: this edge-category model was trained for grammar {raw.get('grammar')!r} "
                             f"(hash {raw.get('grammar_hash')}), not for {grammar.name!r} (hash {grammar_hash(grammar)})")
    try:
        vocab = Vocab.from_json(json.loads(raw["vocab"]))
        cats = EdgeCategories.from_json(json.loads(raw["categories"]))
        config = PredictorConfig(**json.loads(raw["config"]))
        training = json.loads(raw.get("training", "{}"))
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
                                          "training": training}, path)
