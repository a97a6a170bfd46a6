"""The `grammarkit` command. Each subcommand lives in its own module; plugins may add more.

User errors (`GrammarkitError`) are printed as `file:line:col: error: message` with the
source line and a caret, and the exit status is 1; no traceback is shown for them.

Start-up is kept short: a subcommand's module is imported only when that command runs (or
`--help` lists it), `--version` imports nothing of grammarkit's, and plugins are loaded only
by commands that need what they provide (`fmt` and `--help` load none). Problems of plugins
that were loaded are printed as warnings on stderr when the command ends.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
from importlib import import_module


def _stop(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # SIGTERM stops like Ctrl-C: the current result completes or vanishes


_EARLY_SIGNALS: list[int] = []


def _remember(signum: int, frame: object) -> None:
    _EARLY_SIGNALS.append(signum)  # during start-up imports: obeyed when the command starts


def install_stop_signals() -> None:
    """Make SIGINT and SIGTERM stop a command cleanly from its first moment (issue 31: one in
    the first second was ignored and a batch ran on for minutes).

    SIGTERM raises KeyboardInterrupt like Ctrl-C, so every command unwinds through its
    `finally` blocks (results complete or vanish, locks are released). SIGINT gets Python's
    handler back even when it was inherited as ignored: a shell script starts its background
    jobs with SIGINT ignored, and `kill -INT` must still stop them. Installed as early as
    possible when this process is the `grammarkit` command (a program that merely imports this
    module keeps its own handlers), and again when the command starts; main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return
    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, signal.default_int_handler)


def _is_the_command() -> bool:
    argv0 = sys.argv[0] if sys.argv else ""
    parts = argv0.replace("\\", "/").split("/")
    return parts[-1] in ("grammarkit", "grammarkit.exe") or parts[-2:] in (
        ["grammarkit", "__main__.py"], ["cli", "__main__.py"])


if _is_the_command() and threading.current_thread() is threading.main_thread():
    # before the imports below, which take a while on a busy machine: a stop asked for now is
    # remembered (raising in the middle of an import would print a traceback)
    signal.signal(signal.SIGTERM, _remember)
    signal.signal(signal.SIGINT, _remember)

import click  # noqa: E402 - after the signal handlers, on purpose

from .. import __version__  # noqa: E402 - after the signal handlers, as click is
from ..errors import GrammarkitError  # noqa: E402 - after the signal handlers, as click is

# name -> (module, command attribute) of the built-in subcommands, imported on first use.
BUILTIN_COMMANDS: dict[str, tuple[str, str]] = {
    "check": ("grammarkit.cli.lang", "check"),
    "fmt": ("grammarkit.cli.lang", "fmt"),
    "plugins": ("grammarkit.cli.lang", "plugins_command"),
    "derive": ("grammarkit.cli.derive", "derive"),
    "learn": ("grammarkit.cli.tiling", "learn"),
    "validate": ("grammarkit.cli.tiling", "validate"),
    "render": ("grammarkit.cli.render", "render"),
    "train": ("grammarkit.cli.train", "train"),
    "import-cga": ("grammarkit.cli.cga", "import_cga_command"),
    "batch": ("grammarkit.cli.batch", "batch"),
}


