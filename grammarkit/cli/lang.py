"""`grammarkit check`, `grammarkit fmt` and `grammarkit plugins`: the language-facing commands."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import click

from ..errors import Diagnostic, GrammarError

_MAX_SIZE_HELP = "refuse grammar files larger than this many bytes (default: 512 KiB)"
MAX_SHOWN_DIAGNOSTICS = 200  # `check` prints the first ones in file order, then a count


def _read_input(path: Path, max_bytes: int) -> tuple[str, str]:
    """(text, name) of a grammar FILE, or of standard input for `-` (read up to the limit)."""
    from ..dsl.parser import decode_source, read_limited, read_source

    if str(path) == "-":
        stream = getattr(sys.stdin, "buffer", sys.stdin)
        return decode_source(read_limited(stream, max_bytes, "<stdin>"), "<stdin>"), "<stdin>"
    return read_source(path, max_bytes=max_bytes), str(path)


def _counts(diags: list[Diagnostic]) -> tuple[int, int]:
    errors = sum(1 for d in diags if d.severity == "error")
    warnings = sum(1 for d in diags if d.severity == "warning")
    return errors, warnings


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


@click.command("check")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False, allow_dash=True, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="print the diagnostics as JSON")
@click.option("--emit-ir", is_flag=True, help="print the IR of each file as JSON")
@click.option("--max-size", type=click.IntRange(min=1), default=None, help=_MAX_SIZE_HELP)
@click.option("--max-diagnostics", type=click.IntRange(min=1), default=MAX_SHOWN_DIAGNOSTICS,
              show_default=True, help="print at most this many diagnostics, then their count")
def check(files: tuple[Path, ...], as_json: bool, emit_ir: bool, max_size: int | None,
          max_diagnostics: int) -> None:
    """Report every problem in the grammar FILES (`-`: standard input; exit status 1 if there
    are errors)."""
    from ..dsl import DEFAULT_MAX_BYTES

    results = []
    total_errors = total_warnings = 0
    for path in files:
        limit = max_size or DEFAULT_MAX_BYTES
        if str(path) == "-":
            try:
                text, name = _read_input(path, limit)
            except GrammarError as exc:
                grammar, diags = None, list(exc.diagnostics)
            else:
                grammar, diags = _check_lazily(text, name, limit)
        else:
            grammar, diags = _check_lazily(path, None, limit)
        e, w = _counts(diags)
        total_errors += e
        total_warnings += w
        results.append((path, grammar, diags))

    if as_json:
        out = {
            "files": [
                {"file": str(path), "ok": not any(d.severity == "error" for d in diags),
                 "diagnostics": [d.to_json() for d in diags],
                 **({"ir": json.loads(g.model_dump_json()) if g is not None else None}
                    if emit_ir else {})}
                for path, g, diags in results
            ],
            "errors": total_errors,
            "warnings": total_warnings,
        }
        click.echo(json.dumps(out, indent=2))
    else:
        # With --emit-ir the IR goes to stdout and the diagnostics to stderr (pipe-friendly).
        diag_err = emit_ir
        shown = 0
        for path, g, diags in results:
            for d in diags:
                if shown >= max_diagnostics:
                    break
                click.echo(d.format(), err=diag_err)
                shown += 1
            if emit_ir and g is not None:
                click.echo(g.model_dump_json(indent=2))
        total = sum(len(diags) for _, _, diags in results)
        if total > shown:
            click.echo(f"... and {total - shown:,} more diagnostics (--max-diagnostics shows more)",
                       err=diag_err)
        summary = (f"{_plural(total_errors, 'error')}, {_plural(total_warnings, 'warning')} "
                   f"in {_plural(len(files), 'file')}")
        click.echo(summary, err=True)
    if total_errors:
        sys.exit(1)


def _check_lazily(source: Any, filename: str | None, limit: int) -> Any:
    """Check with grammarkit's own operations, functions and constraints first; load the
    third-party plugins only if the grammar names something those do not provide. So `check`
    of a grammar that needs no plugin never runs plugin code (issue 19)."""
    from ..dsl import check_text
    from ..plugins import NEEDS_PLUGINS, builtin_registries, third_party_plugins

    grammar, diags = check_text(source, filename=filename, max_bytes=limit,
                                registries=builtin_registries())
    if any(d.code in NEEDS_PLUGINS for d in diags) and third_party_plugins():
        grammar, diags = check_text(source, filename=filename, max_bytes=limit)
    return grammar, diags


def write_atomically(path: Path, text: str) -> None:
    """Write text to path atomically, keeping the file's permissions (see grammarkit.fileio)."""
    from ..fileio import atomic_output

    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")


@click.command("fmt")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False, allow_dash=True, path_type=Path))
@click.option("--in-place", "-i", is_flag=True, help="rewrite the files (atomically)")
@click.option("--check", "check_only", is_flag=True,
              help="do not write; exit 1 if a file is not in canonical form")
