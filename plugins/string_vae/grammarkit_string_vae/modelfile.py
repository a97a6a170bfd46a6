"""String-VAE model files (`.vae`): safetensors with everything needed to use the model.

The file is a safetensors file (a JSON header and raw tensors; reading it never runs code,
unlike a pickle). Its header metadata holds:

    format            "grammarkit-string-vae"
    format_version    "1"
    grammar, grammar_hash   the grammar it was trained for (grammarkit.run.grammar_hash)
    alphabet, vocab   letters of the part types, the token list
    config            network sizes and max_len
    rules             the grammar's topology rules (masks and validity checks)
    training          training settings and per-epoch history
    train_strings     one string per training graph (novelty, latent sampling)

and the tensors are the network's state dict plus `train_mu` (the posterior mean of each
training string above). Loading checks the format, the version, the alphabet against the
tensors, and (when a grammar is given) the grammar hash; a truncated file, a pickle or any
other file is refused with a message naming the file.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grammarkit.errors import GrammarkitError

from .strings import Alphabet
from .topology import TopologyRules
from .vocab import Vocab

__all__ = ["FORMAT", "FORMAT_VERSION", "LoadedVAE", "ModelFileError", "load_vae", "save_vae", "vae_bytes"]

FORMAT = "grammarkit-string-vae"
FORMAT_VERSION = 1


class ModelFileError(GrammarkitError):
    """A model file that cannot be used: not a model, damaged, another version or grammar."""


@dataclass
class LoadedVAE:
    model: Any  # StringVAE
    vocab: Vocab
    rules: TopologyRules
    meta: dict
    train_strings: list[str]
    train_mu: Any  # torch.Tensor (graphs, latent)
    path: Path | None = None

    @property
    def grammar_hash(self) -> str:
        return str(self.meta["grammar_hash"])

    @property
    def grammar_name(self) -> str:
        return str(self.meta.get("grammar", ""))

    @property
    def alphabet(self) -> Alphabet:
        return self.vocab.alphabet


def vae_bytes(model: Any, *, vocab: Vocab, rules: TopologyRules, grammar_name: str, grammar_hash: str,
              training: dict, train_strings: list[str], train_mu: Any) -> bytes:
    """The model file's bytes."""
    from safetensors.torch import save

    tensors = {f"model.{k}": v.detach().contiguous().clone() for k, v in model.state_dict().items()}
    tensors["train_mu"] = train_mu.detach().float().contiguous().clone()
    meta = {
        "format": FORMAT, "format_version": str(FORMAT_VERSION),
        "grammar": grammar_name, "grammar_hash": grammar_hash,
        "alphabet": json.dumps(vocab.alphabet.to_json()), "vocab": json.dumps(vocab.to_json()),
        "config": json.dumps(model.config.to_json()), "rules": json.dumps(rules.to_json()),
        "training": json.dumps(training), "train_strings": json.dumps(train_strings),
    }
    return save(tensors, metadata=meta)


def save_vae(path: str | Path, **kwargs: Any) -> Path:
    """Write a model file atomically (see `vae_bytes` for the arguments)."""
    from grammarkit.run import write_files

    path = Path(path)
    write_files({path: vae_bytes(**kwargs)})
    return path


_KIND = {FORMAT: "string-VAE model", "grammarkit-edge-categories": "edge-category model"}


