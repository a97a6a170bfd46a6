"""`grammarkit derive`: grammar file -> model file, or a folder of results from a back end.

Everything goes through the run layer (`grammarkit.run`): the split engine is the built-in
`split` back end, tiling grammars go to the graph sampler (or `--backend NAME`). One model
(`-o paris.glb`) is written with its preview and tree as one transaction; several results
(`--variations N`, `-n N`, any tiling back end) go into a resumable folder with `run.json`
and `manifest.jsonl`. Outputs are checked against the inputs and each other before any work.
"""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Callable

import click

from ..errors import GrammarkitError

# Resource guards of the command line: one run writes at most MAX_MODELS files and starts at
# most MAX_WORKERS processes.
MAX_MODELS = 100_000
MAX_WORKERS = 64


def _pairs(values: tuple[str, ...], option: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in values:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", param_hint=option)
        out[key] = value.strip()
    return out


def progress_factory(console: Any) -> tuple[Any, Callable[..., Callable[..., None]]]:
    """A rich Progress and a `progress(description, total)` factory for back ends."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                        TimeElapsedColumn(), TextColumn("{task.fields[info]}"), console=console,
                        transient=False, disable=not console.is_terminal)

    def factory(description: str, total: int | None = None) -> Callable[..., None]:
        task = progress.add_task(description, total=total, info="")

        def advance(n: int = 1, **fields: Any) -> None:
            info = " ".join(f"{k}={v}" for k, v in fields.items())
            progress.update(task, advance=n, info=info)
        return advance
    return progress, factory


def _format_of(out: Path, fmt: str | None, formats: list[str]) -> str:
    if fmt:
        fmt = fmt.lower().lstrip(".")
        if fmt not in formats:
            raise click.BadParameter(f"unknown format {fmt!r}; known formats: {', '.join(formats)}",
                                     param_hint="--format")
        return fmt
    suffix = out.suffix.lower().lstrip(".")
    if suffix in formats:
        return suffix
    raise click.BadParameter(f"cannot tell the format of {out.name!r} from its suffix; "
                             f"use --format ({'|'.join(formats)})", param_hint="-o/--format")


def _check_image(path: Path, option: str) -> None:
    from PIL import Image

    if path.is_dir():
        raise click.BadParameter(f"{str(path)!r} is a folder; give a file name", param_hint=option)
    if Image.registered_extensions().get(path.suffix.lower()) is None:
        raise click.BadParameter(f"cannot tell the image format of {path.name!r} from its suffix; "
                                 "use .png (or .jpg, .webp, ...)", param_hint=option)


@click.command("derive")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(path_type=Path),
              help="model file (one split model), or folder (-n, --variations, tiling back ends)")
@click.option("--preview", type=click.Path(path_type=Path), default=None, is_flag=False,
              flag_value=Path("."), help="a PNG preview: a file for one model; for a folder of "
              "results, give the flag alone and each result gets <id>.png")
@click.option("--seed", type=int, default=0, show_default=True, help="run seed")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="set an attr of a split grammar (checked against its range/enum); repeatable")
@click.option("--format", "fmt", default=None, help="output format (default: from the -o suffix, "
              "or glb for folders); see `grammarkit plugins` for the exporters")
@click.option("--tree", type=click.Path(path_type=Path), default=None, is_flag=False,
              flag_value=Path("."), help="the derivation tree as JSON: a file for one model; for "
              "a folder, give the flag alone and each result gets <id>.tree.json")
@click.option("--variations", type=click.IntRange(min=1, max=MAX_MODELS), default=None,
              help="split grammar: N variations (attrs resampled, choices re-rolled) into the -o folder")
@click.option("--backend", default=None, help="back end (default: split for split grammars, "
              "graph-sampler for tiling grammars; see `grammarkit plugins`)")
@click.option("-n", "count", type=click.IntRange(min=1, max=MAX_MODELS), default=None,
              help="number of results (a folder); split grammars use seeds SEED..SEED+N-1")
@click.option("--iterations", type=click.IntRange(min=1), default=1, show_default=True,
              help="back-end iterations (sampler steps)")
@click.option("--workers", type=click.IntRange(min=1, max=MAX_WORKERS), default=None,
              help="worker processes at most (default: one per CPU; started only when they pay)")
@click.option("--option", "options", multiple=True, metavar="KEY=VALUE",
              help="back-end option (see `grammarkit plugins`); repeatable")
@click.option("--executor", "executor_spec", default="local", show_default=True,
              help="where parallel work runs: local, dask (a LocalCluster), or dask://HOST:PORT")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=None,
              help="hard stop: fail with an error after this many seconds")
@click.option("--time-limit", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS", help="graceful budget: make no new result after this many "
              "seconds, keep what was made and say what fell short")
@click.option("--overwrite", is_flag=True, help="folder output: discard an earlier run's results "
              "instead of continuing it")
@click.option("--json", "as_json", is_flag=True, help="print the run's summary as JSON on stdout "
              "(for scripts) instead of a few lines for people")
@click.option("--surfaces", type=click.Choice(["solid", "cga"]), default=None,
              help="split grammars: solid (default) makes one watertight solid per mass; cga "
              "keeps CityEngine's open faces (the split back end's option surfaces=)")
def derive(file: Path, out: Path, preview: Path | None, seed: int, sets: tuple[str, ...],
           fmt: str | None, tree: Path | None, variations: int | None, backend: str | None,
           count: int | None, iterations: int, workers: int | None, options: tuple[str, ...],
           executor_spec: str, timeout: float | None, time_limit: float | None, overwrite: bool,
           as_json: bool, surfaces: str | None) -> None:
    """Derive a model from the grammar FILE.

    \b
    grammarkit derive grammars/paris.grammar -o paris.glb --preview paris.png
    grammarkit derive grammars/paris.grammar -o out/ --variations 20 --preview
    grammarkit derive castle.grammar -o out/ -n 10 --backend graph-sampler
    """
    from rich.console import Console

    from .deadline import hard_deadline

    console = Console(stderr=True)
    limits = {"timeout": timeout, "time_limit": time_limit}
    if surfaces is not None:  # one spelling of the back-end option, checked with the others
        options = (*options, f"surfaces={surfaces}")
    with hard_deadline(timeout):
        _derive(file, out, preview, seed, sets, fmt, tree, variations, backend, count, iterations,
                workers, options, executor_spec, limits, overwrite, as_json, console)


def _derive(file: Path, out: Path, preview: Path | None, seed: int, sets: tuple[str, ...],
            fmt: str | None, tree: Path | None, variations: int | None, backend: str | None,
            count: int | None, iterations: int, workers: int | None, options: tuple[str, ...],
            executor_spec: str, limits: dict, overwrite: bool, as_json: bool, console: Any) -> None:
    from ..dsl import load
    from ..plugins import get_plugin_manager
    from ..run.api import resolve_backend

    registries = get_plugin_manager().registries()  # the edge: passed down from here
    grammar = load(file, registries=registries)
    spec = resolve_backend(grammar, backend, registries)
    option_values: dict[str, Any] = _pairs(options, "--option")
    attrs = _pairs(sets, "--set")
    if grammar.family == "split" and attrs:
        _check_set_names(grammar, file, attrs, registries)
    if grammar.family != "split":
        for given, name in ((sets, "--set"), (variations, "--variations")):
            if given:
                raise click.UsageError(f"{name} applies to split grammars; {file} is a "
                                       f"{grammar.family} grammar")
    if variations is not None:
        if count is not None:
            raise click.UsageError("give either --variations N or -n N, not both")
        if spec.name != "split":
            raise click.UsageError(f"--variations applies to the split back end, not {spec.name!r}")
        option_values["variations"] = "true"
        count = variations
    formats = sorted(registries.exporters)
    if count is None and spec.name == "split":
        _run_single(grammar, file, out, seed, attrs, _format_of(out, fmt, formats), preview, tree,
                    option_values, limits["timeout"], registries, console, as_json)
        return
    if tree is not None:
        if tree != Path(".") and tree.resolve() != out.resolve():
            raise click.UsageError("for a folder of results, give --tree alone: each result gets "
                                   "<id>.tree.json in the -o folder")
        if spec.name != "split":
            raise click.UsageError(f"--tree applies to split grammars; back end {spec.name!r} "
                                   "has no derivation tree")
        option_values["tree"] = "true"
    if preview is not None and preview != Path(".") and preview.resolve() != out.resolve():
        raise click.UsageError("for a folder of results, give --preview alone: each result gets "
                               "<id>.png in the -o folder")
    _run_folder(grammar, file, spec.name, out, count or 1, iterations, seed, attrs, option_values,
                fmt, preview is not None, workers, executor_spec, limits, overwrite, registries,
                as_json, console)


def _run_single(grammar: Any, file: Path, out: Path, seed: int, attrs: dict[str, str], fmt: str,
                preview: Path | None, tree: Path | None, options: dict[str, Any],
                timeout: float | None, registries: Any, console: Any, as_json: bool = False) -> None:
    from ..run.api import run_backend
    from ..run.writer import ModelFile

    if out.is_dir():
        raise click.BadParameter(f"{str(out)!r} is a folder; give a file name (or -n N for a folder "
                                 "of results)", param_hint="-o")
    if preview is not None:
        if preview == Path("."):
            raise click.UsageError("--preview needs a file name for one model, e.g. --preview out.png")
        _check_image(preview, "--preview")
    if tree is not None:
        if tree == Path("."):
            raise click.UsageError("--tree needs a file name for one model, e.g. --tree tree.json")
        if tree.is_dir():
            raise click.BadParameter(f"{str(tree)!r} is a folder; give a file name", param_hint="--tree")
    attachments = {"png": preview, "tree.json": tree}
    sink = ModelFile(out, {k: p for k, p in attachments.items() if p is not None}, protected=(file,))
    entries: list[dict] = []
    # the one run path (grammarkit.run.run_backend), as folders and batches take it
    run_backend(grammar, out=sink, backend="split", n=1, seed=seed, attrs=attrs,
                options={**options, **({"tree": "true"} if tree is not None else {})},
                workers=1, format=fmt, preview=preview is not None, timeout=timeout,
                inputs=(file,), registries=registries, on_result=entries.append)
    (entry,) = entries
    for w in entry.get("warnings", ()):
        click.echo(warning_text(w), err=True)
    for msg in entry.get("messages", ()):  # CGA's print() (split grammars), on stderr
        console.print(f"print: {msg}", highlight=False, markup=False)
    m = entry["metrics"]
    if as_json:  # for scripts: the files written and the model's numbers, one JSON document
        files = {"model": str(out), **{k: str(p) for k, p in attachments.items() if p is not None}}
        click.echo(json.dumps({"files": files, "format": fmt, "seed": seed, "metrics": m,
                               "warnings": list(entry.get("warnings", ()))}, indent=1, default=str))
        return
    click.echo(f"wrote {out} ({fmt}): {m['triangles']} triangles, {m['terminals']} terminals, "
               f"{m['shapes']} shapes" + (f"; preview {preview}" if preview else "")
               + (f"; tree {tree}" if tree else ""))


_LOCATED = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): (?P<msg>.*)$", re.S)


def warning_text(text: str) -> str:
    """A derivation warning ("file:line:col: message") in `grammarkit check`'s layout: the
    location, the source line and a caret under the name it is about."""
    from ..errors import Diagnostic
    from ..ir.base import Span

    m = _LOCATED.match(text)
    if m is None:
        return Diagnostic("warning", text).format()
    line, col = int(m["line"]), int(m["col"])
    shown = Diagnostic("warning", m["msg"], Span(file=m["file"], line=line, column=col,
                                                  end_line=line, end_column=col + 1)).format()
    source = shown.split("\n")[1][4:] if "\n" in shown else ""
    word = re.match(r"[\w.]+", source[col - 1:]) if source else None
    if word:  # underline the whole name, as check does
        shown = Diagnostic("warning", m["msg"], Span(file=m["file"], line=line, column=col,
                                                      end_line=line,
                                                      end_column=col + len(word[0]))).format()
    return shown


def _run_folder(grammar: Any, file: Path, backend: str, out: Path, n: int, iterations: int,
                seed: int, attrs: dict[str, str], options: dict[str, Any], fmt: str | None,
                preview: bool, workers: int | None, executor_spec: str, limits: dict,
                overwrite: bool, registries: Any, as_json: bool, console: Any) -> None:
    from ..run.api import run_backend
    from ..run.executor import make_executor

    progress, factory = progress_factory(console)
    written: list[str] = []
    # SIGTERM raises KeyboardInterrupt like Ctrl-C from the command's start (grammarkit.cli)
    executor = make_executor(executor_spec, workers)
    try:
        with progress:
            summary = run_backend(grammar, out=out, backend=backend, n=n, seed=seed,
                                  iterations=iterations, attrs=attrs, options=options,
                                  executor=executor, format=fmt, preview=preview, progress=factory,
                                  timeout=limits["timeout"], time_limit=limits["time_limit"],
                                  overwrite=overwrite, inputs=(file,),
                                  registries=registries, on_result=lambda e: written.append(e["id"]))
    except KeyboardInterrupt:
        click.echo(f"interrupted: {len(written)} new results written to {out}/ (manifest.jsonl lists "
                   "every complete one); run the same command again to continue", err=True)
        raise SystemExit(130) from None
    finally:
        executor.close()
    if summary.resumed:
        console.print(f"continued an earlier run: {summary.resumed} results were already in {out}/",
                      highlight=False)
    report_summary(summary, as_json)


def _check_set_names(grammar: Any, file: Path, attrs: dict[str, str], registries: Any) -> None:
    """A `--set` name the grammar has no attr of is a usage error that names the nearest attrs
    (the compiled grammar is cached: the run reuses it)."""
    import difflib

    from ..split import compile as compile_split

    compiled = compile_split(grammar, registries=registries)
    for name in attrs:
        if compiled.resolve_attr_keys(name):
            continue
        known = sorted(compiled.attrs)
        near = difflib.get_close_matches(name, known + sorted({k.split(".")[-1] for k in known}),
                                         n=3, cutoff=0.6)
        hint = ("; did you mean " + " or ".join(repr(n) for n in dict.fromkeys(near)) + "?") if near \
            else (f"; its attrs: {', '.join(known)}" if known else "; it has no attrs")
        raise click.BadParameter(f"{file} has no attr {name!r}{hint}", param_hint="--set")


def report_summary(summary: Any, as_json: bool) -> None:
    """What a folder run wrote and what fell short: a few lines on stdout for people, or the
    summary as one JSON document (`--json`) for scripts."""
    if as_json:
        click.echo(json.dumps(summary.to_dict(), indent=1, default=str))
        return
    for line in summary.lines():
        click.echo(line)


__all__ = ["derive", "progress_factory", "GrammarkitError"]
