"""`grammarkit batch`: a building per lot, or a dataset of variations, on local processes or Dask.

Everything goes through `grammarkit.run.batch.run_batch` (the Python API); this module parses
options, shows progress (rich, on stderr, only on a terminal) and reports the outcome.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ..errors import GrammarkitError
from .derive import report_summary

MAX_VARIATIONS = 1_000_000
MAX_WORKERS = 256  # processes of a local cluster; a remote cluster has its own size


def _pairs(values: tuple[str, ...], option: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in values:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", param_hint=option)
        out[key.strip()] = value.strip()
    return out


class _Reporter:
    """A progress bar with throughput and ETA (rich, stderr, shown only on a terminal)."""

    def __init__(self, console: Any, description: str):
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, ProgressColumn,
                                   TextColumn, TimeElapsedColumn, TimeRemainingColumn)
        from rich.text import Text

        class Throughput(ProgressColumn):
            def render(self, task: Any) -> Text:
                speed = task.finished_speed or task.speed
                return Text("   -- items/s" if speed is None else f"{speed:6.2f} items/s")

        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), Throughput(), TimeElapsedColumn(),
                                 TextColumn("ETA"), TimeRemainingColumn(),
                                 TextColumn("{task.fields[info]}"), console=console,
                                 disable=not console.is_terminal)
        self.description = description
        self.task: Any = None
        self.done = 0
        self.new = 0
        self.failed = 0

    def __call__(self, done: int, total: int, entry: dict | None) -> None:
        if self.task is None:
            self.task = self.progress.add_task(self.description, total=total, completed=done, info="")
            self.done = done
            return
        self.new += 1
        self.done = done
        if entry is not None and entry.get("status") == "failed":
            self.failed += 1
        info = f"[red]{self.failed} failed[/]" if self.failed else ""
        self.progress.update(self.task, completed=done, info=info)


@click.command("batch")
@click.argument("grammar", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--lots", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="GeoJSON (or .shp with pyshp) of lot polygons: one building per polygon")
@click.option("--variations", type=click.IntRange(min=1, max=MAX_VARIATIONS), default=None,
              help="derive N variations (a dataset for learning)")
@click.option("-o", "--out", required=True, type=click.Path(path_type=Path),
              help="output folder (resumable: run the same command again to continue)")
@click.option("--seed", type=int, default=0, show_default=True, help="run seed")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="attr override for every item (a lot's own attrs win); repeatable")
@click.option("--attrs", "attrs_mode", type=click.Choice(["sample", "default"]), default=None,
              help="variations: sample attrs in their ranges, re-roll choices, swap snippets "
                   "(default), or keep the grammar's attrs and vary the seed only")
@click.option("--format", "fmt", default="glb", show_default=True, help="model format")
@click.option("--render", default=None, metavar="STYLES",
              help="PNG renders per item, comma-separated: sketch, lines, shaded, shaded+lines")
@click.option("--render-size", type=click.IntRange(min=16, max=2048), default=256, show_default=True,
              help="render width and height in pixels")
@click.option("--merge", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="also write all built models as one file (e.g. city.glb) when the batch is done")
@click.option("--index", "index_format", type=click.Choice(["jsonl", "parquet"]), default="jsonl",
              show_default=True, help="dataset index: index.jsonl always; parquet adds index.parquet")
@click.option("--executor", default="local", show_default=True,
              help="local, dask (a Dask LocalCluster of --workers processes) or dask://HOST:PORT")
@click.option("--workers", type=click.IntRange(min=1, max=MAX_WORKERS), default=None,
              help="processes (local executor, Dask LocalCluster); default: one per CPU")
@click.option("--connect-timeout", type=click.FloatRange(min=0, min_open=True), default=10.0,
              show_default=True, help="seconds to reach a Dask scheduler")
@click.option("--degrees", type=click.Choice(["project", "refuse"]), default="project",
              show_default=True, help="lots in lon/lat degrees: project them to metres, or refuse them")
@click.option("--holes", type=click.Choice(["refuse", "fill"]), default="refuse", show_default=True,
              help="lots with holes: refuse them (per lot), or build on their outer ring")
@click.option("--units", type=click.Choice(["auto", "metres", "degrees"]), default="auto",
              show_default=True, help="what the lots' coordinates are")
@click.option("--max-triangles", type=click.IntRange(min=1), default=None,
              help="triangles of one model at most (a bigger one fails that item)")
@click.option("--fail-fast", is_flag=True, help="stop at the first failing item (it is not recorded)")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=None,
              help="hard stop: fail (resumably) after this many seconds")
@click.option("--time-limit", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS", help="graceful budget: start no new item after this many seconds, "
              "write and index what was made and say what fell short")
@click.option("--overwrite", is_flag=True, help="discard an earlier run in the folder instead of "
              "continuing it")
@click.option("--json", "as_json", is_flag=True, help="print the summary as JSON on stdout (for "
              "scripts) instead of a few lines for people")
def batch(grammar: Path, lots: Path | None, variations: int | None, out: Path, seed: int,
          sets: tuple[str, ...], attrs_mode: str | None, fmt: str, render: str | None,
          render_size: int, merge: Path | None, index_format: str, executor: str,
          workers: int | None, connect_timeout: float, degrees: str, holes: str, units: str,
          max_triangles: int | None, fail_fast: bool, timeout: float | None,
          time_limit: float | None, overwrite: bool, as_json: bool) -> None:
    """Derive many models of the grammar GRAMMAR into a resumable folder.

    \b
    grammarkit batch grammars/lots/block.grammar --lots grammars/lots/block.geojson -o city/
    grammarkit batch grammars/lots/block.grammar --lots lots.geojson -o city/ --merge city.glb
    grammarkit batch grammars/paris.grammar --variations 1000 -o ds/ --render sketch,shaded
    grammarkit batch grammars/paris.grammar --variations 100000 -o ds/ --executor dask
    """
    from rich.console import Console

    from ..run.batch import run_batch
    from ..run.executor import make_executor

    if (lots is None) == (variations is None):
        raise click.UsageError("give either --lots FILE (a building per lot) or --variations N")
    if lots is not None and attrs_mode == "sample":
        raise click.UsageError("--attrs sample applies to --variations; a lot's attrs come from its "
                               "properties (attrs, attr.<name>) and --set")
    console = Console(stderr=True)
    items: Any = lots if lots is not None else variations
    what = f"lots of {lots.name}" if lots is not None else f"variations of {grammar.name}"
    reporter = _Reporter(console, what)
    options = {"connect_timeout": connect_timeout} if executor.strip() != "local" else {}
    ex = make_executor(executor, workers, **options)
    # SIGTERM raises KeyboardInterrupt like Ctrl-C from the command's start (grammarkit.cli)
    try:
        with reporter.progress:
            summary = run_batch(
                grammar, items, out, executor=ex, seed=seed, attrs=_pairs(sets, "--set"),
                sample=None if attrs_mode is None else attrs_mode == "sample", format=fmt,
                render=render, render_size=render_size, merge=merge, index=index_format,
                fail_fast=fail_fast, overwrite=overwrite, timeout=timeout, time_limit=time_limit,
                limits={"max_triangles": max_triangles}, degrees=degrees, holes=holes, units=units,
                progress=reporter)
    except KeyboardInterrupt:
        click.echo(f"interrupted: {reporter.new} new items written to {out}/ (manifest.jsonl lists "
                   f"all {reporter.done} complete ones); run the same command again to continue",
                   err=True)
        raise SystemExit(130) from None
    finally:
        ex.close()
    for w in summary.warnings:
        console.print(f"[yellow]warning:[/] {w}", highlight=False)
    if summary.resumed:
        console.print(f"continued an earlier run: {summary.resumed} items were already in {out}/",
                      highlight=False)
    report_summary(summary, as_json)
    if summary.failed:
        shown = "\n".join(f"  {f['id']}: {f['error']}" for f in summary.failures[:10])
        more = f"\n  ... and {summary.failed - 10} more" if summary.failed > 10 else ""
        click.echo(f"{summary.failed} of {summary.requested} items failed (recorded in "
                   f"{summary.manifest} with status \"failed\"):\n{shown}{more}", err=True)
        raise SystemExit(1)


__all__ = ["batch", "GrammarkitError"]
