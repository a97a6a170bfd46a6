"""`grammarkit learn` and `grammarkit validate`: tiling grammars from and against segmented models."""
from __future__ import annotations

import contextlib
import json
import os
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator

import click

from ..errors import ShapeError


def _load_grammar(path: Path) -> Any:
    """Parse + resolve imports + check (grammarkit.dsl.load), keeping the file's location."""
    from .. import dsl

    loader = getattr(dsl, "load", None) or getattr(dsl, "parse")
    grammar = loader(path)
    if not grammar.source_path:
        grammar = grammar.model_copy(update={"source_path": str(path)})
    return grammar


def _console() -> Any:
    from rich.console import Console

    return Console(stderr=True)


@contextlib.contextmanager
def _stages() -> Iterator[Callable[[str], Any]]:
    """`stage(description)` context managers shown as rich progress lines on stderr (a spinner
    and the elapsed time each, a tick when done), only when stderr is a terminal: reading a
    5,000-part model or learning from it takes many seconds and should show signs of life.
    Output that is piped or captured stays clean."""
    console = _console()
    if not console.is_terminal:
        yield lambda description: contextlib.nullcontext()
        return
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    progress = Progress(SpinnerColumn(finished_text="[green]done"), TextColumn("{task.description}"),
                        TimeElapsedColumn(), console=console, transient=False)

    @contextlib.contextmanager
    def stage(description: str) -> Iterator[None]:
        task = progress.add_task(description, total=1)
        try:
            yield
        finally:
            progress.update(task, completed=1)

    with progress:
        yield stage


@contextlib.contextmanager
def _substages(stage: Callable[[str], Any], prefix: str) -> Iterator[Callable[[str], None]]:
    """A `progress(stage_name)` callback for learn/validate: each call ends the previous
    sub-stage line and starts the next ("learning: docking sites ..."), so a model that takes
    tens of seconds shows where it is."""
    current: list[Any] = []

    def say(name: str) -> None:
        while current:
            current.pop().__exit__(None, None, None)
        ctx = stage(f"{prefix}: {name}")
        ctx.__enter__()
        current.append(ctx)

    try:
        yield say
    finally:
        while current:
            current.pop().__exit__(None, None, None)


def _relative(path: Path, base: Path) -> str:
    try:
        return Path(os.path.relpath(path.resolve(), base.resolve())).as_posix()
    except ValueError:  # another drive (Windows)
        return path.resolve().as_posix()


@click.command("learn")
@click.argument("examples", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="grammar file to write (default: print to standard output)")
@click.option("--name", default=None, help="grammar name (default: the output file's stem)")
@click.option("--bandwidth", default=0.05, show_default=True, type=click.FloatRange(min=1e-6),
              help="Mean Shift bandwidth for docking configurations, as a fraction of the parts' size")
@click.option("--tolerance", default=None, type=click.FloatRange(min=0.0),
              help="contact tolerance in model units (default: 0.001 x the model's diagonal)")
@click.option("--no-docks", is_flag=True, help="write type pairs only, without docking placements")
@click.option("--neighbors", "neighbors", default="none", show_default=True,
              type=click.Choice(["multisets", "ranges", "none"]),
              help="neighbourhood rules: none (sites, docks, holes and counts only; generalises to "
                   "held-out tilings), count ranges, or exact multisets (Kalojanov)")
@click.option("--no-sites", is_flag=True, help="learn no docking sites (one dock per type pair)")
@click.option("--no-counts", is_flag=True, help="infer no `count(T, lo, hi)` constraints")
@click.option("--counts", "count_mode", default="few", show_default=True, type=click.Choice(["few", "all"]),
              help="count ranges for the types no example has more than 2 of (few), or for every type")
@click.option("--count-slack", default=0, show_default=True, type=click.IntRange(min=0),
              help="widen every learned count range by this many parts on each side")
@click.option("--no-holes", is_flag=True, help="infer no `filled(T, site)` constraints (interior holes)")
@click.option("--no-sockets", is_flag=True,
              help="allow only the site pairs the examples show (default: every pair whose sockets fit)")
@click.option("--up", default="+z", show_default=True, type=click.Choice(["+x", "-x", "+y", "-y", "+z", "-z"]),
              help="the examples' up axis")
