"""`grammarkit train KIND ...`: the trainers of learning back ends, contributed by plugins.

Each plugin that learns something (the string VAE, edge categories, the sketch recognizer)
returns a click command from the `grammarkit_train_commands` hook; it becomes
`grammarkit train <its name>`. Loading them is deferred until `train` itself runs.
"""
from __future__ import annotations

import click


class _TrainGroup(click.Group):
    def _load(self) -> None:
        if getattr(self, "_loaded", False):
            return
        self._loaded = True
        from ..plugins import get_plugin_manager

        for name, command in get_plugin_manager().train_commands().items():
            if name not in self.commands:
                self.add_command(command, name)

    def list_commands(self, ctx: click.Context) -> list[str]:
        self._load()
        return super().list_commands(ctx)

    def get_command(self, ctx: click.Context, name: str):  # noqa: ANN201
        self._load()
        return super().get_command(ctx, name)


@click.group("train", cls=_TrainGroup)
def train() -> None:
    """Train a learning back end's model (see `grammarkit train --help` for the kinds)."""
