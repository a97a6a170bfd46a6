"""The pictures of docs/retarget.md: each test model before and after retargeting, and one
`--explain` picture.

    python -m grammarkit_retarget.gallery docs/images

writes `retarget_<model>.png` (input left, retargeted right, same scale; the caption says
what was asked and what came out) and `retarget_explain.png`, all at once through
`grammarkit.run.write_files`. PNGs are palette-quantised to stay small.
"""
from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np

# (model, axis, factor) shown for each test model
SHOWN = [("facade_panel", 0, 2.0), ("picket_fence", 0, 1.5), ("bookshelf", 0, 2.0),
         ("railing", 0, 0.5), ("tiled_floor", 0, 1.5)]
EXPLAIN = ("bookshelf", 2, 1.5)


def _small_png(img) -> bytes:
    buf = io.BytesIO()
    img.convert("RGB").quantize(colors=128, dither=0).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def pictures() -> dict[str, bytes]:
    from . import testmodels
    from .pictures import before_after_image, explain_image
    from .retargeting import retarget_report, scale_to

    out = {}
    for name, axis, f in SHOWN:
        model = testmodels.build(name)
        size = np.asarray(model.mesh.extents, dtype=np.float64).copy()
        size[axis] *= f
        report = retarget_report(model.mesh, size, name=name)
        before = testmodels.measure(model.mesh, model.probes[axis])
        after = testmodels.measure(report.mesh, model.probes[axis])
        scaled = testmodels.measure(scale_to(model.mesh, size), model.probes[axis])
        caption = [f"{name}: {'xyz'[axis]} x{f:g}: {before['count']} -> {after['count']} elements of "
                   f"{np.median(after['sizes']):.3g} (input {np.median(before['sizes']):.3g}; plain "
                   f"scaling: {scaled['count']} of {np.median(scaled['sizes']):.3g}); "
                   f"{report.stats['nodes']} voxels, {report.stats['labels']} labels, "
                   f"{len(report.mesh.faces)} triangles, watertight {report.mesh.is_watertight}"]
        out[f"retarget_{name}.png"] = _small_png(before_after_image(model.mesh, report.mesh,
                                                                    size=(760, 300), caption=caption))
    name, axis, f = EXPLAIN
    model = testmodels.build(name)
    size = np.asarray(model.mesh.extents, dtype=np.float64).copy()
    size[axis] *= f
    report = retarget_report(model.mesh, size, name=name)
    out["retarget_explain.png"] = _small_png(explain_image(report, size=(760, 340)))
    return out


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1:
        print("usage: python -m grammarkit_retarget.gallery OUT_DIR", file=sys.stderr)
        return 2
    from grammarkit.run import write_files

    folder = Path(args[0])
    files = {folder / name: data for name, data in pictures().items()}
    write_files(files)
    for path, data in files.items():
        print(f"wrote {path} ({len(data) // 1024} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
