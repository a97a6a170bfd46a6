"""A small Wave-Function-Collapse-style tile set ("coast") and tilings of it.

    python grammars/tiling/wfc/make_coast.py [--out grammars/tiling/wfc]

Three tiles on a unit grid, each an octagonal plate (chamfered corners, so that diagonal
neighbours do not touch and face neighbours share a whole face):
- Grass: 0.2 high, the same on every side;
- Water: 0.1 high, the same on every side;
- Shore: slopes from 0.2 (its south side, -y: grass) to 0.1 (its north side, +y: water); its
  east and west sides meet other shores.

The adjacency rules, per side (as a WFC tile set states them): a grass side meets grass or a
shore's south side; a water side meets water or a shore's north side; a shore's east side meets
a shore's west side. A valid tiling is a coast: grass rows, one shore row, water rows, turned
by any multiple of 90 degrees as a whole. `coast(nx, ny, h, turn)` builds one; written files:
`tiles.glb` (one of each tile, for `part ... = mesh(...)`), `coast_*.glb` (tilings) and the
hand-written grammar `coast.grammar` stays as it is. Output is deterministic.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import trimesh

from grammarkit.tiling import Assembly, Part, write_assembly

CHAMFER = 0.15
GRASS_H, WATER_H = 0.2, 0.1


def _octagon() -> np.ndarray:
    a, c = 0.5, 0.5 - CHAMFER
    return np.array([(a, -c), (a, c), (c, a), (-c, a), (-a, c), (-a, -c), (-c, -a), (c, -a)])


def _plate(top) -> trimesh.Trimesh:  # noqa: ANN001
    """An octagonal plate from z=0 up to top(x, y) (a plane), as a closed convex mesh."""
    ring = _octagon()
    pts = [(x, y, 0.0) for x, y in ring] + [(x, y, float(top(x, y))) for x, y in ring]
    return trimesh.convex.convex_hull(np.array(pts))


def tiles() -> dict[str, trimesh.Trimesh]:
    return {
        "Grass": _plate(lambda x, y: GRASS_H),
        "Water": _plate(lambda x, y: WATER_H),
        "Shore": _plate(lambda x, y: GRASS_H - (GRASS_H - WATER_H) * (y + 0.5)),
    }


def _turn(deg: float, about=(0.0, 0.0)) -> np.ndarray:  # noqa: ANN001
    T = trimesh.transformations.rotation_matrix(math.radians(deg), (0, 0, 1), point=(*about, 0.0))
    return T


def coast(nx: int, ny: int, h: int, turn: int = 0, name: str | None = None,
          protos: dict[str, trimesh.Trimesh] | None = None) -> Assembly:
    """An nx x ny grid: rows y < h grass, row h shore (water to the north), rows y > h water;
    then the whole tiling turned by `turn` degrees (a multiple of 90) about the grid's centre."""
    protos = protos or tiles()
    whole = _turn(turn, (nx / 2, ny / 2))
    parts, counts = [], {}
    for j in range(ny):
        for i in range(nx):
            t = "Grass" if j < h else "Shore" if j == h else "Water"
            T = whole @ trimesh.transformations.translation_matrix((i + 0.5, j + 0.5, 0.0))
            k = counts.get(t, 0)
            counts[t] = k + 1
            mesh = protos[t].copy()
            mesh.apply_transform(T)
            parts.append(Part(f"{t}.{k}", t, mesh, T))
    return Assembly(parts, name=name or f"coast_{nx}x{ny}_h{h}_r{turn}")


# the tilings a grammar is learned from, and held-out ones it must accept
TRAINING = [(6, 5, 2, 0), (5, 6, 3, 90), (7, 4, 1, 180), (4, 7, 2, 270), (6, 6, 3, 0)]
HELD_OUT = [(8, 5, 3, 90), (5, 5, 1, 0), (9, 3, 1, 180), (3, 9, 4, 270), (1, 4, 2, 0), (10, 6, 0, 90)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args(argv)
    protos = tiles()
    parts = [Part(f"{t}.0", t, m.copy(), np.eye(4)) for t, m in protos.items()]
    write_assembly(Assembly(parts, name="tiles"), args.out / "tiles.glb")
    for nx, ny, h, turn in TRAINING[:2]:
        a = coast(nx, ny, h, turn, protos=protos)
        write_assembly(a, args.out / f"{a.name}.glb")
    return 0


if __name__ == "__main__":
    sys.exit(main())
