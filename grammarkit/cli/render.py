"""`grammarkit render MODEL -o out.png`: a preview picture of a mesh file (or a split grammar,
derived first) with the CPU renderer. Registered in `grammarkit.cli.BUILTIN_COMMANDS` as
("grammarkit.cli.render", "render")."""
from __future__ import annotations

import re
import time
from pathlib import Path

import click

from ..errors import ShapeError


def _parse_size(value: str) -> tuple[int, int]:
    # ASCII digits only, and few of them: int() of thousands of digits raises, and 8192 is the cap
    m = re.fullmatch(r"\s*([0-9]{1,6})\s*(?:[xX*]\s*([0-9]{1,6}))?\s*", value)
    if not m:
        shown = value if len(value) <= 40 else value[:37] + "..."
        raise click.BadParameter(f"expected WIDTHxHEIGHT such as 512x512, got {shown!r}",
                                 param_hint="--size")
    w = int(m.group(1))
    h = int(m.group(2) or w)
    if not (1 <= w <= 8192 and 1 <= h <= 8192):
        raise click.BadParameter(f"width and height must be 1..8192, got {w}x{h}",
                                 param_hint="--size")
    return w, h


def _parse_color(value: str | None, option: str) -> tuple[int, ...] | None:
    if value is None or value.lower() in ("none", "transparent"):
        return None
    v = value.strip().lstrip("#")
    if re.fullmatch(r"[0-9a-fA-F]{6}([0-9a-fA-F]{2})?", v):
        return tuple(int(v[i:i + 2], 16) for i in range(0, len(v), 2))
    from PIL import ImageColor

    try:
        return tuple(ImageColor.getrgb(value))
    except ValueError:
        raise click.BadParameter(f"not a colour: {value!r} (use #rrggbb or a name)",
                                 param_hint=option) from None


_UP = {"z": (0.0, 0.0, 1.0), "y": (0.0, 1.0, 0.0), "-z": (0.0, 0.0, -1.0), "-y": (0.0, -1.0, 0.0),
       "x": (1.0, 0.0, 0.0)}


@click.command("render")
@click.argument("model", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Image to write (.png, .jpg, ...); written atomically.")
@click.option("--style", type=click.Choice(["shaded", "lines", "shaded+lines"]),
              default="shaded+lines", show_default=True)
@click.option("--size", default="512x512", show_default=True, help="WIDTHxHEIGHT in pixels.")
@click.option("--pitch", type=float, default=30.0, show_default=True,
              help="Camera elevation above the horizon, degrees.")
@click.option("--yaw", type=float, default=-45.0, show_default=True,
              help="Camera azimuth, degrees (0: from the front, -45: front-right corner).")
@click.option("--fov", type=float, default=45.0, show_default=True,
              help="Vertical field of view, degrees (perspective).")
@click.option("--distance", type=float, default=None,
              help="Camera distance from the target; default: frame the model.")
@click.option("--ortho", is_flag=True, help="Orthographic projection instead of perspective.")
@click.option("--up", type=click.Choice(sorted(_UP)), default="z", show_default=True,
              help="World up axis of the model.")
@click.option("--line-width", type=float, default=1.5, show_default=True, help="Pixels.")
@click.option("--line-color", default="#191919", show_default=True)
@click.option("--crease-angle", type=float, default=30.0, show_default=True,
              help="Draw edges whose faces meet at more than this many degrees.")
@click.option("--no-silhouettes", is_flag=True, help="Do not draw silhouette edges.")
@click.option("--no-material-edges", is_flag=True,
              help="Do not draw edges between faces of different colours.")
@click.option("--sketchy", is_flag=True, help="Hand-drawn strokes (jitter, overshoot).")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seed of the sketchy strokes (and of the derivation for a .grammar).")
@click.option("--background", default="#ffffff", show_default=True,
              help="Background colour, or 'none' for a transparent PNG.")
@click.option("--supersample", type=click.IntRange(1, 4), default=2, show_default=True,
              help="Anti-aliasing factor.")
def render(model: Path, output: Path, style: str, size: str, pitch: float, yaw: float, fov: float,
           distance: float | None, ortho: bool, up: str, line_width: float, line_color: str,
           crease_angle: float, no_silhouettes: bool, no_material_edges: bool, sketchy: bool,
           seed: int, background: str, supersample: int) -> None:
    """Render MODEL (a .glb/.gltf/.obj/.stl/.ply mesh, or a .grammar to derive) to an image."""
    from ..geometry.camera import Camera
    from ..geometry.render import LineStyle, render as render_image, save_image

    width, height = _parse_size(size)
    from PIL import Image

    if output.suffix.lower() not in Image.registered_extensions():
        raise click.BadParameter(f"unknown image format {output.suffix or '(no suffix)'!r}; "
                                 "use .png, .jpg, .webp, ...", param_hint="--output")
    from ..run.writer import check_outputs

    check_outputs({"--output": output}, inputs=[model])  # never replace the model with its picture
    bg = _parse_color(background, "--background")
    lc = _parse_color(line_color, "--line-color") or (25, 25, 25)
    try:
        camera = Camera(pitch=pitch, yaw=yaw, fov=fov, distance=distance, up=_UP[up],
                        projection="orthographic" if ortho else "perspective")
        line_style = LineStyle(width=line_width, color=lc[:3], crease_angle=crease_angle,
                               silhouettes=not no_silhouettes,
                               material_edges=not no_material_edges, sketchy=sketchy, seed=seed)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None

    started = time.perf_counter()
    obj = _load_model(model, seed)
    loaded = time.perf_counter()
    try:
        img = render_image(obj, camera, style=style, size=(width, height), line_style=line_style,
                           background=bg, supersample=supersample)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    rendered = time.perf_counter()
    try:
        save_image(img, output)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    except OSError as exc:
        raise ShapeError(f"{output}: cannot write image: {exc.strerror or exc}") from None
    click.echo(f"wrote {output} ({width}x{height}, {style}; load {loaded - started:.2f} s, "
               f"render {rendered - loaded:.2f} s)")


def _load_model(path: Path, seed: int):
    if path.suffix.lower() == ".grammar":
        if not path.exists():
            raise ShapeError(f"{path}: grammar file not found")
        from .. import split

        derive = getattr(split, "derive", None)
        if derive is None:
            raise ShapeError(f"{path}: the split engine is not available to derive it")
        grammar = split.load_grammar(path)
        if grammar.family == "tiling":
            raise ShapeError(f"{path}: a tiling grammar has no single model to render; render one "
                             "of its assemblies (a .glb file, e.g. from `grammarkit derive`)")
        return derive(grammar, seed=seed)
    from ..geometry.meshio import load_mesh

    return load_mesh(path)
