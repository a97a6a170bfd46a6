"""Per-part test models for the retargeter: each part its own closed mesh, parts touching (and
sharing edges) where they meet, as a segmented model from a modelling tool comes. They differ
from `testmodels` (unions built for the project's own tests) in design and proportions, so the
tests and the benchmark also see models the method was not tuned on.

- `slat_fence`: 12 pickets at 0.3625 on two rails between two posts standing on footings of the
  same footprint (the posts and footings share their edges);
- `cabinet`: a bookshelf of 3 columns x 4 shelves standing on a plinth of its own footprint;
- `ladder`: two stiles and 9 rungs at 0.3 (rung ends flush with the stiles' faces);
- `window_facade`: a 6 x 4 grid of windows (bays 1.0, storeys 2.2, windows 0.6 x 1.38) in a
  wall standing on a base course and topped by a parapet, both of the wall's footprint;
- `balustrade`: 10 square balusters at 0.25 on a plinth rail, under a handrail;
- `long_row`: 30 blocks at 0.2 on a beam (the row of more than 13 elements that a minimum
  offset length of 7.5% of the longest side would skip);
- `storey_facade`: 7 storeys of unequal heights (a 3.6 ground floor with shop windows, five
  3.0 storeys, a 2.4 attic) of 5 bays at 1.4, windows half a bay wide (so a window's left
  jamb lands on its right jamb half a bay on: a translation that maps faces onto faces
  turned the other way), sills 0.05 tall as parts of their own;
- `picket_row`: 30 pickets at 0.15 on two rails between two posts;
- `cubby_shelf`: 6 x 2 cubbies, each a closed box of its own open at the front, neighbours
  sharing whole faces and edges, on a plinth;
- `staircase`: 8 treads between two sloping stringers (the repeat runs along the slope);
- `unequal_shelf`: a bookcase whose bottom and top compartments differ from the regular ones;
- `arcade_facade`: an arcade ground floor at twice the pitch of the windows above it.

Each model is a `trimesh.Scene` with one node per part (`TestModel.scene`) and, for measuring,
the union of its parts (`TestModel.mesh`); the probes are those of `testmodels.Probe`.
"""
from __future__ import annotations

from typing import Callable

import manifold3d as m3
import numpy as np
import trimesh

from .testmodels import Probe, TestModel

__all__ = ["PART_MODELS", "build_parts", "main", "scene_of", "union_of", "write_part_models"]


def _box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return trimesh.creation.box(extents=hi - lo,
                                transform=trimesh.transformations.translation_matrix((lo + hi) / 2))


def _manifold(mesh: trimesh.Trimesh) -> m3.Manifold:
    m = m3.Mesh(vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float32),
                tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint32))
    m.merge()
    return m3.Manifold(m)


def _from_manifold(solid: m3.Manifold) -> trimesh.Trimesh:
    out = solid.to_mesh()
    return trimesh.Trimesh(np.asarray(out.vert_properties, dtype=np.float64)[:, :3],
                           np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3), process=False)


def scene_of(parts: list[tuple[str, trimesh.Trimesh, str]]) -> trimesh.Scene:
    """A scene with one node per part (name, mesh, colour)."""
    scene = trimesh.Scene()
    for name, mesh, color in parts:
        mesh = mesh.copy()
        rgb = [int(color.lstrip("#")[i:i + 2], 16) for i in (0, 2, 4)] + [255]
        mesh.visual.face_colors = np.tile(np.array(rgb, np.uint8), (len(mesh.faces), 1))
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    return scene


def union_of(parts: list[tuple[str, trimesh.Trimesh, str]]) -> trimesh.Trimesh:
    """The union of the parts as one closed mesh (for measuring with probes)."""
    solid = m3.Manifold.batch_boolean([_manifold(m) for _, m, _ in parts], m3.OpType.Add)
    return _from_manifold(solid)


def _model(name, parts, generators, probes, description) -> TestModel:
    model = TestModel(name, union_of(parts), generators, probes, description)
    model.scene = scene_of(parts)  # type: ignore[attr-defined]
    return model


