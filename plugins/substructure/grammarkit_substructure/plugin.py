"""The `substructure` back end and the `grammarkit substructures` command, registered through
the `grammarkit` entry-point group. Importing this module stays light (pydantic and click)."""
from __future__ import annotations

from typing import Iterator

from grammarkit import hookimpl
from grammarkit.run import BackendSpec, Request, Result

from .options import SubstructureOptions


def run(request: Request) -> Iterator[Result]:
    from .backend import run as run_backend

    return (yield from run_backend(request))


BACKEND = BackendSpec(
    name="substructure",
    summary="new assemblies by replacing substructures with observed boundaries (Liu 2015)",
    families=frozenset({"tiling"}),
    run=run,
    options=SubstructureOptions,
)


@hookimpl
def grammarkit_backends():
    return [BACKEND]


@hookimpl
def grammarkit_cli_commands():
    from .cli import substructures

    return [substructures]
