"""Training the string VAE on a dataset folder (CPU).

Loss per string: cross-entropy of every token (EOS included) with teacher forcing, plus
beta * KL(q(z|x) || N(0, I)). beta grows linearly from 0 to `beta` over the first
`kl_warmup` of the epochs (KL warm-up, Bowman et al. 2016); decoder inputs are replaced by UNK
with probability `word_dropout`, so the decoder has to use z. Graphs (not strings) are split
into training and validation sets, so validation strings describe unseen graphs. After each
epoch the progress line shows loss, KL, validation reconstruction accuracy and the validity of
strings freely decoded from prior samples (the paper's decoding).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from grammarkit.errors import GrammarkitError

from .dataset import Dataset
from .topology import TopologyRules
from .vocab import BOS, EOS, PAD, UNK, Vocab

__all__ = ["TrainConfig", "TrainResult", "train_vae", "MIN_GRAPHS"]

# Fewer graphs than this cannot be split into training and validation graphs usefully.
MIN_GRAPHS = 8


@dataclass(frozen=True)
class TrainConfig:
    epochs: int = 50
    batch_size: int = 128
    lr: float = 2e-3
    latent: int = 56
    hidden: int = 192
    enc_hidden: int = 192
    embed: int = 32
    conv: tuple[int, int, int] = (64, 64, 96)
    beta: float = 0.2
    kl_warmup: float = 0.5  # fraction of the epochs over which beta grows from 0
    word_dropout: float = 0.25
    val_fraction: float = 0.05
    seed: int = 0
    threads: int = 1
    time_limit: float | None = None  # seconds; stops after the epoch that passes it
    stop_after: int | None = None  # stop after this many epochs (the schedules still span `epochs`)
    monitor_samples: int = 64  # prior samples decoded per epoch for the validity column
    strings_per_epoch: int | None = None  # strings of each graph per epoch, drawn anew (None: all)

    def to_json(self) -> dict:
        out = dict(self.__dict__)
        out["conv"] = list(self.conv)
        return out


@dataclass
class TrainResult:
    model: Any
    vocab: Vocab
    rules: TopologyRules
    history: list[dict] = field(default_factory=list)
    train_graphs: list[int] = field(default_factory=list)
    val_graphs: list[int] = field(default_factory=list)
    seconds: float = 0.0
    stopped: str | None = None


def _tokens(vocab: Vocab, strings: list[str], max_len: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, max_len) token ids ending with EOS and PAD-filled; lengths incl. EOS."""
    arr = np.full((len(strings), max_len), PAD, dtype=np.int64)
    lengths = np.zeros(len(strings), dtype=np.int64)
    for i, s in enumerate(strings):
        ids = vocab.encode(s) + [EOS]
        arr[i, :len(ids)] = ids
        lengths[i] = len(ids)
    return arr, lengths


