"""Generate the tiling examples: geometry (two example assemblies each) and their grammars.

    /work/venv/bin/python grammars/tiling/make_examples.py [--out grammars/tiling]

Three examples, each written as `<name>/<example>.glb` (one node per part, type in the node's
extras and name, shared meshes for identical parts) plus `<name>/<name>.grammar`:
- castle/   towers, wall segments and gates forming cycles (Kalojanov 2019's castle spirit);
- balltrack/ a downhill ball track with Entry/Exit pieces and pillar columns (Liu 2015);
- facade/   a facade-like grid of wall, window and door panels between ledges.
The grammars are *learned* (`grammarkit.tiling.learn`) from the two examples with exact
neighbourhoods (`neighbors="multisets"`: these are designs whose variants should stay like
them; no `filled` sites for the ball track); the ball track's grammar additionally gets the
hand-added constraint `path(from=Entry, to=Exit, downhill=true)`, which learning cannot guess.

Geometry is chosen so contacts are unambiguous: neighbours touch face to face (wall ends dip
0.08 into the towers' flat faces), and every non-neighbour pair is at least 0.1 apart (the
contact tolerance is 0.001 x the model's diagonal, about 0.03 here). Every part is a closed,
low-poly mesh (boxes and octagonal prisms). Output is deterministic.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import trimesh

from grammarkit.ir import Grammar
from grammarkit.ir.expr import Bool, Ref
from grammarkit.ir.split import Arg
from grammarkit.ir.tiling import ConstraintDef
from grammarkit.printer import print_grammar
from grammarkit.tiling import Assembly, Part, learn, validate, write_assembly
from grammarkit.tiling.io import _atomic_write


def _box(x: float, y: float, z: float) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(x, y, z))


def _place(translation, rot_z_deg: float = 0.0) -> np.ndarray:  # noqa: ANN001
    T = trimesh.transformations.rotation_matrix(math.radians(rot_z_deg), (0, 0, 1))
    T[:3, 3] = translation
    return T


class _Builder:
    def __init__(self, name: str):
        self.name = name
        self.parts: list[Part] = []
        self.counts: dict[str, int] = {}

    def add(self, ptype: str, proto: trimesh.Trimesh, T: np.ndarray) -> None:
        k = self.counts.get(ptype, 0)
        self.counts[ptype] = k + 1
        mesh = proto.copy()
        mesh.apply_transform(T)
        self.parts.append(Part(f"{ptype}.{k}", ptype, mesh, T))

    def assembly(self) -> Assembly:
        return Assembly(self.parts, name=self.name)


# -- castle ----------------------------------------------------------------------------------
TOWER_R, TOWER_H = 1.6, 6.0
SPACING = 12.0
WALL_T, WALL_H, GATE_T, GATE_H = 0.8, 4.0, 1.2, 5.0


def castle(name: str, nx: int, ny: int, gates: set[tuple[int, int, int]]) -> Assembly:
    """Towers on an nx x ny grid; each grid edge is a span of two segments (Wall or Gate).

    `gates` holds (span direction 0=x/1=y, span index, segment 0/1) triples to make gates."""
    tower = trimesh.creation.cylinder(radius=TOWER_R, height=TOWER_H, sections=8)
    tower.apply_transform(trimesh.transformations.rotation_matrix(math.radians(22.5), (0, 0, 1)))
    inradius = TOWER_R * math.cos(math.radians(22.5))
    start = inradius - 0.08  # wall ends dip into the tower's flat face
    seg_len = SPACING / 2 - start
    wall, gate = _box(seg_len, WALL_T, WALL_H), _box(seg_len, GATE_T, GATE_H)
    b = _Builder(name)
    for j in range(ny):
        for i in range(nx):
            b.add("Tower", tower, _place((i * SPACING, j * SPACING, TOWER_H / 2)))
    span = 0
    for direction in (0, 1):
        for j in range(ny if direction == 0 else ny - 1):
            for i in range(nx - 1 if direction == 0 else nx):
                origin = np.array([i * SPACING, j * SPACING, 0.0])
                axis = np.eye(3)[direction]
                for seg in (0, 1):
                    is_gate = (direction, span, seg) in gates
                    h = GATE_H if is_gate else WALL_H
                    centre = origin + axis * (start + seg_len / 2 + seg * seg_len) + [0, 0, h / 2]
                    b.add("Gate" if is_gate else "Wall", gate if is_gate else wall,
                          _place(centre, 90.0 * direction))
                span += 1
    return b.assembly()


# -- ball track ------------------------------------------------------------------------------
CELL, DROP, PIECE_H, END_H = 2.0, 0.25, 0.3, 0.6


def serpentine(run: int, rows: int) -> list[tuple[int, int]]:
    """Cells of a zig-zag path: rows of `run` cells, joined by one cell in a gap row, so that
    cells that are not consecutive on the path are never side by side."""
    cells: list[tuple[int, int]] = []
    for r in range(rows):
        xs = range(run) if r % 2 == 0 else range(run - 1, -1, -1)
        cells.extend((x, 2 * r) for x in xs)
        if r < rows - 1:
            cells.append((run - 1 if r % 2 == 0 else 0, 2 * r + 1))
    return cells


def balltrack(name: str, run: int, rows: int) -> Assembly:
    cells = serpentine(run, rows)
    n = len(cells)
    piece, end = _box(CELL, CELL, PIECE_H), _box(CELL, CELL, END_H)
    pillar = _box(0.4, 0.4, 1.0)
    b = _Builder(name)
    for k, (cx, cy) in enumerate(cells):
        bottom = DROP * (n - 1 - k)  # downhill: the exit sits on the ground
        if k == 0:
            ptype, proto, h = "Entry", end, END_H
        elif k == n - 1:
            ptype, proto, h = "Exit", end, END_H
        else:
            prev, nxt = cells[k - 1], cells[k + 1]
            turn = (nxt[0] - cx, nxt[1] - cy) != (cx - prev[0], cy - prev[1])
            ptype, proto, h = ("Turn" if turn else "Ramp"), piece, PIECE_H
        b.add(ptype, proto, _place((cx * CELL, cy * CELL, bottom + h / 2)))
        if k > 0 and bottom >= 1 and abs(bottom - round(bottom)) < 1e-9:
            for level in range(int(round(bottom))):  # a column of unit blocks up to the piece
                b.add("Pillar", pillar, _place((cx * CELL, cy * CELL, level + 0.5)))
    return b.assembly()


# -- facade ----------------------------------------------------------------------------------
PANEL_W, PANEL_H, PANEL_D, LEDGE_H = 1.5, 3.0, 0.3, 0.2


def facade(name: str, columns: int, floors: int) -> Assembly:
    wall, window, door = _box(PANEL_W, PANEL_D, PANEL_H), _box(PANEL_W, 0.2, PANEL_H), _box(PANEL_W, 0.25, PANEL_H)
    width = columns * PANEL_W
    ledge, cornice = _box(width, 0.5, LEDGE_H), _box(width, 0.7, 0.4)
    b = _Builder(name)
    z = 0.0
    for f in range(floors):
        for c in range(columns):
            x = (c + 0.5) * PANEL_W
            edge = c in (0, columns - 1)
            if f == 0 and c == columns // 2:
                b.add("Door", door, _place((x, PANEL_D - 0.125, z + PANEL_H / 2)))
            elif f == 0 or edge:
                b.add("Wall", wall, _place((x, PANEL_D / 2, z + PANEL_H / 2)))
            else:
                b.add("Window", window, _place((x, PANEL_D - 0.1, z + PANEL_H / 2)))
        z += PANEL_H
        if f < floors - 1:
            b.add("Ledge", ledge, _place((width / 2, PANEL_D / 2, z + LEDGE_H / 2)))
            z += LEDGE_H
    b.add("Cornice", cornice, _place((width / 2, PANEL_D / 2, z + 0.2)))
    return b.assembly()


EXAMPLES = {
    "castle": [castle("castle_small", 3, 2, {(0, 0, 1)}),
               castle("castle_large", 3, 3, {(0, 1, 0), (1, 7, 1)})],
    "balltrack": [balltrack("track_short", 4, 3), balltrack("track_long", 5, 4)],
    "facade": [facade("facade_small", 4, 3), facade("facade_large", 6, 4)],
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--picture", type=Path, default=None,
                    help="also render the larger example of each grammar side by side (PNG)")
    args = ap.parse_args(argv)
    for gname, asms in EXAMPLES.items():
        folder = args.out / gname
        for a in asms:
            write_assembly(a, folder / f"{a.name}.glb")
        # Kalojanov's exact neighbourhoods: these examples are designs whose variants should stay
        # like them (learn's default, no neighbourhood rules, is for tilings)
        # (holes: a ball track is no tiling, an open side of a piece inside its loop is no hole)
        grammar = learn(asms, name=gname, example_paths=[f"{a.name}.glb" for a in asms],
                        neighbors="multisets", holes=gname != "balltrack")
        if gname == "balltrack":  # the one rule learning cannot guess (Liu 2015's path constraint)
            path = ConstraintDef(name="path", args=(Arg(name="from", value=Ref(name="Entry")),
                                                    Arg(name="to", value=Ref(name="Exit")),
                                                    Arg(name="downhill", value=Bool(value=True))))
            grammar = Grammar(name=grammar.name, statements=(*grammar.statements, path))
        text = print_grammar(grammar)
        _atomic_write(folder / f"{gname}.grammar", text.encode())
        # validate as the file reads: part geometry relative to the grammar's folder
        grammar = grammar.model_copy(update={"source_path": str(folder / f"{gname}.grammar")})
        for a in asms:
            report = validate(grammar, a)
            if not report.ok:
                print(report.format(), file=sys.stderr)
                return 1
        sizes = ", ".join(f"{a.name}: {len(a)} parts" for a in asms)
        print(f"{folder}/{gname}.grammar ({sizes})")
    if args.picture:
        render_picture(args.picture)
    return 0


def render_picture(path: Path) -> None:
    """The larger example of each grammar, parts coloured by type (docs/images/tiling_examples.png)."""
    from PIL import Image

    from grammarkit.geometry.render import render

    palette = [(200, 170, 120), (150, 150, 160), (170, 80, 60), (90, 130, 170), (110, 160, 90), (220, 200, 90)]
    tiles = []
    for asms in EXAMPLES.values():
        asm = asms[1]
        types = sorted({p.type for p in asm.parts})
        parts = []
        for p in asm.parts:
            m = p.mesh.copy()
            m.visual.face_colors = (*palette[types.index(p.type) % len(palette)], 255)
            parts.append(Part(p.id, p.type, m, p.transform))
        tiles.append(render(Assembly(parts), size=(360, 280)))
    out = Image.new("RGB", (360 * len(tiles), 280), "white")
    for i, t in enumerate(tiles):
        out.paste(t.convert("RGB"), (360 * i, 0))
    path.parent.mkdir(parents=True, exist_ok=True)
    out.save(path, optimize=True)


if __name__ == "__main__":
    raise SystemExit(main())