def slat_fence() -> TestModel:
    pickets, pitch, post = 12, 0.3625, 0.12
    length = 2 * post + pickets * pitch
    parts = []
    for k, x in enumerate((0.0, length - post)):
        parts.append((f"footing{k}", _box((x, 0, 0), (x + post, post, 0.2)), "#777777"))
        parts.append((f"post{k}", _box((x, 0, 0.2), (x + post, post, 1.3)), "#6b4a2f"))
    for k, (z, h) in enumerate(((0.45, 0.1), (1.0, 0.07))):
        parts.append((f"rail{k}", _box((post, 0.07, z), (length - post, 0.11, z + h)), "#7d5a3a"))
    for i in range(pickets):
        x = post + 0.13 + i * pitch
        parts.append((f"picket{i}", _box((x, 0.04, 0.3), (x + 0.1, 0.07, 1.2)), "#e8dcc4"))
    return _model("slat_fence", parts, [np.array([pitch, 0, 0])],
                  {0: Probe(0, (0.0, 0.055, 0.8), "solid")},
                  "12 pickets at 0.3625 between two posts on footings")


def cabinet() -> TestModel:
    cols, rows, col_w, row_h, board, depth = 3, 4, 0.5, 0.4, 0.025, 0.32
    width, height = cols * col_w + board, rows * row_h + board
    parts = [("plinth", _box((0, 0, 0), (width, depth, 0.08)), "#5a3d22")]
    for i in range(cols + 1):
        parts.append((f"side{i}", _box((i * col_w, 0, 0.08), (i * col_w + board, depth,
                                                               0.08 + height)), "#a0703c"))
    for j in range(rows + 1):
        parts.append((f"shelf{j}", _box((board, 0, 0.08 + j * row_h),
                                        (width - board, depth - 0.01, 0.08 + j * row_h + board)),
                      "#b07c45"))
    parts.append(("back", _box((board, depth - 0.01, 0.08), (width - board, depth, 0.08 + height)),
                  "#8a5f33"))
    return _model("cabinet", parts, [np.array([col_w, 0, 0]), np.array([0, 0, row_h])],
                  {0: Probe(0, (0.0, 0.15, 0.08 + 0.1 + row_h / 2), "gap"),
                   2: Probe(2, (col_w / 2, 0.15, 0.0), "gap")},
                  "3 columns x 4 shelves on a plinth")


def ladder() -> TestModel:
    rungs, pitch, stile = 9, 0.3, 0.06
    width, height = 0.5, 0.15 + rungs * pitch
    parts = [(f"stile{k}", _box((x, 0, 0), (x + stile, 0.08, height)), "#8b6b47")
             for k, x in enumerate((0.0, width - stile))]
    for i in range(rungs):
        z = 0.25 + i * pitch
        parts.append((f"rung{i}", _box((stile, 0.02, z), (width - stile, 0.06, z + 0.04)), "#b89466"))
    return _model("ladder", parts, [np.array([0, 0, pitch])],
                  {2: Probe(2, (width / 2, 0.04, 0.0), "solid")}, "two stiles and 9 rungs")


def window_facade() -> TestModel:
    bays, storeys, bay_w, storey_h, base_h = 6, 4, 1.0, 2.2, 0.4
    win_w, win_h, sill_z = 0.6, 1.38, 0.5
    width, depth = bays * bay_w, 0.3
    top = base_h + storeys * storey_h
    wall = _manifold(_box((0, 0, base_h), (width, depth, top)))
    holes = [_manifold(_box((i * bay_w + 0.2, -0.01, base_h + j * storey_h + sill_z),
                            (i * bay_w + 0.2 + win_w, 0.12, base_h + j * storey_h + sill_z + win_h)))
             for i in range(bays) for j in range(storeys)]
    parts = [("base", _box((0, 0, 0), (width, depth, base_h)), "#8f8373"),
             ("wall", _from_manifold(wall - m3.Manifold.batch_boolean(holes, m3.OpType.Add)), "#d9c8a9"),
             ("parapet", _box((0, 0, top), (width, depth, top + 0.5)), "#b5a68a")]
    for i in range(bays):
        for j in range(storeys):
            z = base_h + j * storey_h + sill_z - 0.06
            parts.append((f"sill{i}_{j}", _box((i * bay_w + 0.15, -0.06, z),
                                               (i * bay_w + 0.25 + win_w, 0.0, z + 0.06)), "#9a9a9a"))
    return _model("window_facade", parts, [np.array([bay_w, 0, 0]), np.array([0, 0, storey_h])],
                  # probe points are relative to the bounding box minimum (0, -0.06, 0): the
                  # lines run 0.05 behind the wall's face, through the window recesses
                  {0: Probe(0, (0.0, 0.11, base_h + sill_z + 0.7), "gap"),
                   2: Probe(2, (0.5, 0.11, 0.0), "gap")},
                  "a 6 x 4 grid of windows on a base course, under a parapet")