# long: the training loop with its schedules (KL warm-up, word dropout, time limit) and
# long: per-epoch monitoring, which share the model, optimiser and history
def train_vae(dataset: Dataset, config: TrainConfig = TrainConfig(), *,
              progress: Callable[[dict], None] | None = None) -> TrainResult:
    """Train a StringVAE on `dataset`; `progress(row)` is called after every epoch."""
    import torch

    from .model import ModelConfig, StringVAE

    n_graphs = len(dataset.graphs)
    n_strings = sum(len(s) for s in dataset.strings)
    where = dataset.path or "the dataset"
    if n_graphs == 0 or n_strings == 0:
        raise GrammarkitError(f"{where}: the dataset is empty (no graphs or no strings); build one "
                              "with `grammarkit dataset GRAMMAR -o FOLDER`")
    if n_graphs < MIN_GRAPHS:
        raise GrammarkitError(f"{where}: {n_graphs} graph(s) are too few to train on (at least "
                              f"{MIN_GRAPHS} are needed: some are held out for validation); make more "
                              "with `grammarkit dataset ... -n N`")
    if config.epochs < 1:
        raise GrammarkitError("epochs must be at least 1")
    torch.manual_seed(config.seed)
    torch.set_num_threads(max(1, int(config.threads)))
    rng = np.random.default_rng(config.seed)
    rules = TopologyRules.from_json(dataset.meta["rules"])
    vocab = Vocab(dataset.alphabet, max(1, int(dataset.meta.get("max_ring_label", 1))))
    max_len = int(dataset.meta["max_tokens"]) + 1
    order = rng.permutation(n_graphs)
    n_val = max(1, int(round(config.val_fraction * n_graphs)))
    val_g, train_g = sorted(order[:n_val].tolist()), sorted(order[n_val:].tolist())

    def strings_of(idx: list[int]) -> tuple[list[str], list[int]]:
        out, owner = [], []
        for g in idx:
            out += dataset.strings[g]
            owner += [g] * len(dataset.strings[g])
        return out, owner

    tr_strings, tr_owner = strings_of(train_g)
    tr_x, tr_len = _tokens(vocab, tr_strings, max_len)
    va_x, va_len = _tokens(vocab, strings_of(val_g)[0], max_len)
    by_graph: dict[int, list[int]] = {}
    for i, g in enumerate(tr_owner):
        by_graph.setdefault(g, []).append(i)
    mcfg = ModelConfig(vocab_size=len(vocab), max_len=max_len, embed=config.embed, conv=tuple(config.conv),
                       enc_hidden=config.enc_hidden, hidden=config.hidden, latent=config.latent)
    model = StringVAE(mcfg)
    opt = torch.optim.Adam(model.parameters(), lr=config.lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=config.epochs, eta_min=config.lr * 0.1)
    X = torch.from_numpy(tr_x)
    L = torch.from_numpy(tr_len)
    history: list[dict] = []
    t0 = time.perf_counter()
    stopped = None
    warm = max(1, int(math.ceil(config.kl_warmup * config.epochs)))
    per_epoch = len(X) if not config.strings_per_epoch else \
        sum(min(config.strings_per_epoch, len(v)) for v in by_graph.values())
    steps_per_epoch = max(1, math.ceil(per_epoch / config.batch_size))
    step = 0
    for epoch in range(1, config.epochs + 1):
        model.train()
        if config.strings_per_epoch:
            # every graph once per epoch through a few of its strings, drawn anew each epoch
            pick = [i for g in sorted(by_graph) for i in
                    rng.permutation(by_graph[g])[:config.strings_per_epoch].tolist()]
            perm = torch.from_numpy(rng.permutation(np.array(pick, dtype=np.int64)))
        else:
            perm = torch.from_numpy(rng.permutation(len(X)))
        tot_rec = tot_kl = 0.0
        count = 0
        for b in range(steps_per_epoch):
            idx = perm[b * config.batch_size:(b + 1) * config.batch_size]
            x, lens = X[idx], L[idx]
            width = int(lens.max())
            x = x[:, :width]
            beta = config.beta * min(1.0, step / (warm * steps_per_epoch))
            step += 1
            mu, logvar = model.encode(x, lens)
            z = mu + torch.randn_like(mu) * torch.exp(0.5 * logvar)
            inp = torch.cat([torch.full((x.shape[0], 1), BOS, dtype=torch.long), x[:, :-1]], dim=1)
            if config.word_dropout > 0:
                drop = (torch.rand(inp.shape) < config.word_dropout) & (inp != PAD)
                drop[:, 0] = False
                inp = inp.masked_fill(drop, UNK)
            logits = model.decode_teacher(z, inp)
            rec = torch.nn.functional.cross_entropy(logits.reshape(-1, logits.shape[-1]), x.reshape(-1),
                                                    ignore_index=PAD, reduction="sum") / x.shape[0]
            kl = (-0.5 * (1 + logvar - mu.pow(2) - logvar.exp()).sum(dim=1)).mean()
            loss = rec + beta * kl
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 5.0)
            opt.step()
            tot_rec += float(rec.detach()) * x.shape[0]
            tot_kl += float(kl.detach()) * x.shape[0]
            count += x.shape[0]
        sched.step()
        row = {"epoch": epoch, "loss": tot_rec / count + beta * tot_kl / count, "recon": tot_rec / count,
               "kl": tot_kl / count, "beta": round(beta, 4)}
        row.update(_evaluate(model, vocab, rules, va_x, va_len, config, epoch))
        row["seconds"] = round(time.perf_counter() - t0, 1)
        history.append(row)
        if progress is not None:
            progress(row)
        if config.time_limit is not None and time.perf_counter() - t0 > config.time_limit and epoch < config.epochs:
            stopped = f"time limit of {config.time_limit:g} s reached after epoch {epoch} of {config.epochs}"
            break
        if config.stop_after is not None and epoch >= config.stop_after and epoch < config.epochs:
            stopped = f"stopped after epoch {epoch} of {config.epochs} (stop_after)"
            break
    model.eval()
    return TrainResult(model, vocab, rules, history, train_g, val_g, time.perf_counter() - t0, stopped)


def _evaluate(model, vocab: Vocab, rules: TopologyRules, va_x: np.ndarray, va_len: np.ndarray,
              config: TrainConfig, epoch: int) -> dict:
    """Validation reconstruction (teacher-forced token accuracy, whole-string greedy
    reconstruction from the posterior mean) and free-decoding validity of prior samples."""
    import torch

    from .decoding import decode_latents

    model.eval()
    with torch.no_grad():
        x = torch.from_numpy(va_x[:512])
        lens = torch.from_numpy(va_len[:512])
        mu, _ = model.encode(x, lens)
        inp = torch.cat([torch.full((x.shape[0], 1), BOS, dtype=torch.long), x[:, :-1]], dim=1)
        pred = model.decode_teacher(mu, inp).argmax(dim=2)
        mask = x != PAD
        acc = float(((pred == x) & mask).sum()) / float(mask.sum())
        k = min(64, x.shape[0])
        rec = decode_latents(model, mu[:k], vocab=vocab, rules=rules, mode="free")
        truth = [vocab.decode(row.tolist()) for row in x[:k]]
        exact = sum(r.text == t for r, t in zip(rec, truth)) / max(1, k)
        g = torch.Generator().manual_seed(config.seed * 1000 + epoch)
        zs = torch.randn(config.monitor_samples, model.config.latent, generator=g)
        free = decode_latents(model, zs, vocab=vocab, rules=rules, mode="free", seed=epoch)
    model.train()
    return {"val_token_acc": round(acc, 4), "val_recon": round(exact, 4),
            "validity": round(sum(d.valid for d in free) / max(1, len(free)), 4)}
