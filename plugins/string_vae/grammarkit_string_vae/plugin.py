"""The `string-vae` back end and the shape-string commands, registered through the `grammarkit`
entry-point group (see docs/string-vae.md).

- back end `string-vae`: `grammarkit derive castle.grammar --backend string-vae --option
  model=castle.vae -n 200 --option mode=perturb` yields new valid shape graphs sampled from a
  trained string VAE (strings and graphs in the manifest);
- `grammarkit strings`: the shape strings of a model, or a string decoded and checked;
- `grammarkit dataset`: a training set of graphs and strings from a back end's output;
- `grammarkit train string-vae`: train the sequence VAE (needs the `learning` extra: torch);
- `grammarkit vae-metrics`: validity, uniqueness, novelty, diversity, sampling yields and the
  latent-graph statistics of a trained model.

Importing this module stays light (click, pydantic): torch loads only when a model is used.
"""
from __future__ import annotations

from typing import Iterator

from grammarkit import hookimpl
from grammarkit.run import BackendSpec, Request, Result

from .options import StringVAEOptions


def run(request: Request) -> Iterator[Result]:
    """Yield new valid shape graphs sampled from the model's latent space."""
    from .generate import generate

    stats = yield from generate(request)
    return stats


BACKEND = BackendSpec(
    name="string-vae",
    summary="new valid shape graphs sampled from a string VAE's latent space, grammar-masked "
            "decoding (Kalojanov 2019, s. 5)",
    families=frozenset({"tiling"}),
    run=run,
    options=StringVAEOptions,
    model_format="glb",
)


@hookimpl
def grammarkit_backends():
    return [BACKEND]


@hookimpl
def grammarkit_cli_commands():
    from .cli import (compress_command, dataset_command, decompress_command, instantiate_command, strings_command,
                      vae_metrics_command)

    return [strings_command, dataset_command, vae_metrics_command, instantiate_command, compress_command,
            decompress_command]


@hookimpl
def grammarkit_train_commands():
    from .cli import train_edge_categories, train_string_vae

    return [train_string_vae, train_edge_categories]
