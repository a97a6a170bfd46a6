"""Pictures of a retargeting, with grammarkit's CPU renderer (`grammarkit.geometry.render`).

- `before_after_png(input, output)`: the input and the output side by side at the same scale.
- `explain_png(report)`: the principal offsets as arrows on the input, the output coloured by
  label (which translated copy supplies each voxel), a slice of the label field as a grid
  with the label vectors, and the numbers (offsets, counts, steps, graph size, solve time).
"""
from __future__ import annotations

import colorsys
import io

import numpy as np
import trimesh
from PIL import Image, ImageDraw, ImageFont

import grammarkit.geometry.render as gk_render

__all__ = ["before_after_png", "explain_png", "label_colors"]

ARROW_COLORS = [(220, 50, 47), (38, 139, 60), (38, 90, 210)]
BACKGROUND = (255, 255, 255)


def _font(size: int):
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType sizes
        return ImageFont.load_default()


def label_colors(n: int) -> np.ndarray:
    """n well-separated colours (golden-ratio hues), uint8 RGB."""
    out = []
    for i in range(n):
        h = (0.08 + i * 0.6180339887) % 1.0
        s = 0.55 + 0.3 * ((i // 7) % 2)
        v = 0.95 - 0.2 * ((i // 3) % 2)
        out.append([int(round(c * 255)) for c in colorsys.hsv_to_rgb(h, s, v)])
    return np.array(out, dtype=np.uint8).reshape(-1, 3)


def _colored(mesh: trimesh.Trimesh, rgb=None) -> trimesh.Trimesh:
    out = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if rgb is not None:
        fc = np.tile(np.array([*rgb, 255], np.uint8), (len(mesh.faces), 1))
        out.visual.face_colors = fc
    elif mesh.visual.kind in ("face", "vertex"):
        out.visual.face_colors = np.asarray(mesh.visual.face_colors, np.uint8)
    return out


def _side_by_side(a: trimesh.Trimesh, b: trimesh.Trimesh) -> tuple[trimesh.Trimesh, float]:
    """b moved to the right of a (bounding boxes aligned at their minimum y and z)."""
    gap = 0.15 * float(max(a.extents.max(), b.extents.max()))
    shift = np.array([a.bounds[1][0] + gap - b.bounds[0][0],
                      a.bounds[0][1] - b.bounds[0][1], a.bounds[0][2] - b.bounds[0][2]])
    b2 = b.copy()
    b2.apply_translation(shift)
    return trimesh.util.concatenate([a, b2]), float(shift[0])


def _camera():
    return gk_render.Camera(pitch=22.0, yaw=-25.0, fov=35.0)


def _png(img: Image.Image) -> bytes:
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def _wrap(line: str, width: int) -> list[str]:
    words, out, cur = line.split(" "), [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width:
            out.append(cur)
            cur = "    " + w
        else:
            cur = f"{cur} {w}" if cur else w
    return out + [cur]


def _caption(img: Image.Image, lines: list[str], size: int = 15) -> Image.Image:
    font = _font(size)
    line_h = size + 6
    chars = max(20, int(img.width / (0.52 * size)))
    lines = [w for line in lines for w in _wrap(line, chars)]
    out = Image.new("RGB", (img.width, img.height + line_h * len(lines) + 10), BACKGROUND)
    out.paste(img, (0, 0))
    draw = ImageDraw.Draw(out)
    for i, line in enumerate(lines):
        draw.text((12, img.height + 4 + i * line_h), line, fill=(30, 30, 30), font=font)
    return out


def before_after_image(before: trimesh.Trimesh, after: trimesh.Trimesh, *,
                       size: tuple[int, int] = (960, 420), caption: list[str] | None = None) -> Image.Image:
    scene, _ = _side_by_side(_colored(before), _colored(after))
    img = gk_render.render(scene, _camera(), style="shaded+lines", size=size,
                           line_style=gk_render.LineStyle(width=1.0, crease_angle=40.0))
    return _caption(img, caption) if caption else img


def before_after_png(before: trimesh.Trimesh, after: trimesh.Trimesh, *,
                     size: tuple[int, int] = (960, 420), caption: list[str] | None = None) -> bytes:
    """PNG bytes: the input (left) and the output (right) at the same scale."""
    return _png(before_after_image(before, after, size=size, caption=caption))


def _arrow(start: np.ndarray, vector: np.ndarray, radius: float, rgb) -> trimesh.Trimesh:
    length = float(np.linalg.norm(vector))
    head = min(0.35 * length, 6 * radius)
    axis = vector / length
    shaft_end = start + axis * (length - head)
    shaft = trimesh.creation.cylinder(radius=radius, segment=[start, shaft_end], sections=12)
    cone = trimesh.creation.cone(radius=2.4 * radius, height=head, sections=12)
    # trimesh's cone points along +z from the origin: rotate onto the axis, move to the shaft end
    cone.apply_transform(trimesh.geometry.align_vectors([0, 0, 1], axis))
    cone.apply_translation(shaft_end)
    arrow = trimesh.util.concatenate([shaft, cone])
    return _colored(arrow, rgb)


def _label_face_colors(report, mesh: trimesh.Trimesh, colors: np.ndarray) -> np.ndarray:
    lab = report.labelling
    frame = report.offsets.frame
    centres = frame.to_normalised(mesh.triangles_center)
    vox = np.floor(lab.lattice.to_lattice(centres) - lab.lattice.start).astype(np.int64)
    vox = np.clip(vox, 0, lab.dims - 1)
    labels = report.label_grid[vox[:, 0], vox[:, 1], vox[:, 2]]
    return colors[labels]


def _label_grid_image(report, colors: np.ndarray, height: int) -> tuple[Image.Image, str]:
    """The label field: the slice through the output voxels across the two generators with
    the most voxels (drawn with the one closer to world x across), each cell in its label's
    colour with its label vector (the steps along the retargeted generators)."""
    grid, L = report.label_grid, report.labelling.labels
    gens = report.offsets.generators
    dims = np.array(grid.shape)
    pair = sorted(np.argsort(-dims, kind="stable")[:2])
    across, up = sorted(pair, key=lambda a: -abs(gens[a][0]) / np.linalg.norm(gens[a]))
    third = [a for a in range(3) if a not in (across, up)][0]
    sl = [slice(None)] * 3
    sl[third] = dims[third] // 2
    field = grid[tuple(sl)]
    if across > up:
        field = field.T  # rows along `across`
    nx, ny = field.shape
    cell = int(max(6, min(56, (height - 20) / max(ny, 1), 1060 / max(nx, 1))))
    img = Image.new("RGB", (nx * cell + 40, ny * cell + 20), BACKGROUND)
    draw = ImageDraw.Draw(img)
    font = _font(max(8, min(13, cell // 4)))
    retargeted = [i for i in range(3) if report.steps[i] != 0]
    for i in range(nx):
        for j in range(ny):
            lbl = int(field[i, j])
            x0, y0 = 20 + i * cell, 10 + (ny - 1 - j) * cell  # `up` upwards
            draw.rectangle([x0, y0, x0 + cell - 1, y0 + cell - 1],
                           fill=tuple(int(c) for c in colors[lbl]), outline=(255, 255, 255))
            if cell >= 24:
                text = ",".join(str(int(L[lbl][a])) for a in retargeted) or "0"
                draw.text((x0 + 3, y0 + 3), text, fill=(20, 20, 20), font=font)
    names = [f"v{a + 1}" for a in range(3)]
    what = (f"label field (below): output voxels along {names[across]} (across) and "
            f"{names[up]} (up), the middle layer along {names[third]}; each cell shows how many "
            f"steps along {', '.join(names[a] for a in retargeted) or 'no generator'} its copy is moved")
    return img, what


def explain_image(report, *, size: tuple[int, int] = (1100, 460)) -> Image.Image:
    """The principal offsets and the label field of a retargeting (`RetargetReport`)."""
    offsets = report.offsets
    inp = report.input_mesh if getattr(report, "input_mesh", None) is not None else None
    out = report.mesh
    lines = []
    if offsets is not None:
        for i, (g, s, c) in enumerate(zip(offsets.generators, offsets.structured, offsets.counts)):
            kind = f"principal, {int(c)} matches" if s else "dummy (not retargeted along)"
            lines.append(f"v{i + 1} = ({', '.join(f'{x:.4g}' for x in g)})  |v{i + 1}| = "
                         f"{np.linalg.norm(g):.4g}  {kind}")
        sp = offsets.sparsity
        if sp.get("bins"):
            lines.append(f"offset histogram: {sp['offsets']} matches in {sp['bins']} bins; "
                         f"{100 * sp['top7']:.1f}% in the fullest 7% of bins, "
                         f"{100 * sp['top20']:.1f}% in 20% (paper: 79.9%, 97.1%)")
    st = report.stats
    lines.append(f"steps k = {report.steps.astype(int).tolist()}; size "
                 f"{' x '.join(f'{x:.4g}' for x in report.input_size)} -> "
                 f"{' x '.join(f'{x:.4g}' for x in report.size)} (requested "
                 f"{' x '.join(f'{x:.4g}' for x in report.requested)})")
    if report.labelling is not None:
        lines.append(f"MRF: {st['nodes']} nodes, {st['labels']} labels, {st['edges']} edges; "
                     f"alpha-expansion {st['solver']['cycles']} cycles, "
                     f"{st['seconds']['solve']:.3f} s; energy {st['solver']['initial_energy']:.4g} -> "
                     f"{st['solver']['energy']:.4g}")
    if report.labelling is None or inp is None:
        img = gk_render.render(_colored(out), _camera(), style="shaded+lines", size=size)
        return _caption(img, lines)
    colors = label_colors(report.labelling.n_labels)
    colored_out = _colored(out)
    colored_out.visual.face_colors = np.column_stack(
        [_label_face_colors(report, out, colors), np.full(len(out.faces), 255, np.uint8)])
    base = _colored(inp, (205, 205, 200))
    radius = 0.008 * float(inp.extents.max())
    start = np.array([inp.bounds[0][0], inp.bounds[0][1] - 0.08 * inp.extents.max(),
                      inp.bounds[1][2] + 0.06 * inp.extents.max()])
    arrows = [_arrow(start, g, radius, ARROW_COLORS[i])
              for i, (g, s) in enumerate(zip(offsets.generators, offsets.structured)) if s]
    left = trimesh.util.concatenate([base, *arrows])
    scene, _ = _side_by_side(left, colored_out)
    img = gk_render.render(scene, _camera(), style="shaded+lines", size=size,
                           line_style=gk_render.LineStyle(width=1.0, crease_angle=40.0))
    grid, grid_text = _label_grid_image(report, colors, height=size[1])
    width = max(img.width, grid.width)
    combined = Image.new("RGB", (width, img.height + grid.height), BACKGROUND)
    combined.paste(img, (0, 0))
    combined.paste(grid, (0, img.height))
    legend = ["arrows: principal offsets (v1 red, v2 green, v3 blue); right: the output, "
              "each voxel in the colour of the copy that supplies it", grid_text] + lines
    return _caption(combined, legend)


def explain_png(report, *, size: tuple[int, int] = (1100, 460)) -> bytes:
    """PNG bytes of `explain_image`."""
    return _png(explain_image(report, size=size))
