"""The edge-category predictor (Kalojanov et al. 2019, section 6): an LSTM and a dense layer
that give every character of a shape string a category.

Targets per character, as in the paper: a part's letter gets the category of the edge to its
parent in the spanning tree (the child's placement in the parent's frame); each ring label (both
of its characters) gets the category of its cycle edge (the closer's placement in the opener's
frame); brackets and the root's letter get none (they are left out of the loss, the paper's
"dummy category"). The network is an embedding, a two-layer LSTM and a dense layer; its output
is masked so that only the categories of the edge's type pair can be predicted.

Two versions are kept measurable side by side (`PredictorConfig`):

- **the paper's**: a unidirectional LSTM reading the string left to right (`bidirectional=False,
  features=0`), votes by majority of the per-string argmax (`voting="majority"`);
- **this one** (the default): a bidirectional LSTM (a part's category also depends on what comes
  after its letter: its ring-closure digits, its later branches); votes sum log-probabilities
  over strings (`voting="logprob"`). On request, the input per character is the letter's
  embedding plus *graph features* of the character's edge (`features > 0`): for both end parts,
  the number of neighbours of each part type at distance 1 and 2 in the decoded graph (the
  string determines these, but an LSTM has to carry them over up to a hundred characters), and
  `"joint"` voting decides each part's edges together (`assign_jointly`): a part cannot take two
  neighbours at one docking place, and only the neighbour configurations seen in the
  training data (per part type, the multiset of (neighbour type, category)) are allowed.
"""
from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass
from typing import Any, Sequence

import numpy as np
import torch
from torch import nn

from .categories import EdgeCategories
from .graphs import TypedGraph
from .strings import decode, encode_with_order, tokenize
from .vocab import PAD, Vocab

__all__ = ["CategoryLSTM", "PredictorConfig", "assign_jointly", "encode_targets", "graph_features", "predict_graph"]

IGNORE = -100


@dataclass(frozen=True)
class PredictorConfig:
    vocab_size: int
    n_categories: int
    embed: int = 32
    hidden: int = 128
    layers: int = 2
    bidirectional: bool = True  # False: the paper's left-to-right LSTM
    features: int = 0  # graph features per character (0: the paper's input, letters only)
    types: tuple[str, ...] = ()  # part types, in the order the features count them

    def to_json(self) -> dict:
        return asdict(self)


class CategoryLSTM(nn.Module):
    def __init__(self, config: PredictorConfig):
        super().__init__()
        self.config = config
        self.embed = nn.Embedding(config.vocab_size, config.embed, padding_idx=PAD)
        self.lstm = nn.LSTM(config.embed + config.features, config.hidden, num_layers=config.layers,
                            batch_first=True, bidirectional=config.bidirectional)
        self.dense = nn.Linear((2 if config.bidirectional else 1) * config.hidden, config.n_categories)

    def forward(self, tokens: torch.Tensor, allowed: torch.Tensor, feats: torch.Tensor | None = None) -> torch.Tensor:
        """Masked logits (B, L, C): categories not valid for a character's type pair are -inf."""
        x = self.embed(tokens)
        if self.config.features:
            x = torch.cat([x, feats if feats is not None else x.new_zeros(*x.shape[:2], self.config.features)], dim=2)
        out, _ = self.lstm(x)
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


def graph_features(graph: TypedGraph, types: Sequence[str]) -> np.ndarray:
    """(nodes, 2 * len(types)) per node: its neighbours of each type at distance 1, then the
    walks of length 2 ending at each type (scaled by 1/4 to keep the inputs near 1)."""
    index = {t: i for i, t in enumerate(types)}
    n, m = len(graph.types), len(types)
    onehot = np.zeros((n, m))
    for i, t in enumerate(graph.types):
        if t in index:
            onehot[i, index[t]] = 1.0
    A = np.zeros((n, n))
    for u, v in graph.edges:
        A[u, v] = A[v, u] = 1.0
    one = A @ onehot
    return np.concatenate([one, A @ one], axis=1) / 4.0


