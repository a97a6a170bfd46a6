"""The plugin author's contract: every hook grammarkit calls, with what it receives and returns.

A plugin is a module (or object) with functions decorated by `grammarkit.hookimpl` and named
like the specifications below. Register it with an entry point in group ``grammarkit``::

    [project.entry-points.grammarkit]
    my-plugin = "my_package.plugin"

grammarkit's own features (the split operations, the tiling constraints, the exporters,
the graph sampler) are registered exactly this way. Every hook is optional. Hooks are
called once, lazily, the first time the plugin manager needs that kind of thing; results
are cached for the process. A hook that raises is reported with the plugin's name and its
contribution is skipped; other plugins and unrelated commands keep working.
See docs/plugins.md for a complete example.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Iterable

import pluggy

if TYPE_CHECKING:  # pragma: no cover - types only
    import click

    from .registry import BackendSpec, ConstraintSpec, ExporterSpec, FitSpec, FunctionSpec, OperationSpec

PROJECT = "grammarkit"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def grammarkit_operations() -> Iterable["OperationSpec"]:
    """Split operations this plugin provides (e.g. `extrude`, `split`, `roofGable`).

    Return `OperationSpec`s. The checker validates calls against `params`/`block`; the split
    engine calls `apply(ctx, shape, args, block)`. A name provided twice is an error reported
    with both plugins' names; the first registered wins.
    """


@hookspec
def grammarkit_functions() -> Iterable["FunctionSpec"]:
    """Expression functions usable in grammar text (`rand(lo, hi)`, `min(a, b)`, ...)."""


@hookspec
def grammarkit_constraints() -> Iterable["ConstraintSpec"]:
    """Global constraints of tiling grammars (`constraint NAME(args)` in grammar text).

    `check(graph, args, context)` receives the shape graph (networkx, nodes with attribute
    `type`), the evaluated arguments as a dict, and a context with the assembly; it returns a
    list of human-readable violation messages, empty when the constraint holds.
    """


@hookspec
def grammarkit_backends() -> Iterable["BackendSpec"]:
    """Back ends for `grammarkit derive --backend NAME` and `grammarkit.run.run_backend`.

    Return `grammarkit.run.BackendSpec`s. A back end's `run(request)` is a generator that
    yields `grammarkit.run.Result`s and never writes files; its `options` is a pydantic model
    of its `--option key=value` settings. See grammarkit/run/backend.py and docs/plugins.md.
    """


@hookspec
def grammarkit_exporters() -> Iterable["ExporterSpec"]:
    """File formats models can be written in (`--format` / output suffix)."""


@hookspec
def grammarkit_cli_commands() -> Iterable["click.Command"]:
    """Extra `grammarkit` subcommands (click commands). Names must not clash with built-ins."""


@hookspec
def grammarkit_train_commands() -> Iterable["click.Command"]:
    """Subcommands of `grammarkit train` (click commands), one per trainable model kind, e.g.
    `grammarkit train string-vae DATASET -o model.vae`. Names must be unique across plugins."""


@hookspec
def grammarkit_insert_fits() -> Iterable["FitSpec"]:
    """Ways to fit an inserted asset into a scope, named in grammar text as
    `i("asset.glb", fit=NAME)`; see `grammarkit.registry.FitSpec`."""