def learn(examples: tuple[Path, ...], output: Path | None, name: str | None, bandwidth: float,
          tolerance: float | None, no_docks: bool, neighbors: str = "none", no_sites: bool = False,
          no_counts: bool = False, count_mode: str = "few", count_slack: int = 0, no_holes: bool = False,
          up: str = "+z", no_sockets: bool = False) -> None:
    """Learn the tiling grammar that segmented EXAMPLES (GLB/glTF/OBJ files or folders) exhibit.

    Example: grammarkit learn examples/*.glb -o castle.grammar"""
    from ..printer import print_grammar
    from ..tiling import learn as learn_grammar
    from ..tiling import read_assembly
    from ..run.writer import check_outputs, write_files

    if output is not None:  # refuse, before any work, to write the grammar over an example
        inputs = [q for p in examples for q in ([p] if not p.is_dir() else sorted(p.iterdir()))]
        check_outputs({"-o": output}, inputs=inputs)
    base = output.parent if output else Path.cwd()
    with _stages() as stage:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            asms = []
            for k, p in enumerate(examples, 1):
                with stage(f"reading {p} ({k}/{len(examples)})"):
                    asms.append(read_assembly(p))
        notes: list[str] = []
        with _substages(stage, f"learning from {sum(len(a) for a in asms)} parts") as say:
            grammar = learn_grammar(asms, name=name or (output.stem if output else "learned"),
                                    example_paths=[_relative(p, base) for p in examples],
                                    tolerance=tolerance, bandwidth=bandwidth, docks=not no_docks,
                                    neighbors=neighbors, sites=not no_sites,
                                    counts=False if no_counts else (True if count_mode == "few" else "all"),
                                    count_slack=count_slack, holes=not no_holes, sockets=not no_sockets, up=up, notes=notes,
                                    progress=say)
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    for line in notes:  # what was inferred (counts, symmetries, support): the user should know
        click.echo(f"learned: {line}", err=True)
    text = print_grammar(grammar)
    if output is None:
        click.echo(text, nl=False)
        return
    write_files({output: text})
    n_parts = sum(len(a) for a in asms)
    click.echo(f"wrote {output}: {len(grammar.parts)} part types, {len(grammar.sites)} sites, {len(grammar.docks)} docks, "
               f"{len(grammar.constraints)} constraints, learned from {len(asms)} example(s) "
               f"with {n_parts} parts", err=True)


@click.command("validate")
@click.argument("grammar_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("shapes", nargs=-1, type=click.Path(exists=True, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="print the report(s) as JSON")
@click.option("--tolerance", default=None, type=click.FloatRange(min=0.0),
              help="contact tolerance in model units (default: 0.001 x the model's diagonal)")
@click.option("--no-docks", is_flag=True, help="skip the docking-placement check")
def validate(grammar_file: Path, shapes: tuple[Path, ...], as_json: bool, tolerance: float | None,
             no_docks: bool) -> None:
    """Check SHAPES (segmented models) against a tiling grammar; without SHAPES, check the
    grammar's own examples (files or inline). Prints OK or every violation; exit status 1 on
    violations. Example: grammarkit validate castle.grammar shape.glb"""
    from ..tiling import load_examples, read_assembly, rules_from_grammar
    from ..tiling import validate as run_validate

    grammar = _load_grammar(grammar_file)
    if grammar.family == "split":
        raise ShapeError(f"{grammar_file}: this is a split grammar; `validate` checks tiling grammars")
    rules = rules_from_grammar(grammar)
    with _stages() as stage:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # unknown part types become violations (with the part id) rather than a read error
            asms = []
            for k, p in enumerate(shapes, 1):
                with stage(f"reading {p} ({k}/{len(shapes)})"):
                    asms.append(read_assembly(p))
            if not shapes:
                with stage(f"reading the examples of {grammar_file}"):
                    asms = load_examples(grammar, check_types=False)
        if not asms:
            raise ShapeError(f"{grammar_file}: nothing to validate (no shapes given and the grammar has no examples)")
        reports = []
        for k, a in enumerate(asms, 1):
            with _substages(stage, f"validating {a.name or k} ({len(a)} parts, {k}/{len(asms)})") as say:
                reports.append(run_validate(rules, a, tolerance=tolerance, docks=not no_docks, progress=say))
    if not as_json:
        for w in caught:
            click.echo(f"warning: {w.message}", err=True)
    ok = all(r.ok for r in reports)
    if as_json:
        doc = reports[0].to_json() if len(reports) == 1 else {"ok": ok, "reports": [r.to_json() for r in reports]}
        click.echo(json.dumps(doc, indent=2))
    else:
        for r in reports:
            click.echo(r.format())
    if not ok:
        click.get_current_context().exit(1)


__all__ = ["learn", "validate"]