def encode_targets(graph: TypedGraph, text: str, order: Sequence[int], vocab: Vocab, cats: EdgeCategories,
                   labels: dict[tuple[int, int], int | None] | None, types: Sequence[str] = ()
                   ) -> tuple[list[int], list[int], np.ndarray, list, np.ndarray]:
    """Token ids, target category per token (IGNORE where none), allowed-category mask
    (tokens, C), the graph edge (u, v) of each token (direction as written) or None, and the
    graph features (tokens, 4 * len(types)): `graph_features` of the edge's two parts (zeros
    for tokens without an edge; no columns without `types`)."""
    ids = vocab.encode(text)
    edges = string_edges(text, vocab)
    C = len(cats)
    nf = graph_features(graph, types) if types else None
    feats = np.zeros((len(ids), 2 * nf.shape[1] if nf is not None else 0), dtype=np.float32)
    allowed = np.zeros((len(ids), C), dtype=bool)
    targets = [IGNORE] * len(ids)
    graph_edges: list = [None] * len(ids)
    for k, e in enumerate(edges):
        if e is None:
            allowed[k, :] = True  # no prediction is read here; keep the softmax finite
            continue
        u, v = order[e[0]], order[e[1]]
        graph_edges[k] = (u, v)
        if nf is not None:
            feats[k] = np.concatenate([nf[u], nf[v]])
        cand = cats.pair_categories(graph.types[u], graph.types[v])
        if not cand:
            allowed[k, :] = True
            continue
        allowed[k, cand] = True
        if labels is not None:
            lab = labels.get((u, v))
            if lab is not None:
                targets[k] = lab
    return ids, targets, allowed, graph_edges, feats


def _batch(rows: Sequence[tuple[list[int], list[int], np.ndarray, np.ndarray]], C: int):
    """Padded tensors of rows (ids, targets, allowed, features): X, Y, A, F."""
    L = max(len(r[0]) for r in rows)
    nf = rows[0][3].shape[1]
    X = torch.full((len(rows), L), PAD, dtype=torch.long)
    Y = torch.full((len(rows), L), IGNORE, dtype=torch.long)
    A = torch.ones((len(rows), L, C), dtype=torch.bool)
    F = torch.zeros((len(rows), L, nf), dtype=torch.float32)
    for i, (ids, tg, al, ft) in enumerate(rows):
        X[i, :len(ids)] = torch.tensor(ids)
        Y[i, :len(tg)] = torch.tensor(tg)
        A[i, :len(ids)] = torch.from_numpy(al)
        F[i, :len(ids)] = torch.from_numpy(ft)
    return X, Y, A, F


def flip(lp: np.ndarray, cats: EdgeCategories) -> np.ndarray:
    """Per-category scores of an edge seen from its other end (same-type pairs: `reverse`)."""
    out = np.full_like(lp, -1e9)
    for c in range(len(lp)):
        rc = cats.reverse.get(c, c)
        out[rc] = max(out[rc], lp[c])
    return out


def vote(per_string: Sequence[np.ndarray], voting: str) -> np.ndarray:
    """One edge's scores from its log-probabilities in several strings (masked entries -1e9):
    "logprob" sums them; "majority" (the paper's) counts each string's argmax, ties broken by
    the mean log-probability. Entries <= -1e8 stay impossible."""
    L = np.stack(per_string)
    total = L.sum(axis=0)
    if voting == "majority":
        counts = np.bincount(L.argmax(axis=1), minlength=L.shape[1]).astype(np.float64)
        total = np.where(total > -1e8, counts + 1e-3 * np.maximum(total / len(L), -900.0), -1e9)
    return np.where(total > -1e8, total, -1e9)


