"""The `grammarkit` command. Each subcommand lives in its own module; plugins may add more.

User errors (`GrammarkitError`) are printed as `file:line:col: error: message` with the
source line and a caret, and the exit status is 1; no traceback is shown for them.
"""
from __future__ import annotations

import sys
from importlib import import_module

import click

from ..errors import GrammarkitError

# (module, command attribute) of the built-in subcommands; imported when the CLI starts.
BUILTIN_COMMANDS = [
    ("grammarkit.cli.lang", "check"),
    ("grammarkit.cli.lang", "fmt"),
    ("grammarkit.cli.lang", "plugins_command"),
    ("grammarkit.cli.derive", "derive"),
    ("grammarkit.cli.tiling", "learn"),
    ("grammarkit.cli.tiling", "validate"),
    ("grammarkit.cli.render", "render"),
    ("grammarkit.cli.train", "train"),
    ("grammarkit.cli.cga", "import_cga_command"),
    ("grammarkit.cli.batch", "batch"),
]


class GrammarkitGroup(click.Group):
    """Adds plugin commands lazily and turns user errors into diagnostics."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        self._add_plugin_commands()
        return super().list_commands(ctx)

    def get_command(self, ctx: click.Context, name: str):  # noqa: ANN201
        cmd = super().get_command(ctx, name)
        if cmd is None:
            self._add_plugin_commands()
            cmd = super().get_command(ctx, name)
        return cmd

    def _add_plugin_commands(self) -> None:
        if getattr(self, "_plugins_added", False):
            return
        self._plugins_added = True
        from ..plugins import get_plugin_manager

        for name, command in get_plugin_manager().cli_commands().items():
            if name not in self.commands:
                self.add_command(command, name)

    def invoke(self, ctx: click.Context):  # noqa: ANN201
        try:
            return super().invoke(ctx)
        except GrammarkitError as exc:
            report_error(exc)
            ctx.exit(1)


def report_error(exc: GrammarkitError) -> None:
    click.echo(exc.format(), err=True)


@click.group(cls=GrammarkitGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="grammarkit")
def main() -> None:
    """grammarkit: split grammars and tiling grammars for 3D shape modeling."""


for _module, _attr in BUILTIN_COMMANDS:
    try:
        main.add_command(getattr(import_module(_module), _attr))
    except (ImportError, AttributeError) as _exc:  # a half-installed tree should still run `--help`
        print(f"grammarkit: warning: command from {_module} unavailable: {_exc}", file=sys.stderr)
