"""The `grammarkit` command. Each subcommand lives in its own module; plugins may add more.

User errors (`GrammarkitError`) are printed as `file:line:col: error: message` with the
source line and a caret, and the exit status is 1; no traceback is shown for them.

Start-up is kept short: a subcommand's module is imported only when that command runs (or
`--help` lists it), `--version` imports nothing of grammarkit's, and plugins are loaded only
by commands that need what they provide (`fmt` and `--help` load none). Problems of plugins
that were loaded are printed as warnings on stderr when the command ends.
"""
from __future__ import annotations

import _thread
import os
import signal
import sys
import threading
from importlib import import_module
from typing import Any


# The import machinery's lock handling. A stop raised there can be lost or leave a lock held:
# the weakref callback that drops a finished import's module lock (`cb`) runs inside whatever
# code triggered the collection, its exceptions are discarded ("Exception ignored in ...
# _get_module_lock.<locals>.cb"), and it takes the global import lock before its `try`. Every
# lazy import of a running command passes through these, so a signal in the first second
# often landed there (issue 31: the run went on to exit 0). Elsewhere in an import a stop is
# raised at once, as Python always did (importlib unwinds it).
_IMPORT_LOCK_FRAMES = ("<frozen importlib._bootstrap>", frozenset({
    "cb", "_get_module_lock", "_lock_unlock_module", "acquire", "release", "has_deadlock",
    "__enter__", "__exit__"}))
_SIGNALS_SEEN: list[int] = []  # the stop signals this process received, in order


class _StopCourier:
    """Asks for a stop again a moment later, from a thread of its own: a handler cannot do it
    itself (Python would run it again at once, still in the frame it must leave). The handler
    only writes a byte to a pipe (no lock it could already hold); the thread then calls
    `_thread.interrupt_main`, which runs the handler in the main thread at a later bytecode."""

    def __init__(self) -> None:
        self._read, self._write = os.pipe()
        threading.Thread(target=self._serve, name="grammarkit-stop", daemon=True).start()

    def ask(self, signum: int) -> None:
        try:
            os.write(self._write, bytes([signum]))
        except OSError:  # pragma: no cover - the pipe is this process's own
            pass

    def _serve(self) -> None:
        import time

        while True:
            try:
                signum = os.read(self._read, 1)[0]
            except (OSError, IndexError):  # pragma: no cover - the pipe is this process's own
                return
            time.sleep(0.001)  # let the main thread run a little before asking again
            _thread.interrupt_main(signum)


_COURIER: list[_StopCourier] = []


def _stop(signum: int, frame: object) -> None:
    """SIGINT and SIGTERM raise KeyboardInterrupt, the current result completes or vanishes.
    Inside the import machinery's lock handling the stop is asked again a moment later."""
    _SIGNALS_SEEN.append(signum)
    code = getattr(frame, "f_code", None)
    in_lock = code is not None and code.co_filename == _IMPORT_LOCK_FRAMES[0] \
        and code.co_name in _IMPORT_LOCK_FRAMES[1]
    if _COURIER and (in_lock or _in_code_that_swallows_stops(frame)):
        _COURIER[0].ask(signum)
        return
    raise KeyboardInterrupt


# Libraries that catch BaseException, so that a KeyboardInterrupt raised while their code is on
# the stack is swallowed: trimesh wraps its optional imports (scipy, networkx, ...) in
# `except BaseException as E` and keeps E for later. A stop that landed in the lazy
# `import trimesh` of a running command was lost (exit 0) or resurfaced later, outside the
# command's handling (exit -2) (issue 31, seen on the first-second signal tests). While such
# code is running, the stop is asked again a moment later, until it has returned.
_SWALLOWING_PACKAGES = (f"{os.sep}trimesh{os.sep}",)


# A C extension module's initialization that calls back into Python (nanobind, which
# manifold3d is built with, creates its enums with `enum.Enum(...)`): a KeyboardInterrupt raised
# there becomes a C++ exception that nothing catches, and the process aborts (exit -6, issue
# 31: a batch stopped 0.6 s after its start, in the lazy `import manifold3d`). Inside one, the
# stop is asked again once the module exists.
_EXTENSION_INIT = ("<frozen importlib._bootstrap_external>", frozenset({
    "ExtensionFileLoader.create_module", "ExtensionFileLoader.exec_module"}))


def _in_code_that_swallows_stops(frame: Any) -> bool:
    while frame is not None:
        code = frame.f_code
        if any(p in code.co_filename for p in _SWALLOWING_PACKAGES) \
                or code.co_name == "__set_name__" \
                or (code.co_filename == _EXTENSION_INIT[0]
                    and getattr(code, "co_qualname", "") in _EXTENSION_INIT[1]):
            return True
        frame = frame.f_back
    return False


