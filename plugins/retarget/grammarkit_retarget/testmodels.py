"""Structured test models for the retargeter, with the offsets that generated them and probes
that count and measure their repeated elements.

Five models (z up, metres), each a watertight union of boxes and turned solids built with
manifold3d, coloured per part:

- `facade_panel`: a wall with a 5 x 3 grid of recessed windows (bays 1.2 wide, storeys 1.5 high),
  sills, end pilasters, a base course and a cornice;
- `picket_fence`: 12 pickets at 0.25 between two posts, on a bottom and a (lighter) top rail;
- `bookshelf`: 4 compartments (0.42) x 5 shelves (0.36), a back panel and a plinth;
- `railing`: 9 turned balusters at 0.3 between two newel posts, handrail and bottom rail;
- `tiled_floor`: 10 x 8 raised tiles at 0.3 on a slab with a skirting frame.

Every repeat is more than 0.15 of the normalised size apart (the paper's minimum offset tau),
so the generating offsets are what the method should find.

`Probe`s measure a model along one line: the solid intervals (or the gaps between them) that
the line crosses, without the first and last one (the end posts, frames, margins). Tests and the
benchmark use them to count elements and measure their sizes before and after retargeting.

Write the models as GLB files with `python -m grammarkit_retarget.testmodels OUT_DIR`.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import manifold3d as m3
import numpy as np
import trimesh

__all__ = ["MODELS", "Probe", "TestModel", "arched_facade", "bench_model", "build", "measure",
           "write_models"]


@dataclass(frozen=True)
class Probe:
    """A line parallel to world axis `axis` through `point` (relative to the model's bounding
    box minimum); `kind` says whether the elements are the solid intervals the line crosses
    ("solid", e.g. pickets) or the gaps between them ("gap", e.g. window openings)."""

    axis: int
    point: tuple[float, float, float]
    kind: str = "solid"


@dataclass
class TestModel:
    name: str
    mesh: trimesh.Trimesh
    generators: list[np.ndarray]  # the offsets that generated the repetition (world units)
    probes: dict[int, Probe] = field(default_factory=dict)  # structured world axis -> probe
    description: str = ""

    @property
    def structured_axes(self) -> list[int]:
        return sorted(self.probes)


# ------------------------------------------------------------------------------------------
# Construction helpers
# ------------------------------------------------------------------------------------------
def _box(lo, hi) -> m3.Manifold:
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    return m3.Manifold.cube(tuple(hi - lo)).translate(tuple(lo))


class _Parts:
    """Collects solids by colour; `mesh()` unions them and colours each face by its part."""

    def __init__(self) -> None:
        self.solids: list[m3.Manifold] = []
        self.colors: dict[int, tuple[int, int, int]] = {}

    def add(self, solid: m3.Manifold, color: str) -> None:
        solid = solid.as_original()
        rgb = tuple(int(color.lstrip("#")[i:i + 2], 16) for i in (0, 2, 4))
        self.colors[solid.original_id()] = rgb
        self.solids.append(solid)

    def mesh(self, name: str) -> trimesh.Trimesh:
        union = m3.Manifold.batch_boolean(self.solids, m3.OpType.Add)
        out = union.to_mesh()
        verts = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
        faces = np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3)
        run_index = np.asarray(out.run_index, dtype=np.int64)
        run_ids = np.asarray(out.run_original_id, dtype=np.int64)
        colors = np.full((len(faces), 4), 255, dtype=np.uint8)
        for r, oid in enumerate(run_ids):
            colors[run_index[r] // 3:run_index[r + 1] // 3, :3] = self.colors.get(int(oid), (200, 200, 200))
        mesh = trimesh.Trimesh(verts, faces, process=False, metadata={"name": name})
        mesh.visual.face_colors = colors
        return mesh


def _turned(profile: list[tuple[float, float]], segments: int) -> m3.Manifold:
    """A solid of revolution about z from a (radius, z) profile (a baluster)."""
    pts = [(0.0, profile[0][1])] + [tuple(p) for p in profile] + [(0.0, profile[-1][1])]
    section = m3.CrossSection([pts])
    return m3.Manifold.revolve(section, circular_segments=segments)


def _baluster_profile(points: int, height: float, radius: float) -> list[tuple[float, float]]:
    """A turned baluster: a vase bulging in its lower half, a collar near the top (z from 0);
    nothing along it repeats."""
    t = np.linspace(0.0, 1.0, max(points, 4))
    r = radius * (0.55 + 0.45 * np.sin(np.pi * t ** 1.5) ** 2
                  + 0.25 * np.exp(-((t - 0.85) / 0.04) ** 2))
    r[0] = r[-1] = radius
    return [(float(ri), float(zi)) for ri, zi in zip(r, t * height)]


# ------------------------------------------------------------------------------------------
# The five models
# ------------------------------------------------------------------------------------------
def facade_panel() -> TestModel:
    p = _Parts()
    bays, storeys, bay_w, storey_h, base_h = 5, 3, 1.2, 1.5, 0.3
    width, depth = bays * bay_w, 0.3
    top = base_h + storeys * storey_h
    wall = _box((0, 0, 0), (width, depth, top))
    holes = [_box((i * bay_w + 0.25, -0.01, base_h + j * storey_h + 0.35),
                  (i * bay_w + 0.95, 0.15, base_h + j * storey_h + 1.25))
             for i in range(bays) for j in range(storeys)]
    p.add(wall - m3.Manifold.batch_boolean(holes, m3.OpType.Add), "#d9c8a9")
    for i in range(bays):
        for j in range(storeys):
            z = base_h + j * storey_h + 0.29
            p.add(_box((i * bay_w + 0.18, -0.08, z), (i * bay_w + 1.02, 0.02, z + 0.06)), "#9a9a9a")
    p.add(_box((0, -0.05, 0), (width, depth, base_h)), "#8f8373")                 # base course
    p.add(_box((-0.1, -0.12, top), (width + 0.1, depth, top + 0.2)), "#b5a68a")     # cornice
    for x in (-0.1, width - 0.1):                                                   # pilasters
        p.add(_box((x, -0.05, 0), (x + 0.2, depth, top)), "#c9b797")
    return TestModel("facade_panel", p.mesh("facade_panel"),
                     [np.array([bay_w, 0, 0]), np.array([0, 0, storey_h])],
                     # probe points are relative to the bounding box minimum (-0.1, -0.12, 0)
                     {0: Probe(0, (0.0, 0.19, base_h + 0.8), "gap"),
                      2: Probe(2, (0.1 + 0.6, 0.19, 0.0), "gap")},
                     "a wall with a 5 x 3 grid of recessed windows")


def picket_fence() -> TestModel:
    p = _Parts()
    pickets, pitch, post_w = 12, 0.25, 0.1
    length = post_w + pickets * pitch + post_w
    for x in (0.0, length - post_w):
        p.add(_box((x, -0.035, 0), (x + post_w, 0.065, 1.2)), "#6b4a2f")
    # a heavier bottom rail than top rail (two equal rails would be a second repetition)
    for z, half in ((0.3, 0.045), (0.8, 0.03)):
        p.add(_box((post_w - 0.01, 0.03, z - half), (length - post_w + 0.01, 0.07, z + half)), "#7d5a3a")
    for i in range(pickets):
        x = post_w + 0.085 + i * pitch
        body = _box((x, 0.0, 0.05), (x + 0.08, 0.03, 1.0))
        cap = m3.Manifold.hull_points([(x, 0.0, 1.0), (x + 0.08, 0.0, 1.0), (x, 0.03, 1.0),
                                       (x + 0.08, 0.03, 1.0), (x + 0.04, 0.015, 1.08)])
        p.add(body + cap, "#e8dcc4")
    return TestModel("picket_fence", p.mesh("picket_fence"), [np.array([pitch, 0, 0])],
                     {0: Probe(0, (0.0, 0.05, 0.55), "solid")}, "12 pickets between two posts")


def bookshelf() -> TestModel:
    p = _Parts()
    cols, rows, col_w, row_h, board, depth = 4, 5, 0.42, 0.36, 0.03, 0.35
    width, height = cols * col_w + board, rows * row_h + board
    for i in range(cols + 1):
        p.add(_box((i * col_w, 0, 0), (i * col_w + board, depth, height)), "#a0703c")
    for j in range(rows + 1):
        p.add(_box((0, 0, j * row_h), (width, depth, j * row_h + board)), "#b07c45")
    p.add(_box((0, depth - 0.01, 0), (width, depth, height)), "#8a5f33")            # back panel
    p.add(_box((0.02, 0.02, -0.1), (width - 0.02, depth - 0.01, 0)), "#6f4a26")    # plinth
    return TestModel("bookshelf", p.mesh("bookshelf"),
                     [np.array([col_w, 0, 0]), np.array([0, 0, row_h])],
                     {0: Probe(0, (0.0, 0.15, 0.1 + row_h / 2), "solid"),
                      2: Probe(2, (col_w / 2, 0.15, 0.0), "solid")},
                     "4 compartments x 5 shelves")


def railing(*, segments: int = 24, profile_points: int = 12) -> TestModel:
    p = _Parts()
    balusters, pitch, post_w = 9, 0.3, 0.12
    length = 3.0
    for x in (0.0, length - post_w):
        p.add(_box((x, -0.06, 0), (x + post_w, 0.06, 1.1)), "#5b4636")
    p.add(_box((post_w - 0.01, -0.04, 0.95), (length - post_w + 0.01, 0.04, 1.0)), "#6e5442")
    p.add(_box((post_w - 0.01, -0.03, 0.1), (length - post_w + 0.01, 0.03, 0.15)), "#6e5442")
    profile = _baluster_profile(profile_points, 0.8, 0.025)
    shape = _turned(profile, segments)
    for i in range(balusters):
        p.add(shape.translate((post_w + 0.18 + i * pitch, 0.0, 0.15)), "#ddd2c0")
    name = "railing"
    return TestModel(name, p.mesh(name), [np.array([pitch, 0, 0])],
                     {0: Probe(0, (0.0, 0.06, 0.55), "solid")},
                     "9 turned balusters between two newel posts")


def tiled_floor() -> TestModel:
    p = _Parts()
    nx, ny, pitch, gap, frame = 10, 8, 0.3, 0.03, 0.06
    sx, sy = nx * pitch + gap, ny * pitch + gap
    p.add(_box((-frame, -frame, 0), (sx + frame, sy + frame, 0.04)), "#d8d4cc")
    for lo, hi in (((-frame, -frame), (sx + frame, 0)), ((-frame, sy), (sx + frame, sy + frame)),
                   ((-frame, -frame), (0, sy + frame)), ((sx, -frame), (sx + frame, sy + frame))):
        p.add(_box((lo[0], lo[1], 0.04), (hi[0], hi[1], 0.1)), "#7a6a5a")
    for i in range(nx):
        for j in range(ny):
            x, y = gap + i * pitch, gap + j * pitch
            p.add(_box((x, y, 0.04), (x + pitch - gap, y + pitch - gap, 0.06)), "#c46a4a")
    return TestModel("tiled_floor", p.mesh("tiled_floor"),
                     [np.array([pitch, 0, 0]), np.array([0, pitch, 0])],
                     {0: Probe(0, (0.0, frame + gap + 0.1, 0.05), "solid"),
                      1: Probe(1, (frame + gap + 0.1, 0.0, 0.05), "solid")},
                     "10 x 8 tiles inside a skirting frame")


MODELS: dict[str, Callable[[], TestModel]] = {
    "facade_panel": facade_panel,
    "picket_fence": picket_fence,
    "bookshelf": bookshelf,
    "railing": railing,
    "tiled_floor": tiled_floor,
}


def build(name: str) -> TestModel:
    """The test model called `name` (one of `MODELS`)."""
    try:
        return MODELS[name]()
    except KeyError:
        raise KeyError(f"no test model {name!r}; known: {', '.join(MODELS)}") from None


def arched_facade(*, segments: int = 32) -> TestModel:
    """The facade panel with round-arched window openings (`segments` per full circle)."""
    p = _Parts()
    bays, storeys, bay_w, storey_h, base_h = 5, 3, 1.2, 1.5, 0.3
    width, depth = bays * bay_w, 0.3
    top = base_h + storeys * storey_h
    wall = _box((0, 0, 0), (width, depth, top))
    arch = m3.Manifold.cylinder(0.16, 0.35, 0.35, circular_segments=segments)
    arch = arch.rotate((-90.0, 0.0, 0.0))  # axis along +y, from y = 0 to 0.16
    holes = []
    for i in range(bays):
        for j in range(storeys):
            x0, z0 = i * bay_w + 0.25, base_h + j * storey_h + 0.35
            holes.append(_box((x0, -0.01, z0), (x0 + 0.7, 0.15, z0 + 0.55)))
            holes.append(arch.translate((x0 + 0.35, -0.01, z0 + 0.55)))
    p.add(wall - m3.Manifold.batch_boolean(holes, m3.OpType.Add), "#d9c8a9")
    for i in range(bays):
        for j in range(storeys):
            z = base_h + j * storey_h + 0.29
            p.add(_box((i * bay_w + 0.18, -0.08, z), (i * bay_w + 1.02, 0.02, z + 0.06)), "#9a9a9a")
    p.add(_box((0, -0.05, 0), (width, depth, base_h)), "#8f8373")
    p.add(_box((-0.1, -0.12, top), (width + 0.1, depth, top + 0.2)), "#b5a68a")
    for x in (-0.1, width - 0.1):
        p.add(_box((x, -0.05, 0), (x + 0.2, depth, top)), "#c9b797")
    return TestModel("arched_facade", p.mesh("arched_facade"),
                     [np.array([bay_w, 0, 0]), np.array([0, 0, storey_h])],
                     {0: Probe(0, (0.0, 0.19, base_h + 0.6), "gap"),
                      2: Probe(2, (0.1 + 0.6, 0.19, 0.0), "gap")},
                     "a wall with a 5 x 3 grid of round-arched windows")


def bench_model(triangles: int = 50_000) -> TestModel:
    """The benchmark's large model: the arched facade with its arches tessellated finely
    enough for about `triangles` triangles."""
    segments = 32
    model = arched_facade(segments=segments)
    while len(model.mesh.faces) < triangles and segments < 65536:
        segments = int(segments * max(1.05, triangles / len(model.mesh.faces)))
        model = arched_facade(segments=segments)
    model.name = f"arched_facade_{round(len(model.mesh.faces) / 1000)}k"
    return model


# ------------------------------------------------------------------------------------------
# Measuring
# ------------------------------------------------------------------------------------------
def _solid(mesh: trimesh.Trimesh) -> m3.Manifold:
    verts = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    tris = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    m = m3.Mesh(vert_properties=verts, tri_verts=tris)
    m.merge()
    return m3.Manifold(m)


def intervals(mesh: trimesh.Trimesh, probe: Probe, *, origin=None) -> list[tuple[float, float]]:
    """The solid intervals (start, end) along the probe line, sorted, in world coordinates.

    Computed by intersecting the solid with a thin bar along the line (exact, no ray casting):
    each connected piece of the bar is one interval. `origin` replaces the bounding-box
    minimum that the probe point is relative to."""
    lo = np.asarray(mesh.bounds[0] if origin is None else origin, dtype=np.float64)
    hi = np.asarray(mesh.bounds[1], dtype=np.float64)
    point = lo + np.asarray(probe.point, dtype=np.float64)
    a = probe.axis
    eps = 1e-4
    bar_lo, bar_hi = point - eps, point + eps
    bar_lo[a], bar_hi[a] = lo[a] - 1.0, hi[a] + 1.0
    pieces = (_solid(mesh) ^ _box(bar_lo, bar_hi)).decompose()
    spans = []
    for piece in pieces:
        b = piece.bounding_box()
        spans.append((float(b[a]), float(b[a + 3])))
    return sorted(spans)


def measure(mesh: trimesh.Trimesh, probe: Probe, *, origin=None) -> dict:
    """Count and size the repeated elements along a probe line: the interior solid intervals
    (kind "solid") or the gaps between solid intervals (kind "gap"), first and last dropped.
    Returns {"count", "sizes", "pitch" (median start-to-start distance), "intervals"}."""
    spans = intervals(mesh, probe, origin=origin)
    if probe.kind == "solid":
        elems = spans[1:-1]
    else:
        gaps = [(spans[i][1], spans[i + 1][0]) for i in range(len(spans) - 1)]
        elems = [g for g in gaps if g[1] - g[0] > 1e-6]
    sizes = [e[1] - e[0] for e in elems]
    starts = [e[0] for e in elems]
    pitch = float(np.median(np.diff(starts))) if len(starts) > 1 else float("nan")
    return {"count": len(elems), "sizes": sizes, "pitch": pitch, "intervals": spans}


# ------------------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------------------
def write_models(folder: str | Path, names: list[str] | None = None,
                 progress: Callable[[str, int, int], None] | None = None) -> list[Path]:
    """Write the test models as GLB files into `folder` (atomically, all or none).
    `progress(name, done, total)` is called before each model is built and once at the end."""
    from grammarkit.geometry.exporters import exporter_for
    from grammarkit.run import write_files

    folder = Path(folder)
    files = {}
    chosen = names or list(MODELS)
    for k, name in enumerate(chosen):
        if progress is not None:
            progress(name, k, len(chosen))
        model = build(name)
        path = folder / f"{name}.glb"
        files[path] = exporter_for(path).encode(model.mesh)
    if progress is not None:
        progress("", len(chosen), len(chosen))
    write_files(files)
    return list(files)


USAGE = "usage: python -m grammarkit_retarget.testmodels [--json] OUT_DIR"


def main(argv: list[str] | None = None) -> int:
    """Write the models with progress on stderr (rich) and one line per file on stdout (a JSON
    list of {path, triangles, bytes} with --json)."""
    import json

    args = list(sys.argv[1:] if argv is None else argv)
    as_json = "--json" in args
    args = [a for a in args if a != "--json"]
    if len(args) != 1 or args[0].startswith("-"):
        print(USAGE, file=sys.stderr)
        return 2
    from .cli import progress_bar

    bar = progress_bar()
    with bar:
        task = bar.add_task("building", total=len(MODELS))

        def step(name: str, done: int, total: int) -> None:
            bar.update(task, completed=done, total=total,
                       description=f"building {name}" if name else "writing")
        paths = write_models(args[0], progress=step)
    rows = []
    for path in paths:
        mesh = trimesh.load(path, force="mesh")
        rows.append({"path": str(path), "triangles": len(mesh.faces), "bytes": path.stat().st_size})
    if as_json:
        print(json.dumps(rows, indent=1))
        return 0
    for r in rows:
        print(f"wrote {r['path']} ({r['triangles']} triangles)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