def balustrade() -> TestModel:
    balusters, pitch, post = 10, 0.25, 0.16
    length = 2 * post + balusters * pitch
    parts = [(f"newel{k}", _box((x, 0, 0), (x + post, post, 1.0)), "#5b4636")
             for k, x in enumerate((0.0, length - post))]
    parts.append(("plinth", _box((post, 0.02, 0), (length - post, 0.14, 0.12)), "#6e5442"))
    parts.append(("handrail", _box((post, 0.02, 0.85), (length - post, 0.14, 0.93)), "#6e5442"))
    for i in range(balusters):
        x = post + 0.085 + i * pitch
        parts.append((f"baluster{i}", _box((x, 0.05, 0.12), (x + 0.08, 0.11, 0.85)), "#ddd2c0"))
    return _model("balustrade", parts, [np.array([pitch, 0, 0])],
                  {0: Probe(0, (0.0, 0.08, 0.5), "solid")}, "10 square balusters between newels")


def long_row() -> TestModel:
    blocks, pitch = 30, 0.2
    length = 0.1 + blocks * pitch
    parts = [("beam", _box((0, 0, 0), (length, 0.2, 0.1)), "#777777")]
    for i in range(blocks):
        x = 0.1 + i * pitch
        parts.append((f"block{i}", _box((x, 0.05, 0.1), (x + 0.1, 0.15, 0.3)), "#c46a4a"))
    return _model("long_row", parts, [np.array([pitch, 0, 0])],
                  {0: Probe(0, (0.0, 0.1, 0.2), "solid")}, "30 blocks at 0.2 on a beam")


def storey_facade() -> TestModel:
    bays, bay_w, depth, base_h = 5, 1.4, 0.35, 0.3
    # (storey height, sill height, window height, window width) from the ground up
    storeys = [(3.6, 0.4, 2.4, 1.0)] + [(3.0, 0.8, 1.6, 0.7)] * 5 + [(2.4, 0.7, 0.9, 0.7)]
    width, z, holes, sills = bays * bay_w, base_h, [], []
    for j, (h, sill, win_h, win_w) in enumerate(storeys):
        for i in range(bays):
            x = i * bay_w + (bay_w - win_w) / 2
            holes.append(_manifold(_box((x, -0.01, z + sill), (x + win_w, 0.14, z + sill + win_h))))
            if j > 0:
                sills.append((f"sill{i}_{j}", _box((x - 0.05, -0.05, z + sill - 0.05),
                                                   (x + win_w + 0.05, 0.0, z + sill)), "#999999"))
        z += h
    wall = _manifold(_box((0, 0, base_h), (width, depth, z)))
    parts = [("plinth", _box((0, 0, 0), (width, depth, base_h)), "#776655"),
             ("wall", _from_manifold(wall - m3.Manifold.batch_boolean(holes, m3.OpType.Add)), "#ddccaa"),
             ("cornice", _box((0, 0, z), (width, depth, z + 0.4)), "#bbaa88")] + sills
    # probe points relative to the bounding box minimum (0, -0.05, 0), through the recesses
    return _model("storey_facade", parts, [np.array([bay_w, 0, 0]), np.array([0, 0, 3.0])],
                  {0: Probe(0, (0.0, 0.12, base_h + 3.6 + 1.6), "gap"),
                   2: Probe(2, (0.7, 0.12, 0.0), "gap")},
                  "7 storeys of unequal heights, 5 bays, windows half a bay wide")


