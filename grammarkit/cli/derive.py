"""`grammarkit derive`: grammar file -> model file(s).

Split grammars are derived by the split engine (`grammarkit.split`); tiling grammars (or any
grammar with `--backend NAME`) are handed to a back end plugin with a DeriveRequest. Every
output is computed in memory first and written atomically (temporary file + rename), so a
failure never leaves a half-written file behind.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import click

from ..errors import GrammarError, GrammarkitError, PluginError, ShapeError

FORMATS = ("glb", "obj", "stl", "ply")
# Resource guards of the command line: one run writes at most MAX_MODELS files (the manifest
# of all of them is held in memory) and starts at most MAX_WORKERS processes.
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


def _progress_factory(console: Any) -> tuple[Any, Callable[..., Callable[..., None]]]:
    """A rich Progress and a `progress(description, total)` factory for back ends."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                        TimeElapsedColumn(), TextColumn("{task.fields[info]}"), console=console,
                        transient=False)

    def factory(description: str, total: int | None = None) -> Callable[..., None]:
        task = progress.add_task(description, total=total, info="")

        def advance(n: int = 1, **fields: Any) -> None:
            info = " ".join(f"{k}={v}" for k, v in fields.items())
            progress.update(task, advance=n, info=info)
        return advance
    return progress, factory


def _write_text(path: Path, text: str) -> None:
    from ..fileio import atomic_output

    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _check_format(out: Path, fmt: str | None) -> str:
    if fmt:
        return fmt
    suffix = out.suffix.lower().lstrip(".")
    if suffix in FORMATS or suffix == "gltf":
        return suffix
    raise click.BadParameter(f"cannot tell the format of {out.name!r} from its suffix; "
                             f"use --format ({'|'.join(FORMATS)})", param_hint="-o/--format")


@click.command("derive")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--out", required=True, type=click.Path(path_type=Path),
              help="model file (split grammar), or folder (--variations, back ends)")
@click.option("--preview", type=click.Path(path_type=Path), default=None,
              help="also render a PNG preview (a folder with --variations)")
@click.option("--seed", type=int, default=0, show_default=True, help="run seed")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="set an attr (checked against its range/enum); repeatable")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default=None,
              help="output format (default: from the file suffix)")
@click.option("--tree", type=click.Path(path_type=Path), default=None,
              help="write the derivation tree as JSON")
@click.option("--variations", type=click.IntRange(min=1, max=MAX_MODELS), default=None,
              help=f"derive N variations into the -o folder (at most {MAX_MODELS})")
@click.option("--backend", default=None, help="back end for tiling grammars (see `grammarkit plugins`)")
@click.option("-n", "count", type=click.IntRange(min=1, max=MAX_MODELS), default=1, show_default=True,
              help="number of models a back end should make")
@click.option("--iterations", type=click.IntRange(min=1), default=1, show_default=True,
              help="back end iterations (sampler steps)")
@click.option("--workers", type=click.IntRange(min=1, max=MAX_WORKERS), default=None,
              help="worker processes (back ends, and --variations)")
@click.option("--option", "options", multiple=True, metavar="KEY=VALUE", help="back end option; repeatable")
def derive(file: Path, out: Path, preview: Path | None, seed: int, sets: tuple[str, ...],
           fmt: str | None, tree: Path | None, variations: int | None, backend: str | None,
           count: int, iterations: int, workers: int | None, options: tuple[str, ...]) -> None:
    """Derive a model from the grammar FILE.

    \b
    grammarkit derive grammars/paris.grammar -o paris.glb --preview paris.png
    grammarkit derive grammars/paris.grammar -o out/ --variations 20
    grammarkit derive castle.grammar -o out/ -n 10 --backend graph-sampler
    """
    from rich.console import Console

    from ..dsl import load

    console = Console(stderr=True)
    grammar = load(file)
    if backend is not None or grammar.family == "tiling":
        _run_backend(grammar, backend, out, count, iterations, seed, workers, _pairs(options, "--option"),
                     console)
        return
    if grammar.family != "split":
        raise GrammarError(f"{file}: the grammar has no rules to derive", None)
    attrs = _pairs(sets, "--set")
    if variations is not None:
        _run_variations(grammar, out, variations, seed, attrs, fmt or "glb", preview, tree, console,
                        file, workers)
        return
    _run_single(grammar, out, seed, attrs, _check_format(out, fmt), preview, tree, console)


