"""`grammarkit substructures MODEL --grammar G`: every replaceable substructure of a model."""
from __future__ import annotations

import json
from pathlib import Path

import click


@click.command("substructures")
@click.argument("model", type=click.Path(exists=True, path_type=Path))
@click.option("--grammar", "grammar_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="tiling grammar: part types from its `part` declarations, reconnections checked "
                   "against its type pairs")
@click.option("--q", "q", type=click.IntRange(0, 4), default=0, show_default=True,
              help="ordering violations tolerated per match (dummy edges; the paper uses q <= 2)")
@click.option("--tolerance", type=click.FloatRange(min=0.0), default=None,
              help="contact tolerance in model units (default: 0.001 x the model's diagonal)")
@click.option("--json", "as_json", is_flag=True, help="print the operations as JSON")
@click.option("--pictures", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="write a PNG per operation into this folder (both pieces highlighted)")
@click.option("--limit", type=click.IntRange(min=1), default=None,
              help="list (and draw) at most this many operations")
def substructures(model: Path, grammar_file: Path | None, q: int, tolerance: float | None,
                  as_json: bool, pictures: Path | None, limit: int | None) -> None:
    """List every replaceable substructure of MODEL (a segmented GLB/glTF/OBJ or folder) as
    normalised operations (Liu et al. 2015): the removed and the copied piece, their cut edges,
    the boundary correspondence, and whether the rule is recursive.

    Example: grammarkit substructures castle_small.glb --grammar castle.grammar --pictures ops/"""
    from grammarkit.errors import GrammarkitError, ShapeError
    from grammarkit.tiling import read_assembly

    from . import api
    from .shape import Shape

    grammar = None
    if grammar_file is not None:
        from grammarkit.dsl import load

        grammar = load(grammar_file)
        if grammar.family != "tiling":
            raise ShapeError(f"{grammar_file}: a {grammar.family} grammar; substructures need a tiling grammar")
    try:
        assembly = read_assembly(model, grammar=grammar)
    except GrammarkitError:
        raise
    except Exception as exc:  # a file trimesh cannot read: say which and why
        raise ShapeError(f"{model}: cannot read the model: {exc}") from None
    if len(assembly) == 0:
        raise ShapeError(f"{model}: the model has no parts")
    shape = Shape.from_assembly(assembly, tolerance)
    with click.progressbar(length=len(shape), label="matching", file=None,
                           show_pos=True) if len(shape) >= 200 else _NoBar() as bar:
        ops = api.enumerate(shape, grammar, q=q, progress=bar.update)
    total = len(ops)
    if limit is not None:
        ops = ops[:limit]
    if total == 0:
        click.echo(f"{model}: no replaceable substructure: no two pieces of the shape graph "
                   f"({len(shape)} parts, {len(shape.edges)} contacts) have boundaries that "
                   "reconnect in observed ways" + ("" if q else "; --q 1 or 2 tolerates ordering defects"),
                   err=True)
    rows = [dict(op.to_json(shape.ids, shape.ids), id=k) for k, op in enumerate(ops)]
    if pictures is not None and ops:
        from grammarkit.fileio import atomic_output

        from .pictures import operation_png

        pictures.mkdir(parents=True, exist_ok=True)
        for k, op in enumerate(ops):
            data = operation_png(shape.meshes, op)
            path = pictures / f"operation_{k:04d}.png"
            with atomic_output(path) as tmp:
                Path(tmp).write_bytes(data)
            rows[k]["picture"] = str(path)
    if as_json:
        click.echo(json.dumps({"model": str(model), "parts": len(shape), "contacts": len(shape.edges),
                               "q": q, "operations_total": total, "operations": rows}, indent=1))
        return
    for row in rows:
        rec = f" [{row['recursive']}]" if row["recursive"] else ""
        links = ", ".join(f"{b['copied']}->{b['attach_to']} (was {b['replaces']})" for b in row["boundary"])
        click.echo(f"#{row['id']}{rec}: remove {{{', '.join(row['removed'])}}}  copy "
                   f"{{{', '.join(row['copied'])}}}  cut: {links}")
    if total:
        n_rec = sum(1 for op in ops if op.recursive)
        click.echo(f"{total} operation(s) on {len(shape)} parts ({n_rec} of those listed recursive)"
                   + (f"; pictures in {pictures}" if pictures is not None else ""), err=True)


class _NoBar:
    def __enter__(self):  # noqa: ANN204
        return self

    def __exit__(self, *exc) -> None:  # noqa: ANN002
        return None

    def update(self, n: int) -> None:
        return None
