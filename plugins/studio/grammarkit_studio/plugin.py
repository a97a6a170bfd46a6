"""The `studio` entry point: registers `grammarkit studio` (click only; the server stack is
imported when the command runs, so `grammarkit --help` stays light)."""
from __future__ import annotations

from pathlib import Path

import click

from grammarkit import hookimpl


@click.command("studio")
@click.argument("grammar", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--port", type=click.IntRange(1, 65535), default=None,
              help="port on 127.0.0.1 (default: a free one)")
@click.option("--open", "open_browser", is_flag=True, help="open the page in a browser")
@click.option("--budget", type=click.FloatRange(0.1, 3600), default=30.0, show_default=True,
              help="seconds one derive may take before its worker is stopped")
def studio(grammar: Path, port: int | None, open_browser: bool, budget: float) -> None:
    """Edit GRAMMAR in the browser: live 3D view, sliders, tree, export, gallery.

    Serves a local page on 127.0.0.1 only and prints its address, which holds a per-session
    token (see docs/studio.md for the security model)."""
    from grammarkit_studio import EXTRA_HINT, missing_extra

    missing = missing_extra()
    if missing is not None:
        raise click.ClickException(f"the studio needs the optional extra 'studio' ({missing} is not "
                                   f"installed): {EXTRA_HINT}")
    from grammarkit_studio.server import serve

    serve(grammar, port=port, open_browser=open_browser, budget=budget, echo=click.echo)


@hookimpl
def grammarkit_cli_commands() -> list[click.Command]:
    return [studio]