def picket_row() -> TestModel:
    pickets, pitch, post = 30, 0.15, 0.1
    length = 2 * post + pickets * pitch
    parts = [(f"post{k}", _box((x, 0, 0), (x + post, post, 1.1)), "#654321")
             for k, x in enumerate((0.0, length - post))]
    for k, z in enumerate((0.2, 0.8)):
        parts.append((f"rail{k}", _box((post, 0.06, z), (length - post, 0.1, z + 0.06)), "#7d5a3a"))
    for i in range(pickets):
        x = post + 0.035 + i * pitch
        parts.append((f"picket{i}", _box((x, 0.03, 0.1), (x + 0.08, 0.06, 1.0)), "#eeeeee"))
    return _model("picket_row", parts, [np.array([pitch, 0, 0])],
                  {0: Probe(0, (0.0, 0.045, 0.5), "solid")}, "30 pickets at 0.15 between two posts")


def cubby_shelf() -> TestModel:
    cols, rows, w, h, depth, board = 6, 2, 0.38, 0.34, 0.3, 0.02
    parts = [("plinth", _box((0, 0, 0), (cols * w, depth, 0.06)), "#444444")]
    for i in range(cols):
        for j in range(rows):
            lo = np.array([i * w, 0, 0.06 + j * h])
            hi = lo + [w, depth, h]
            box = _manifold(_box(lo, hi)) - _manifold(_box(lo + [board, -0.01, board], hi - board))
            parts.append((f"cubby{i}_{j}", _from_manifold(box), "#c8a070"))
    return _model("cubby_shelf", parts, [np.array([w, 0, 0]), np.array([0, 0, h])],
                  {0: Probe(0, (0.0, 0.15, 0.06 + h / 2), "gap"),
                   2: Probe(2, (w / 2, 0.15, 0.0), "gap")},
                  "6 x 2 cubbies, each its own closed box, sharing faces and edges")


def staircase(treads: int = 8) -> TestModel:
    """`treads` treads (run 0.28, rise 0.18) between two sloping stringers: the repetition
    runs along the slope, one offset with both a run and a rise."""
    run, rise, width, side = 0.28, 0.18, 1.0, 0.05
    length, height = treads * run, treads * rise
    parts = []
    for k, (y0, y1) in enumerate(((0.0, side), (width - side, width))):
        pts = [(x, y, z) for y in (y0, y1) for x, z in ((0.0, -0.3), (0.0, 0.05),
                                                        (length, height - 0.3), (length, height + 0.05))]
        parts.append((f"stringer{k}", trimesh.convex.convex_hull(np.array(pts, dtype=np.float64)), "#5b4636"))
    for i in range(treads):
        x, z = i * run, (i + 1) * rise - 0.04
        parts.append((f"tread{i}", _box((x, side, z), (x + run, width - side, z + 0.04)), "#c8a070"))
    return _model("staircase", parts, [np.array([run, 0, rise])], {},
                  f"{treads} treads (run 0.28, rise 0.18) between sloping stringers")


def unequal_shelf() -> TestModel:
    """A bookcase of 3 columns whose compartments differ in height: a 0.42 bottom one, three
    regular 0.30 ones, a 0.24 top one (boards 0.02 between them, uprights cut per compartment)."""
    cols, col_w, board, depth, plinth = 3, 0.5, 0.02, 0.3, 0.08
    heights = [0.42, 0.30, 0.30, 0.30, 0.24]
    width = cols * (col_w + board) + board
    parts = [("plinth", _box((0, 0, 0), (width, depth, plinth)), "#444444")]
    z = plinth
    for j, h in enumerate(heights + [None]):
        parts.append((f"board{j}", _box((0, 0, z), (width, depth, z + board)), "#b07c45"))
        z += board
        if h is None:
            break
        for i in range(cols + 1):
            x = i * (col_w + board)
            parts.append((f"upright{i}_{j}", _box((x, 0, z), (x + board, depth, z + h)), "#a0703c"))
        z += h
    pitch_x, pitch_z = col_w + board, 0.30 + board
    return _model("unequal_shelf", parts, [np.array([pitch_x, 0, 0]), np.array([0, 0, pitch_z])],
                  {0: Probe(0, (0.0, 0.15, plinth + board + 0.2), "gap"),
                   2: Probe(2, (board + col_w / 2, 0.15, 0.0), "gap")},
                  "3 columns of compartments 0.42, 3 x 0.30 and 0.24 tall")