@torch.no_grad()
def predict_graph(model: CategoryLSTM, graph: TypedGraph, vocab: Vocab, cats: EdgeCategories, *,
                  strings: int = 8, seed: int = 0, voting: str = "logprob",
                  configurations: Any = None) -> dict[tuple[int, int], tuple[int, np.ndarray]]:
    """Category of every edge (u, v), u < v, direction u -> v, voted over `strings` random
    strings of the graph: {(u, v): (category, scores over all categories)}. `voting`:
    "majority" (the paper's), "logprob" or "joint" (logprob, then `assign_jointly` with the
    training data's `configurations`). A string whose ring labels exceed the vocabulary is
    skipped."""
    if voting not in ("majority", "logprob", "joint"):
        raise ValueError(f"unknown voting {voting!r}: majority, logprob or joint")
    rng = np.random.default_rng(seed)
    C = len(cats)
    types = model.config.types if model.config.features else ()
    rows, metas = [], []
    for _ in range(max(1, strings)):
        text, order = encode_with_order(graph, vocab.alphabet, rng=rng)
        try:
            ids, _, al, ge, ft = encode_targets(graph, text, order, vocab, cats, None, types)
        except Exception:  # noqa: BLE001 - more ring labels than the model knows: skip this string
            continue
        rows.append((ids, [IGNORE] * len(ids), al, ft))
        metas.append(ge)
    if not rows:
        return {}
    X, _, A, F = _batch(rows, C)
    logp = torch.log_softmax(model(X, A, F), dim=2).numpy()
    per_edge: dict[tuple[int, int], list[np.ndarray]] = {}
    for i, ge in enumerate(metas):
        for k, e in enumerate(ge):
            if e is None:
                continue
            u, v = e
            lp = np.where(np.isfinite(logp[i, k]), logp[i, k], -1e9)
            if u > v:  # seen from v: map each category to its reverse (same-type pairs)
                u, v = v, u
                lp = flip(lp, cats)
            per_edge.setdefault((u, v), []).append(lp)
    votes = {e: vote(v, "majority" if voting == "majority" else "logprob") for e, v in per_edge.items()}
    choice = {e: int(np.argmax(v)) for e, v in votes.items()}
    if voting == "joint" and configurations:
        choice = assign_jointly(graph, votes, cats, configurations)
    return {e: (choice[e], v) for e, v in votes.items()}


def node_configuration(graph: TypedGraph, adj: Sequence[Sequence[int]], x: int, cat_of: Any,
                       cats: EdgeCategories) -> tuple:
    """Part x's configuration: its type and the sorted (neighbour type, category seen from x)
    of its edges; `cat_of(u, v)` gives an edge's category u -> v for u < v."""
    out = []
    for y in adj[x]:
        c = cat_of(min(x, y), max(x, y))
        if c is not None and y < x:
            c = cats.reverse.get(c, c)
        out.append((graph.types[y], -1 if c is None else int(c)))
    return (graph.types[x], tuple(sorted(out)))


def assign_jointly(graph: TypedGraph, votes: dict[tuple[int, int], np.ndarray], cats: EdgeCategories,
                   configurations: Any, *, passes: int = 8, max_combinations: int = 729) -> dict[tuple[int, int], int]:
    """Categories for all edges that maximise the summed votes while every part's
    configuration is one seen in training (`configurations`: a set of `node_configuration`s).

    Iterated conditional modes over parts (a hand-written local search: the problem is a small
    weighted constraint problem per graph and no library in our dependencies solves those):
    starting from each edge's best category, each part in turn re-chooses the categories of all
    its edges together, scoring the votes minus a large penalty per part (itself and its
    neighbours) left in an unseen configuration; passes repeat until nothing changes. Parts
    with more than `max_combinations` choices keep their edges as they are. Deterministic."""
    adj = graph.adjacency()
    cur = {e: int(np.argmax(v)) for e, v in votes.items()}
    cat_of = lambda u, v: cur.get((u, v))  # noqa: E731
    seen = configurations

    def bad(x: int) -> int:
        return int(node_configuration(graph, adj, x, cat_of, cats) not in seen)

    penalty = 1e4
    for _ in range(passes):
        changed = False
        for x in range(len(graph.types)):
            es = [(min(x, y), max(x, y)) for y in adj[x] if (min(x, y), max(x, y)) in votes]
            doms = [[c for c in np.argsort(-votes[e], kind="stable") if votes[e][c] > -1e8] for e in es]
            if not es or any(not d for d in doms) or int(np.prod([len(d) for d in doms])) > max_combinations:
                continue
            around = [x] + list(adj[x])
            old = [cur[e] for e in es]
            best, best_combo = None, old
            for combo in itertools.product(*doms):
                for e, c in zip(es, combo):
                    cur[e] = int(c)
                score = sum(float(votes[e][c]) for e, c in zip(es, combo)) - penalty * sum(bad(z) for z in around)
                if best is None or score > best + 1e-9:
                    best, best_combo = score, [int(c) for c in combo]
            for e, c in zip(es, best_combo):
                cur[e] = c
            changed |= best_combo != old
        if not changed:
            break
    return cur
