"""The edge-category predictor (Kalojanov et al. 2019, section 6): an LSTM and a dense layer
that give every character of a shape string a category.

Targets per character, as in the paper: a part's letter gets the category of the edge to its
parent in the spanning tree (the child's placement in the parent's frame); each ring label (both
of its characters) gets the category of its cycle edge (the closer's placement in the opener's
frame); brackets and the root's letter get none (they are left out of the loss, the paper's
"dummy category"). The network is an embedding, a two-layer bidirectional LSTM and a dense
layer; its output is masked so that only the categories of the edge's type pair can be
predicted. `predict_graph` predicts on several strings of one graph and votes per edge (sum of
log-probabilities, opposite directions of a same-type pair mapped through `reverse`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Sequence

import numpy as np
import torch
from torch import nn

from .categories import EdgeCategories
from .graphs import TypedGraph
from .strings import decode, encode_with_order, tokenize
from .vocab import PAD, Vocab

__all__ = ["CategoryLSTM", "PredictorConfig", "encode_targets", "predict_graph"]

IGNORE = -100


@dataclass(frozen=True)
class PredictorConfig:
    vocab_size: int
    n_categories: int
    embed: int = 32
    hidden: int = 128
    layers: int = 2

    def to_json(self) -> dict:
        return asdict(self)


class CategoryLSTM(nn.Module):
    def __init__(self, config: PredictorConfig):
        super().__init__()
        self.config = config
        self.embed = nn.Embedding(config.vocab_size, config.embed, padding_idx=PAD)
        self.lstm = nn.LSTM(config.embed, config.hidden, num_layers=config.layers, batch_first=True,
                            bidirectional=True)
        self.dense = nn.Linear(2 * config.hidden, config.n_categories)

    def forward(self, tokens: torch.Tensor, allowed: torch.Tensor) -> torch.Tensor:
        """Masked logits (B, L, C): categories not valid for a character's type pair are -inf."""
        out, _ = self.lstm(self.embed(tokens))
        logits = self.dense(out)
        return logits.masked_fill(~allowed, float("-inf"))


def string_edges(text: str, vocab: Vocab) -> list[tuple[int, int] | None]:
    """Per token of `text`: the (first, second) parse nodes of its edge, or None."""
    parsed = decode(text, vocab.alphabet)
    toks = tokenize(parsed.text, vocab.alphabet)
    at = {t.index: k for k, t in enumerate(toks)}
    out: list[tuple[int, int] | None] = [None] * len(toks)
    for parent, child in parsed.tree_edges:
        out[at[parsed.node_index[child]]] = (parent, child)
    for (o, c), (i, j) in zip(parsed.ring_edges, parsed.ring_chars):
        out[at[i]] = (o, c)
        out[at[j]] = (o, c)
    return out


def encode_targets(graph: TypedGraph, text: str, order: Sequence[int], vocab: Vocab, cats: EdgeCategories,
                   labels: dict[tuple[int, int], int | None] | None) -> tuple[list[int], list[int], np.ndarray, list]:
    """Token ids, target category per token (IGNORE where none), allowed-category mask
    (tokens, C) and the graph edge (u, v) of each token (direction as written) or None."""
    ids = vocab.encode(text)
    edges = string_edges(text, vocab)
    C = len(cats)
    allowed = np.zeros((len(ids), C), dtype=bool)
    targets = [IGNORE] * len(ids)
    graph_edges: list = [None] * len(ids)
    for k, e in enumerate(edges):
        if e is None:
            allowed[k, :] = True  # no prediction is read here; keep the softmax finite
            continue
        u, v = order[e[0]], order[e[1]]
        graph_edges[k] = (u, v)
        cand = cats.pair_categories(graph.types[u], graph.types[v])
        if not cand:
            allowed[k, :] = True
            continue
        allowed[k, cand] = True
        if labels is not None:
            lab = labels.get((u, v))
            if lab is not None:
                targets[k] = lab
    return ids, targets, allowed, graph_edges


def _batch(rows: Sequence[tuple[list[int], list[int], np.ndarray]], C: int):
    L = max(len(r[0]) for r in rows)
    X = torch.full((len(rows), L), PAD, dtype=torch.long)
    Y = torch.full((len(rows), L), IGNORE, dtype=torch.long)
    A = torch.ones((len(rows), L, C), dtype=torch.bool)
    for i, (ids, tg, al) in enumerate(rows):
        X[i, :len(ids)] = torch.tensor(ids)
        Y[i, :len(tg)] = torch.tensor(tg)
        A[i, :len(ids)] = torch.from_numpy(al)
    return X, Y, A


@torch.no_grad()
def predict_graph(model: CategoryLSTM, graph: TypedGraph, vocab: Vocab, cats: EdgeCategories, *,
                  strings: int = 8, seed: int = 0) -> dict[tuple[int, int], tuple[int, np.ndarray]]:
    """Category of every edge (u, v), u < v, direction u -> v, voted over `strings` random
    strings of the graph: {(u, v): (category, summed log-probabilities over all categories)}.
    A string whose ring labels exceed the vocabulary is skipped."""
    rng = np.random.default_rng(seed)
    C = len(cats)
    rows, metas = [], []
    for _ in range(max(1, strings)):
        text, order = encode_with_order(graph, vocab.alphabet, rng=rng)
        try:
            ids, _, al, ge = encode_targets(graph, text, order, vocab, cats, None)
        except Exception:  # noqa: BLE001 - more ring labels than the model knows: skip this string
            continue
        rows.append((ids, [IGNORE] * len(ids), al))
        metas.append(ge)
    votes: dict[tuple[int, int], np.ndarray] = {}
    if not rows:
        return {}
    X, _, A = _batch(rows, C)
    logp = torch.log_softmax(model(X, A), dim=2).numpy()
    for i, ge in enumerate(metas):
        for k, e in enumerate(ge):
            if e is None:
                continue
            u, v = e
            lp = np.where(np.isfinite(logp[i, k]), logp[i, k], -np.inf)
            if u > v:  # seen from v: map each category to its reverse (same-type pairs)
                u, v = v, u
                flipped = np.full_like(lp, -np.inf)
                for c in range(C):
                    flipped[cats.reverse.get(c, c)] = max(flipped[cats.reverse.get(c, c)], lp[c])
                lp = flipped
            votes[(u, v)] = votes.get((u, v), 0) + np.where(np.isfinite(lp), lp, -1e9)
    return {e: (int(np.argmax(v)), v) for e, v in votes.items()}
