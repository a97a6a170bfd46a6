"""Train a string VAE on a dataset and write its model file (what `grammarkit train string-vae` does)."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from grammarkit.errors import GrammarkitError

from .dataset import Dataset
from .train import TrainConfig, train_vae


def encode_strings(model, vocab, strings: list[str]):  # noqa: ANN001, ANN201
    """Posterior means of `strings` (N, latent), in batches."""
    import torch

    from .train import _tokens

    out = []
    with torch.no_grad():
        for i in range(0, len(strings), 512):
            x, lens = _tokens(vocab, strings[i:i + 512], model.config.max_len)
            mu, _ = model.encode(torch.from_numpy(x), torch.from_numpy(lens))
            out.append(mu)
    return torch.cat(out) if out else torch.zeros((0, model.config.latent))


def train_and_save(dataset: Dataset, config: TrainConfig, out: str | Path,
                   progress: Callable[[dict], None] | None = None) -> dict:
    """Train, then write `out` with the grammar hash, alphabet, rules, history and the
    training graphs (one string each, with its encoding). Returns a summary."""
    from .modelfile import save_vae

    out = Path(out)
    if out.exists() and out.is_dir():
        raise GrammarkitError(f"{out}: is a folder; give a model file name (e.g. castle.vae)")
    if dataset.path is not None and out.resolve() == Path(dataset.path).resolve():
        raise GrammarkitError(f"{out}: would overwrite the dataset")
    result = train_vae(dataset, config, progress=progress)
    train_strings = [dataset.strings[g][0] for g in result.train_graphs]
    mu = encode_strings(result.model, result.vocab, train_strings)
    training = {"config": config.to_json(), "history": result.history, "seconds": round(result.seconds, 1),
                "dataset": {"path": str(dataset.path) if dataset.path else None, "graphs": len(dataset),
                            "source": dataset.meta.get("source"), "seed": dataset.meta.get("seed")},
                "train_graphs": len(result.train_graphs), "val_graphs": len(result.val_graphs),
                "stopped": result.stopped}
    save_vae(out, model=result.model, vocab=result.vocab, rules=result.rules,
             grammar_name=str(dataset.meta["grammar"]), grammar_hash=dataset.grammar_hash,
             training=training, train_strings=train_strings, train_mu=mu)
    n_strings = sum(len(dataset.strings[g]) for g in result.train_graphs)
    return {"path": str(out), "train_graphs": len(result.train_graphs), "train_strings": n_strings,
            "epochs": len(result.history), "seconds": result.seconds, "last": result.history[-1],
            "stopped": result.stopped}
