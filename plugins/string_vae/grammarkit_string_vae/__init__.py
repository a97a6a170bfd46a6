"""grammarkit string VAE: shape strings, a sequence VAE over them with grammar-masked decoding,
latent sampling and metrics (Kalojanov et al. 2019, section 5). See docs/string-vae.md.

Python API (light: no torch)::

    from grammarkit_string_vae import Alphabet, TypedGraph, decode, encode, strings_of, TopologyRules

With the `learning` extra (torch)::

    from grammarkit_string_vae import build_dataset, train_vae, load_vae, Sampler, vae_metrics
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "Alphabet": "strings", "ShapeStringError": "strings", "decode": "strings", "encode": "strings",
    "strings_of": "strings", "convert": "strings",
    "TypedGraph": "graphs", "GraphSet": "graphs", "histogram_distance": "graphs",
    "TopologyRules": "topology",
    "Automaton": "masked", "complete": "masked",
    "Vocab": "vocab",
    "Dataset": "dataset", "build_dataset": "dataset", "load_dataset": "dataset", "write_dataset": "dataset",
    "TrainConfig": "train", "train_vae": "train",
    "load_vae": "modelfile", "save_vae": "modelfile", "ModelFileError": "modelfile",
    "decode_latents": "decoding",
    "Sampler": "sampling", "SamplingSettings": "sampling",
    "vae_metrics": "metrics", "generator_metrics": "metrics",
    "build_latent_graph": "latent_graph", "path_statistics": "latent_graph",
    "StringVAEOptions": "options",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    # Imported on first use: the plugin manager imports `.plugin` (and so this package) for
    # every `grammarkit` command, which must not pay for torch or networkx.
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
