"""`grammarkit retarget MODEL (--size X Y Z | --scale X Y Z) -o OUT`: the retargeter's command,
added to `grammarkit` by the `grammarkit_cli_commands` hook (see plugin.py).

Everything is computed first; the model, `--preview` and `--explain` pictures are then written
together through `grammarkit.run.write_files` (all files or none), so nothing is written when
anything fails. Imports of trimesh/scipy/manifold3d happen inside the command only.
"""
from __future__ import annotations

import json
from pathlib import Path

import click


def _png_option(path: Path | None, option: str) -> None:
    if path is not None and path.suffix.lower() != ".png":
        raise click.BadParameter(f"{path}: the picture is written as PNG; give a .png name",
                                 param_hint=option)


@click.command("retarget")
@click.argument("model", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Mesh to write (.glb, .gltf, .obj, .stl, .ply).")
@click.option("--size", nargs=3, type=float, default=None, metavar="X Y Z",
              help="Requested bounding box, in the model's units and axes.")
@click.option("--scale", nargs=3, type=float, default=None, metavar="X Y Z",
              help="Requested bounding box as factors of the model's (e.g. 2 1 1).")
@click.option("--allow-scale", is_flag=True,
              help="Scale along axes no principal offset runs along (and scale a model "
                   "without repetitive structure) instead of refusing.")
@click.option("--exact", is_flag=True,
              help="Scale the remainder (under half a voxel) so the bounding box is exactly the "
                   "requested one; by default it is the nearest whole number of steps.")
@click.option("--open-surface", is_flag=True,
              help="Stitch an open (not watertight) mesh as a surface instead of refusing it.")
@click.option("--preview", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write a before/after picture (.png).")
@click.option("--explain", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the principal offsets and the label field as a picture (.png).")
@click.option("--seam", type=click.Choice(["geometry", "descriptor"]), default="geometry",
              show_default=True,
              help="Seam cost: surface distance of the two copies, or the paper's Hausdorff "
                   "distance of their SHOT descriptor sets.")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seed of the surface samples (same seed, same output).")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def retarget_command(model: Path, output: Path, size, scale, allow_scale: bool, exact: bool,
                     open_surface: bool, preview: Path | None, explain: Path | None, seam: str,
                     seed: int, as_json: bool) -> None:
    """Resize MODEL by stitching translated copies of it along its principal offsets, so that
    repeated elements (shelves, pickets, windows) are added or removed instead of stretched
    (Wu et al., "3D Model Retargeting Using Offset Statistics")."""
    if (size is None) == (scale is None):
        raise click.UsageError("give exactly one of --size X Y Z and --scale X Y Z")
    _png_option(preview, "--preview")
    _png_option(explain, "--explain")
    from grammarkit.geometry.exporters import encode_with, exporter_for
    from grammarkit.geometry.meshio import load_mesh
    from grammarkit.run import check_outputs, write_files

    from .retargeting import prepare_mesh, retarget_report, target_from_scale

    check_outputs({"--output": output, "--preview": preview, "--explain": explain},
                  inputs=[model])
    spec = exporter_for(output)
    steps = 3 + (preview is not None) + (explain is not None)
    with progress_bar() as bar:
        task = bar.add_task(f"reading {model}", total=steps)
        # per part: a scene's parts are welded one by one, never to each other
        mesh = prepare_mesh(load_mesh(model), str(model))
        target = size if size is not None else target_from_scale(mesh, scale, str(model))
        bar.update(task, advance=1, description="finding offsets, stitching copies")
        report = retarget_report(mesh, target, allow_scale=allow_scale, exact=exact,
                                 open_surface=open_surface, name=str(model), seed=seed, seam=seam)
        bar.update(task, advance=1, description=f"encoding {output.name}")
        files: dict[Path, bytes] = {output: encode_with(spec, report.mesh)}
        if preview is not None:
            from .pictures import before_after_png

            bar.update(task, advance=1, description=f"drawing {preview.name}")
            files[preview] = before_after_png(mesh, report.mesh, caption=[_one_line(report)])
        if explain is not None:
            from .pictures import explain_png

            bar.update(task, advance=1, description=f"drawing {explain.name}")
            files[explain] = explain_png(report)
        bar.update(task, advance=1, description="writing")
        write_files(files)
    summary = report.summary()
    summary["output"] = str(output)
    if as_json:
        click.echo(json.dumps(summary, indent=1, sort_keys=True))
        return
    click.echo(f"wrote {output} ({len(report.mesh.faces)} triangles): {_one_line(report)}")
    for path in (preview, explain):
        if path is not None:
            click.echo(f"wrote {path}")


def progress_bar():  # noqa: ANN201 - rich.progress.Progress
    """Progress on stderr (rich, transient: silent when stderr is not a terminal); stdout keeps
    the summary or the JSON."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    console = Console(stderr=True)
    return Progress(SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(),
                    MofNCompleteColumn(), TimeElapsedColumn(), console=console,
                    transient=True, disable=not console.is_terminal)


def _one_line(report) -> str:
    fmt = lambda v: " x ".join(f"{x:.4g}" for x in v)  # noqa: E731
    if report.method == "scale":
        how = "scaled (no principal offset)"
    elif report.method == "unchanged":
        how = "no repeats added or removed (the nearest whole number of steps is 0)"
    else:
        gens = [f"{int(k):+d} x ({', '.join(f'{x:.3g}' for x in g)})"
                for g, s, k in zip(report.offsets.generators, report.offsets.structured, report.steps)
                if s and k]
        how = "stitched " + ", ".join(gens)
        if report.stats.get("nodes"):
            how += (f"; {report.stats['nodes']} voxels, {report.stats['labels']} labels, solved in "
                    f"{report.stats['seconds']['solve']:.3f} s")
    scaled = [f"{'xyz'[a]} x{f:.4g}" for a, f in enumerate(report.scale) if abs(f - 1) > 1e-9]
    if scaled and report.method != "scale":
        how += "; then scaled " + ", ".join(scaled)
    return (f"{fmt(report.input_size)} -> {fmt(report.size)} (requested {fmt(report.requested)}); "
            + how)