# Python 3.11 turns any exception leaving a `__set_name__` (run while a class is created) into
# `RuntimeError: Error calling __set_name__`: a stop that landed while a dataclass's fields were
# named, in a lazy import of a running command, ended it with a traceback and exit 1 (issue 31,
# caught by a traced handler under load). Inside one, the stop is asked again once it returned.


def _clear_interpreter_stop_flag() -> None:
    """CPython keeps one process-wide "unhandled KeyboardInterrupt" flag, set when a
    KeyboardInterrupt leaves code run by `exec`/`eval` of a *string* (dataclasses and namedtuple
    build their methods so, in every lazy import) and cleared only when the next string is
    evaluated. At exit a set flag replaces the exit status with death by SIGINT (-2), although
    the stop was handled and the command exits 130 (issue 31: the first-second signal tests'
    rare -2, with "interrupted" printed and no traceback). Evaluating a string that ends
    normally clears it."""
    exec("pass")  # noqa: S102 - a constant string, run for the flag it clears (above)


def _stop_again_if_swallowed(unraisable: Any) -> None:
    """sys.unraisablehook: a KeyboardInterrupt raised by `_stop` inside a finalizer or a
    weakref callback (whose exceptions Python discards) is asked for again instead of being
    lost; everything else goes to the previous hook."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and _SIGNALS_SEEN and _COURIER:
        _COURIER[0].ask(_SIGNALS_SEEN[-1])
        return
    _PREVIOUS_UNRAISABLE_HOOK[0](unraisable)


_PREVIOUS_UNRAISABLE_HOOK = [sys.unraisablehook]
_EARLY_SIGNALS: list[int] = []


def _remember(signum: int, frame: object) -> None:
    _EARLY_SIGNALS.append(signum)  # during start-up imports: obeyed when the command starts


def install_stop_signals() -> None:
    """Make SIGINT and SIGTERM stop a command cleanly from its first moment (issue 31: one in
    the first second was ignored and a batch ran on for minutes).

    Both raise KeyboardInterrupt, so every command unwinds through its `finally` blocks
    (results complete or vanish, locks are released), and never where Python would discard it
    (`_stop`, `_stop_again_if_swallowed`). SIGINT is handled even when it was inherited as
    ignored: a shell script starts its background jobs with SIGINT ignored, and `kill -INT`
    must still stop them. Installed as early as possible when this process is the `grammarkit`
    command (a program that merely imports this module keeps its own handlers), and again when
    the command starts; main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return
    if not _COURIER:
        _COURIER.append(_StopCourier())
    if sys.unraisablehook is not _stop_again_if_swallowed:
        _PREVIOUS_UNRAISABLE_HOOK[0] = sys.unraisablehook
        sys.unraisablehook = _stop_again_if_swallowed
    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)


def _is_the_command() -> bool:
    argv0 = sys.argv[0] if sys.argv else ""
    parts = argv0.replace("\\", "/").split("/")
    return parts[-1] in ("grammarkit", "grammarkit.exe") or parts[-2:] in (
        ["grammarkit", "__main__.py"], ["cli", "__main__.py"])


if _is_the_command() and threading.current_thread() is threading.main_thread():
    # before the imports below, which take a while on a busy machine: a stop asked for now is
    # remembered (raising in the middle of an import would print a traceback). SIGINT first:
    # once SIGTERM shows as caught in /proc (what tests wait for), both are.
    signal.signal(signal.SIGINT, _remember)
    signal.signal(signal.SIGTERM, _remember)

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
        try:
            return super().main(*args, **kwargs)
        finally:  # the command has ended: a stop it handled must not turn its exit into -2
            _clear_interpreter_stop_flag()

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

    def resolve_command(self, ctx: click.Context, args: list[str]) -> Any:
        """An unknown command name is a usage error that names the nearest commands
        (`No such command 'derve'. Did you mean 'derive'?`); plugin commands count too."""
        name = click.utils.make_str(args[0]) if args else ""
        if args and not name.startswith("-") and self.get_command(ctx, name) is None:
            import difflib

            known = sorted(set(self.list_commands(ctx)) | set(_plugin_command_names()))
            near = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
            hint = (" Did you mean " + " or ".join(repr(n) for n in near) + "?") if near else ""
            ctx.fail(f"No such command {name!r}.{hint} (`grammarkit --help` lists the commands)")
        return super().resolve_command(ctx, args)

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


def _plugin_command_names() -> list[str]:
    """Names of the installed plugins' commands (only asked for an unknown command name)."""
    from ..plugins import get_plugin_manager

    try:
        return list(get_plugin_manager().cli_commands())
    except Exception:  # noqa: BLE001 - a suggestion must never turn a usage error into a crash
        return []


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