def arcade_facade() -> TestModel:
    """A facade whose ground floor differs in pitch as well as height: 3 arcade openings
    (2.0 x 3.0) at 2.8 under 4 storeys of 6 windows (0.7 x 1.5) at 1.4, so the whole facade
    repeats only every 2.8 across while the storeys repeat every 3.0 up."""
    bays, bay_w, depth, base_h, ground_h, storey_h, storeys = 6, 1.4, 0.35, 0.3, 4.0, 3.0, 4
    width = bays * bay_w
    top = base_h + ground_h + storeys * storey_h
    holes, sills = [], []
    for i in range(bays // 2):
        x = i * 2 * bay_w + 0.4
        holes.append(_manifold(_box((x, -0.01, base_h), (x + 2.0, 0.15, base_h + 3.0))))
    for j in range(storeys):
        z = base_h + ground_h + j * storey_h + 0.8
        for i in range(bays):
            x = i * bay_w + 0.35
            holes.append(_manifold(_box((x, -0.01, z), (x + 0.7, 0.15, z + 1.5))))
            sills.append((f"sill{i}_{j}", _box((x - 0.05, -0.05, z - 0.05), (x + 0.75, 0.0, z)), "#999999"))
    wall = _manifold(_box((0, 0, base_h), (width, depth, top)))
    parts = [("plinth", _box((0, 0, 0), (width, depth, base_h)), "#776655"),
             ("wall", _from_manifold(wall - m3.Manifold.batch_boolean(holes, m3.OpType.Add)), "#ddccaa"),
             ("cornice", _box((0, 0, top), (width, depth, top + 0.4)), "#bbaa88")] + sills
    # probe points relative to the bounding box minimum (0, -0.05, 0): x through the upper
    # windows of the first storey, z through the first bay's windows
    return _model("arcade_facade", parts, [np.array([2 * bay_w, 0, 0]), np.array([0, 0, storey_h])],
                  {0: Probe(0, (0.0, 0.12, base_h + ground_h + 0.8 + 0.75), "gap"),
                   2: Probe(2, (0.7, 0.12, 0.0), "gap")},
                  "an arcade ground floor (3 openings at 2.8) under 4 storeys of 6 windows at 1.4")


PART_MODELS: dict[str, Callable[[], TestModel]] = {
    "slat_fence": slat_fence, "cabinet": cabinet, "ladder": ladder,
    "window_facade": window_facade, "balustrade": balustrade, "long_row": long_row,
    "storey_facade": storey_facade, "picket_row": picket_row, "cubby_shelf": cubby_shelf,
    "staircase": staircase, "unequal_shelf": unequal_shelf, "arcade_facade": arcade_facade,
}


def build_parts(name: str) -> TestModel:
    """The per-part model called `name` (one of `PART_MODELS`); `.scene` holds its parts."""
    try:
        return PART_MODELS[name]()
    except KeyError:
        raise KeyError(f"no per-part model {name!r}; known: {', '.join(PART_MODELS)}") from None


def write_part_models(folder, names: list[str] | None = None) -> list:
    """Write the per-part models as GLB files (one node per part) into `folder`, all or none."""
    from pathlib import Path

    from grammarkit.run import write_files

    folder = Path(folder)
    files = {folder / f"{name}.glb": trimesh.exchange.gltf.export_glb(build_parts(name).scene)
             for name in names or list(PART_MODELS)}
    write_files(files)
    return list(files)


def main(argv: list[str] | None = None) -> int:
    import sys

    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1:
        print("usage: python -m grammarkit_retarget.partmodels OUT_DIR", file=sys.stderr)
        return 2
    for path in write_part_models(args[0]):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