class GrammarkitGroup(click.Group):
    """Built-in commands imported lazily, plugin commands found on demand, user errors turned
    into diagnostics, plugin problems reported."""

    def main(self, *args, **kwargs):  # noqa: ANN002, ANN003, ANN201 - click's signature
        install_stop_signals()
        if _EARLY_SIGNALS:
            click.echo("interrupted: stopped before anything was written", err=True)
            sys.exit(130)
        return super().main(*args, **kwargs)

    def list_commands(self, ctx: click.Context) -> list[str]:
        # plugin commands are not listed here: finding them means importing every plugin,
        # which `--help` must not do (`grammarkit plugins` lists them)
        return sorted(set(BUILTIN_COMMANDS) | set(self.commands))

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        cmd = super().get_command(ctx, name)
        if cmd is not None:
            return cmd
        if name in BUILTIN_COMMANDS:
            module, attr = BUILTIN_COMMANDS[name]
            try:
                cmd = getattr(import_module(module), attr)
            except (ImportError, AttributeError) as exc:  # a half-installed tree still runs --help
                click.echo(f"grammarkit: warning: command {name!r} unavailable: {exc}", err=True)
                return None
            self.add_command(cmd, name)
            return cmd
        return self._plugin_command(name)

    def _plugin_command(self, name: str) -> click.Command | None:
        from ..plugins import get_plugin_manager

        command = get_plugin_manager().cli_commands().get(name)
        if command is not None and name not in BUILTIN_COMMANDS:  # never shadow a built-in
            self.add_command(command, name)
            return command
        return None

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except GrammarkitError as exc:
            report_error(exc)
            ctx.exit(1)
        except KeyboardInterrupt:
            # a signal before a command began writing (the commands that write say themselves
            # what was written): nothing was changed
            click.echo("interrupted: stopped before anything was written", err=True)
            ctx.exit(130)
        except ImportError as exc:
            missing = missing_dependency(exc)
            if missing is None:
                raise
            click.echo(f"error: {missing}", err=True)
            ctx.exit(1)
        finally:
            report_plugin_problems()


# Importable module -> (distribution, extra of grammarkit that installs it, or None: a core
# dependency). A command that needs one that is missing names it instead of a traceback.
DEPENDENCIES: dict[str, tuple[str, str | None]] = {
    "trimesh": ("trimesh", None), "manifold3d": ("manifold3d", None), "scipy": ("scipy", None),
    "numpy": ("numpy", None), "networkx": ("networkx", None), "rtree": ("rtree", None),
    "PIL": ("Pillow", None), "lark": ("lark", None), "pydantic": ("pydantic", None),
    "torch": ("torch", "learning"), "safetensors": ("safetensors", "learning"),
    "dask": ("dask[distributed]", "dask"), "distributed": ("dask[distributed]", "dask"),
    "pyarrow": ("pyarrow", "parquet"), "shapefile": ("pyshp", "shapefile"),
    "rdkit": ("rdkit", "molecules"),
}


def missing_dependency(exc: ImportError) -> str | None:
    """The message for an ImportError of a known dependency (None: not one of them)."""
    name = (getattr(exc, "name", None) or "").split(".")[0]
    if name not in DEPENDENCIES:
        text = str(exc)  # a module that raises ImportError itself names it in the message
        name = next((m for m in DEPENDENCIES if m in text.split("'") or f" {m}" in text), "")
    if name not in DEPENDENCIES:
        return None
    dist, extra = DEPENDENCIES[name]
    how = (f"pip install 'grammarkit[{extra}]'" if extra else
           f"pip install '{dist}' (a dependency of grammarkit: the installation is incomplete)")
    return (f"this command needs the Python package {dist!r}, which cannot be imported "
            f"({type(exc).__name__}: {exc}); install it: {how}")


def report_error(exc: GrammarkitError) -> None:
    click.echo(exc.format(), err=True)


def report_plugin_problems() -> None:
    """Warn (stderr) about problems of the plugins this command loaded, once each."""
    from ..plugins import manager_if_loaded

    manager = manager_if_loaded()
    if manager is None:
        return
    for err in manager.new_errors():
        click.echo(f"grammarkit: warning: {err} (see `grammarkit plugins`)", err=True)


def _no_plugins(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    """`--no-plugins`: load the built-ins only; the environment variable carries the choice
    to worker processes too."""
    if not value:
        return
    from ..plugins import NO_PLUGINS_ENV, reset_plugin_manager

    os.environ[NO_PLUGINS_ENV] = "1"
    reset_plugin_manager()


@click.group(cls=GrammarkitGroup, context_settings={"help_option_names": ["-h", "--help"]},
             epilog="Plugins may add commands: `grammarkit plugins` lists them.")
@click.version_option(__version__, prog_name="grammarkit", message="%(prog)s, version %(version)s")
@click.option("--no-plugins", is_flag=True, is_eager=True, expose_value=False, callback=_no_plugins,
              help="load no third-party plugins (built-ins only; also GRAMMARKIT_NO_PLUGINS=1); "
                   "GRAMMARKIT_DISABLE_PLUGINS=name,... disables single ones")
def main() -> None:
    """grammarkit: split grammars and tiling grammars for 3D shape modeling."""