def _check_out_file(path: Path, option: str) -> None:
    """Refuse an output path that can never be written, before any work is done."""
    if path.is_dir():
        raise click.BadParameter(f"{str(path)!r} is a folder; give a file name", param_hint=option)


def _check_image(path: Path, option: str) -> None:
    from PIL import Image

    _check_out_file(path, option)
    if Image.registered_extensions().get(path.suffix.lower()) is None:
        raise click.BadParameter(f"cannot tell the image format of {path.name!r} from its suffix; "
                                 "use .png (or .jpg, .webp, ...)", param_hint=option)


def _make_folder(folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ShapeError(f"{folder}: cannot create folder: {exc.strerror or exc}") from None


def _run_single(grammar: Any, out: Path, seed: int, attrs: dict[str, str], fmt: str,
                preview: Path | None, tree: Path | None, console: Any) -> None:
    from contextlib import ExitStack

    from ..geometry.exporters import atomic_output, export
    from ..split import derive as derive_model

    _check_out_file(out, "-o")
    if preview is not None:
        _check_image(preview, "--preview")
    if tree is not None:
        _check_out_file(tree, "--tree")
    model = derive_model(grammar, seed=seed, attrs=attrs)
    image = _preview(model) if preview is not None else None
    tree_text = model.tree_json(indent=1) if tree is not None else None
    for p in [out, preview, tree]:  # only now that everything is computed
        if p is not None:
            _make_folder(p.parent)
    # one transaction: every file is written to its temporary name first and the renames
    # happen only when all of them were written, so a failing preview or tree (a full disk,
    # an unwritable folder) leaves an existing model file untouched, and vice versa
    with ExitStack() as stack:
        export(model.to_scene(), stack.enter_context(atomic_output(out)), fmt)
        if image is not None:
            from ..geometry.render import save_image
            save_image(image, stack.enter_context(atomic_output(preview)),
                       format=_image_format(preview))
        if tree_text is not None:
            stack.enter_context(atomic_output(tree)).write_text(tree_text, encoding="utf-8")
    for w in model.warnings:
        console.print(f"[yellow]warning:[/] {w}", highlight=False)
    click.echo(f"wrote {out} ({fmt}): {model.triangle_count} triangles, {len(model.parts)} terminals, "
               f"{model.shape_count} shapes" + (f"; preview {preview}" if preview else "")
               + (f"; tree {tree}" if tree else ""))


def _image_format(path: Path) -> str:
    from PIL import Image

    return Image.registered_extensions()[path.suffix.lower()]


def _preview(model: Any) -> Any:
    from ..geometry.render import render

    return render(model.mesh, style="shaded+lines", size=(640, 640))


def _variation_job(job: tuple) -> dict:
    """Derive and write variation `index` (in a worker process or in the main one)."""
    grammar, index, seed, attrs, fmt, out, preview, tree = job
    from ..geometry.exporters import export
    from ..split import load_grammar, variations as split_variations

    g = load_grammar(grammar)
    name = g.name or "model"
    (var, model), = split_variations(g, 1, seed=seed, attrs=attrs, start=index)
    stem = f"{name}_{var.index:04d}"
    path = Path(out) / f"{stem}.{fmt}"
    export(model.to_scene(), path, fmt)
    entry = {"file": path.name, **var.to_dict(), "triangles": model.triangle_count,
             "terminals": len(model.parts)}
    if preview is not None:
        from ..geometry.render import save_image
        save_image(_preview(model), Path(preview) / f"{stem}.png")
        entry["preview"] = str(Path(preview) / f"{stem}.png")
    if tree:
        _write_text(Path(out) / f"{stem}.tree.json", model.tree_json())
    return entry


def _run_variations(grammar: Any, out: Path, n: int, seed: int, attrs: dict[str, str], fmt: str,
                    preview: Path | None, tree: Path | None, console: Any, file: Path,
                    workers: int | None) -> None:
    from ..split import check_attrs

    if out.suffix and out.suffix.lower().lstrip(".") in FORMATS + ("gltf",):
        raise click.BadParameter("with --variations, -o is a folder", param_hint="-o")
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"with --variations, -o is a folder; {str(out)!r} is a file",
                                 param_hint="-o")
    if preview is not None and preview.exists() and not preview.is_dir():
        raise click.BadParameter(f"with --variations, --preview is a folder; {str(preview)!r} is a file",
                                 param_hint="--preview")
    check_attrs(grammar, attrs)  # a bad --set fails before any folder is made
    _make_folder(out)
    if preview is not None:
        _make_folder(preview)
    workers = min(workers, n) if workers else None
    progress, factory = _progress_factory(console)
    name = grammar.name or "model"
    # workers re-load the grammar from its file (a Grammar object does not cross processes
    # cheaply); the main process passes its own object
    jobs = [(grammar if not workers or workers < 2 else str(file), i, seed, attrs, fmt, str(out),
             str(preview) if preview is not None else None, tree is not None) for i in range(n)]
    manifest: list[dict] = []
    with progress:
        advance = factory(f"deriving {n} variations of {name}", n)
        if workers and workers > 1:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
                for entry in pool.map(_variation_job, jobs, chunksize=max(1, n // (8 * workers))):
                    manifest.append(entry)
                    advance(1, file=entry["file"])
        else:
            for job in jobs:
                entry = _variation_job(job)
                manifest.append(entry)
                advance(1, file=entry["file"])
    _write_text(out / "variations.json", json.dumps({"grammar": name, "seed": seed, "variations": manifest},
                                                    indent=1, default=str))
    click.echo(f"wrote {n} variations to {out}/ (manifest: {out / 'variations.json'})")


def _run_backend(grammar: Any, name: str | None, out: Path, n: int, iterations: int, seed: int,
                 workers: int | None, options: dict[str, str], console: Any) -> None:
    from ..plugins import get_plugin_manager
    from ..registry import DeriveRequest

    pm = get_plugin_manager()
    family = grammar.family
    spec = pm.backend(name) if name is not None else pm.default_backend(family)
    if spec is None:
        known = ", ".join(sorted(pm.backends())) or "none installed"
        raise GrammarkitError(f"no default back end for {family} grammars; pass --backend NAME "
                              f"(known: {known})")
    if family not in spec.families:
        raise GrammarkitError(f"back end {spec.name!r} does not derive {family} grammars "
                              f"(it accepts: {', '.join(sorted(spec.families))})")
    if spec.derive is None:
        raise GrammarkitError(f"back end {spec.name!r} (plugin {spec.plugin!r}) has no derive function")
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"a back end writes into a folder; {str(out)!r} is a file", param_hint="-o")
    # (the back end makes the folder itself, once its options are known to be good)
    progress, factory = _progress_factory(console)
    request = DeriveRequest(out=out, n=n, iterations=iterations, seed=seed, workers=workers,
                            options=options, progress=factory)
    with progress:
        try:
            summary = spec.derive(grammar, request)
        except GrammarkitError:
            raise
        except OSError as exc:  # a file the back end could not write or read
            where = exc.filename or out
            raise ShapeError(f"{where}: back end {spec.name!r}: {exc.strerror or exc}") from None
        except Exception as exc:  # noqa: BLE001 - a plugin crashed: name it, no traceback
            raise PluginError(f"back end {spec.name!r} (plugin {spec.plugin!r}) failed: "
                              f"{type(exc).__name__}: {exc}") from None
    click.echo(json.dumps(summary, indent=1, default=str))