@click.option("--max-size", type=click.IntRange(min=1), default=None, help=_MAX_SIZE_HELP)
def fmt(files: tuple[Path, ...], in_place: bool, check_only: bool, max_size: int | None) -> None:
    """Print grammar FILES in canonical form (or rewrite them with --in-place); `-` reads
    standard input."""
    from ..dsl import DEFAULT_MAX_BYTES
    from ..printer import format_grammar

    failed = False
    changed = []
    for path in files:
        if str(path) == "-" and in_place:
            raise click.UsageError("--in-place cannot rewrite standard input")
        try:
            original, name = _read_input(path, max_size or DEFAULT_MAX_BYTES)
            text = format_grammar(original, filename=name)
        except GrammarError as exc:
            _report_unformattable(exc, path)
            failed = True
            continue
        if check_only:
            if text != original:
                changed.append(path)
                click.echo(f"would reformat {path}", err=True)
        elif in_place:
            if text != original:
                write_atomically(path, text)
                click.echo(f"reformatted {path}", err=True)
        else:
            click.echo(text, nl=False)
    if failed or (check_only and changed):
        sys.exit(1)


FMT_SHOWN_ERRORS = 10  # `fmt` of a file with many errors (often not a grammar at all): the first


def _report_unformattable(exc: GrammarError, path: Path) -> None:
    """Why `fmt` cannot format a file: its first errors in check's layout, then how many more
    there are and the command that lists them all."""
    diags = list(exc.diagnostics) or [None]
    if diags == [None] or len(diags) <= FMT_SHOWN_ERRORS:
        click.echo(exc.format(), err=True)
        return
    for d in diags[:FMT_SHOWN_ERRORS]:
        click.echo(d.format(), err=True)
    more = len(diags) - FMT_SHOWN_ERRORS
    hint = "" if str(path).endswith(".grammar") or str(path) == "-" else " (is it a grammar file?)"
    click.echo(f"{path}: {_plural(more, 'more error')} not shown{hint}; "
               f"`grammarkit check {path}` lists them all", err=True)


def _backend_options(manager: Any) -> dict[str, dict[str, list[dict]]]:
    """plugin -> back end -> its options ([{name, type, default, doc}]), for `plugins`."""
    from ..jsonable import to_jsonable
    from ..run import describe_options

    out: dict[str, dict[str, list[dict]]] = {}
    for spec in manager.backends().values():
        try:
            options = describe_options(spec.options)
        except Exception as exc:  # noqa: BLE001 - a malformed options model is the plugin's problem
            options = [{"name": "?", "type": "?", "default": None,
                        "doc": f"cannot describe the options: {type(exc).__name__}: {exc}"}]
        out.setdefault(spec.plugin, {})[spec.name] = to_jsonable(options)
    return out


@click.command("plugins")
@click.option("--json", "as_json", is_flag=True, help="print the plugin list as JSON")
def plugins_command(as_json: bool) -> None:
    """List every registered plugin: distribution, version, what it provides (with each back
    end's --option settings), and errors."""
    from ..plugins import get_plugin_manager

    manager = get_plugin_manager()
    infos = manager.plugins()
    options = _backend_options(manager)
    if as_json:
        click.echo(json.dumps([
            {"name": i.name, "distribution": i.distribution, "version": i.version,
             "module": i.module, "builtin": i.builtin, "status": i.status, "provides": i.provides,
             **({"backend_options": options[i.name]} if i.name in options else {}),
             "errors": i.errors, "ok": i.ok}
            for i in infos], indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title="grammarkit plugins", show_lines=False)
    table.add_column("plugin", style="bold")
    table.add_column("distribution")
    table.add_column("version")
    table.add_column("provides")
    table.add_column("status")
    for i in infos:
        lines = []
        for kind, names in sorted(i.provides.items()):
            lines.append(_escape(f"{kind}: {', '.join(names)}"))
            if kind == "backend":
                for backend, opts in options.get(i.name, {}).items():
                    for o in opts:
                        default = "" if o["default"] is None else f" = {o['default']}"
                        doc = f": {o['doc']}" if o["doc"] else ""
                        lines.append(_escape(f"  {backend} --option {o['name']} ({o['type']}{default}){doc}"))
        name = i.name + (" (built-in)" if i.builtin else "")
        if i.disabled:
            status = "disabled"
        else:
            status = "ok" if i.ok else "[red]" + "\n".join(_escape(e) for e in i.errors) + "[/red]"
        table.add_row(name, i.distribution or "-", i.version or "-", "\n".join(lines) or "-", status)
    Console(width=max(100, _terminal_width())).print(table)
    broken = [i.name for i in infos if not i.ok]
    if broken:
        click.echo(f"{_plural(len(broken), 'plugin')} with problems: {', '.join(broken)}", err=True)


def _escape(text: str) -> str:
    from rich.markup import escape
    return escape(text)


def _terminal_width() -> int:
    try:
        return os.get_terminal_size().columns
    except OSError:
        return 120