def _header(path: Path, expect: str = FORMAT) -> dict:
    """The metadata of a safetensors file of format `expect`, read without torch; refuses
    anything else (pickles included: nothing in them is ever run)."""
    what = f"grammarkit {_KIND.get(expect, expect)} file"
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(8)
            if len(head) < 8:
                raise ModelFileError(f"{path}: not a {what} (too short: "
                                     f"{size} bytes)")
            n = int.from_bytes(head, "little")
            if n <= 0 or n > min(size - 8, 100_000_000):
                raise ModelFileError(f"{path}: not a {what} (no safetensors "
                                     "header; pickles and other files are refused: they could run code)")
            text = fh.read(n)
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        header = json.loads(text.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise ModelFileError(f"{path}: not a {what} (its header is not "
                             "safetensors JSON)") from None
    if not isinstance(header, dict):
        raise ModelFileError(f"{path}: not a {what}")
    end = max((int(v["data_offsets"][1]) for k, v in header.items()
               if k != "__metadata__" and isinstance(v, dict) and "data_offsets" in v), default=0)
    if 8 + n + end > size:
        raise ModelFileError(f"{path}: the model file is truncated ({size} of {8 + n + end} bytes); "
                             "copy or train it again")
    meta = header.get("__metadata__") or {}
    if meta.get("format") != expect:
        raise ModelFileError(f"{path}: not a {what} (format {meta.get('format')!r})")
    return meta


WEIGHTS = Path(__file__).resolve().parent / "weights"


def resolve(path: str | Path, suffix: str = ".vae") -> Path:
    """A model path; `builtin:NAME` names a file shipped in the package's weights folder, of the
    kind `suffix` says (`builtin:castle` -> weights/castle.vae, made by
    scripts/train_castle_weights.py; for edge-category models weights/castle.edges, made by
    scripts/train_castle_edges.py)."""
    text = str(path)
    if text.startswith("builtin:"):
        name = text[len("builtin:"):]
        found = WEIGHTS / f"{name}{suffix}"
        if not name or "/" in name or not found.is_file():
            shipped = ", ".join(sorted(p.stem for p in WEIGHTS.glob(f"*{suffix}"))) or "none"
            raise ModelFileError(f"{text}: no shipped {suffix} model of that name (shipped: {shipped})")
        return found
    return Path(path)


def read_meta(path: str | Path) -> dict:
    """The model file's metadata (decoded JSON fields), without loading tensors or torch."""
    path = resolve(path)
    if not path.exists():
        raise ModelFileError(f"{path}: no such model file")
    if path.is_dir():
        raise ModelFileError(f"{path}: is a folder, not a model file")
    meta = _header(path)
    version = meta.get("format_version")
    if version != str(FORMAT_VERSION):
        raise ModelFileError(f"{path}: model format version {version!r}; this grammarkit reads version "
                             f"{FORMAT_VERSION} (train the model again)")
    out: dict = {}
    try:
        for k, v in meta.items():
            out[k] = json.loads(v) if k in ("alphabet", "vocab", "config", "rules", "training",
                                             "train_strings") else v
    except ValueError as exc:
        raise ModelFileError(f"{path}: damaged metadata ({exc})") from None
    return out


def check_grammar(meta: dict, grammar: Any, path: Path | str) -> None:
    """Refuse a model trained for another grammar (by hash) or another alphabet."""
    from grammarkit.run import grammar_hash

    h = grammar_hash(grammar)
    if meta.get("grammar_hash") != h:
        raise ModelFileError(f"{path}: this model was trained for grammar {meta.get('grammar')!r} (hash "
                             f"{meta.get('grammar_hash')}), not for {grammar.name!r} (hash {h}); train a "
                             "model on a dataset of this grammar")
    rules = TopologyRules.from_grammar(grammar)
    alphabet = Alphabet.from_json(meta["alphabet"])
    if sorted(alphabet.types) != sorted(rules.types):
        raise ModelFileError(f"{path}: the model's part types ({', '.join(alphabet.types)}) differ from "
                             f"the grammar's ({', '.join(rules.types)})")


def load_vae(path: str | Path, grammar: Any = None) -> LoadedVAE:
    """Load a model file; with `grammar`, refuse a model trained for another grammar."""
    import torch
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    from .model import ModelConfig, StringVAE

    path = resolve(path)
    meta = read_meta(path)
    if grammar is not None:
        check_grammar(meta, grammar, path)
    try:
        vocab = Vocab.from_json(meta["vocab"])
        if vocab.alphabet != Alphabet.from_json(meta["alphabet"]):
            raise ModelFileError(f"{path}: the model's alphabet and vocabulary disagree")
        cfg = dict(meta["config"])
        cfg["conv"] = tuple(cfg["conv"])
        config = ModelConfig(**cfg)
        rules = TopologyRules.from_json(meta["rules"])
        train_strings = [str(s) for s in meta["train_strings"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: damaged metadata ({type(exc).__name__}: {exc})") from None
    if config.vocab_size != len(vocab):
        raise ModelFileError(f"{path}: the network has {config.vocab_size} tokens but the vocabulary "
                             f"{len(vocab)}")
    try:
        tensors = load_file(str(path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise ModelFileError(f"{path}: damaged model file ({exc})") from None
    model = StringVAE(config)
    state = {k[len("model."):]: v for k, v in tensors.items() if k.startswith("model.")}
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).splitlines()[0]
        raise ModelFileError(f"{path}: the tensors do not fit the network described in the file ({first})") from None
    model.eval()
    # the length 90% of the training strings stay within: masked decoding closes from there on
    lengths = sorted(len(vocab.encode(t)) + 1 for t in train_strings) if train_strings else []
    model.soft_end = lengths[int(0.9 * (len(lengths) - 1))] if lengths else None
    mu = tensors.get("train_mu")
    if mu is None or mu.ndim != 2 or mu.shape[1] != config.latent or mu.shape[0] != len(train_strings):
        raise ModelFileError(f"{path}: the training-set encodings are missing or do not match")
    return LoadedVAE(model, vocab, rules, meta, train_strings, mu.to(torch.float32), path)
