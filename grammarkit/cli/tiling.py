"""`grammarkit learn` and `grammarkit validate`: tiling grammars from and against segmented models."""
from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import click

from ..errors import ShapeError


def _load_grammar(path: Path):  # noqa: ANN202
    """Parse + resolve imports + check (grammarkit.dsl.load), keeping the file's location."""
    from .. import dsl

    loader = getattr(dsl, "load", None) or getattr(dsl, "parse")
    grammar = loader(path)
    if not grammar.source_path:
        grammar = grammar.model_copy(update={"source_path": str(path)})
    return grammar


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
def learn(examples: tuple[Path, ...], output: Path | None, name: str | None, bandwidth: float,
          tolerance: float | None, no_docks: bool) -> None:
    """Learn the tiling grammar that segmented EXAMPLES (GLB/glTF/OBJ files or folders) exhibit.

    Example: grammarkit learn examples/*.glb -o castle.grammar"""
    from ..printer import print_grammar
    from ..tiling import learn as learn_grammar
    from ..tiling import read_assembly
    from ..tiling.io import _atomic_write

    base = output.parent if output else Path.cwd()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        asms = [read_assembly(p) for p in examples]
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    grammar = learn_grammar(asms, name=name or (output.stem if output else "learned"),
                            example_paths=[_relative(p, base) for p in examples],
                            tolerance=tolerance, bandwidth=bandwidth, docks=not no_docks)
    text = print_grammar(grammar)
    if output is None:
        click.echo(text, nl=False)
        return
    _atomic_write(output, text.encode("utf-8"))
    n_parts = sum(len(a) for a in asms)
    click.echo(f"wrote {output}: {len(grammar.neighbor_rules)} part types, {len(grammar.docks)} docks, "
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
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # unknown part types become violations (with the part id) rather than a read error
        asms = [read_assembly(p) for p in shapes] if shapes else load_examples(grammar, check_types=False)
    if not as_json:
        for w in caught:
            click.echo(f"warning: {w.message}", err=True)
    if not asms:
        raise ShapeError(f"{grammar_file}: nothing to validate (no shapes given and the grammar has no examples)")
    reports = [run_validate(rules, a, tolerance=tolerance, docks=not no_docks) for a in asms]
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
