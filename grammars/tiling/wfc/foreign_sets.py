"""Tile sets built independently of wfc_sets.py, to attack `learn`'s generalisation (issue 28):
other grids, other geometry, another generator, gravity, and an independent checker.

    python grammars/tiling/wfc/foreign_sets.py [--set roads|hexes|town] [--size 6 5] [--seed 0] [-o t.glb]

What differs from wfc_sets.py (octagonal plates with channels cut, solved by WFC):

- `roads`: plain **square** plates (no chamfer: diagonal neighbours touch along an edge, so the
  shape graph has corner contacts) with raised ridges (road `r`, path `p`) instead of channels;
  symmetry 4 (Grass), 2 (Road, Path, Crossing), none (Bend, Tee, Ramp) and a **chiral** tile
  (Fork: its mirror image is no turn of it);
- `hexes`: **hexagonal** prisms on a hex grid (6 neighbours, turns of 60 degrees): symmetry
  6 (Blank, Star), 3 (Tri), 2 (Line, Canal), none (Arc, Kink, Lock) and a chiral tile
  (Twist); ridges (`1`) and grooves (`2`);
- `town`: a **stacked** set under gravity: ground pads everywhere, columns of blocks of 0-3
  storeys, a gable roof on every column but one, which carries the town's single spire, and
  bridges held only sideways between two columns (runs of 1-2): support, spans and a
  designed count (one spire) matter.

Tilings come from `backtrack` (cell by cell in scan order, candidates in a seeded random
order, chronological backtracking with a node budget and restarts), not from WFC; the town
from its own seeded procedure. `corruptions` makes broken tilings, each checked broken by
`check` (below) first: rotated, direction (two neighbours exchanged), unseen pair, hole,
floating (a part lifted off what carries it), squashed (a part scaled by 0.9 along one
horizontal axis), mirrored (a chiral tile reflected), count (the town with no or two spires),
span (a bridge run longer than any example's), overlap (a copy of a part pushed a third of
the way into its neighbour).

`check(ts, assembly)` is an independent plausibility checker that reads only the geometry and
the tile set's own rules (nothing of grammarkit's learn or validate): each part's pose by a
Kabsch fit of its vertices to its tile's prototype (rigid within 0.1% of the diagonal, no
reflection), its cell and turn from that pose, the sockets of every two face neighbours, holes
(an empty cell with filled cells on both sides along some axis), support (every town part on
the ground or on a part below, or in a sideways run of at most 2 between carried parts) and the
spire count."""
from __future__ import annotations

import argparse
import math
import random
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from grammarkit.tiling import Assembly, Part

PLATE = 0.2
HEX_A = 0.5  # hexagon apothem: neighbours 1.0 apart


@dataclass(frozen=True)
class Tile:
    name: str
    sides: tuple[str, ...]  # one socket per side, counter-clockwise from direction 0 (east)
    weight: float = 1.0

    def turned(self, k: int) -> tuple[str, ...]:
        n = len(self.sides)
        return tuple(self.sides[(d - k) % n] for d in range(n))

    def mirrored(self) -> tuple[str, ...]:
        """Sockets of the tile reflected across its x axis (side d goes to side -d)."""
        n = len(self.sides)
        return tuple(self.sides[(-d) % n][::-1] for d in range(n))


@dataclass
class TileSet:
    name: str
    tiles: tuple[Tile, ...]
    grid: str  # "square" or "hex"
    options: list[tuple[int, int]] = field(default_factory=list)

    def __post_init__(self) -> None:
        for i, t in enumerate(self.tiles):
            seen = set()
            for k in range(self.n_dirs):
                if t.turned(k) not in seen:
                    seen.add(t.turned(k))
                    self.options.append((i, k))

    @property
    def n_dirs(self) -> int:
        return 6 if self.grid == "hex" else 4

    def fits(self, a: tuple[int, int], b: tuple[int, int], d: int) -> bool:
        n = self.n_dirs
        sa = self.tiles[a[0]].turned(a[1])[d]
        sb = self.tiles[b[0]].turned(b[1])[(d + n // 2) % n]
        return sa == sb[::-1]

    def steps(self) -> list[tuple[int, int]]:
        if self.grid == "hex":  # axial coordinates, direction k at 60k degrees
            return [(1, 0), (0, 1), (-1, 1), (-1, 0), (0, -1), (1, -1)]
        return [(1, 0), (0, 1), (-1, 0), (0, -1)]

    def centre(self, cell: tuple[int, int]) -> tuple[float, float]:
        q, r = cell
        if self.grid == "hex":
            return (2 * HEX_A * (q + 0.5 * r), 2 * HEX_A * r * math.sqrt(3) / 2)
        return (q + 0.5, r + 0.5)

    def cells(self, size: tuple[int, int]) -> list[tuple[int, int]]:
        nx, ny = size
        if self.grid == "hex":  # a roughly rectangular patch
            return [(q - r // 2, r) for r in range(ny) for q in range(nx)]
        return [(i, j) for j in range(ny) for i in range(nx)]


ROADS = TileSet("roads", (
    Tile("Grass", ("0", "0", "0", "0"), 3.0),
    Tile("Road", ("r", "0", "r", "0"), 2.0),
    Tile("Bend", ("r", "r", "0", "0")),
    Tile("Tee", ("r", "r", "r", "0"), 0.5),
    Tile("Path", ("p", "0", "p", "0")),
    Tile("Crossing", ("r", "p", "r", "p"), 0.5),
    Tile("Ramp", ("r", "0", "p", "0"), 0.7),
    Tile("Fork", ("r", "p", "0", "r"), 0.7),
), "square")
HEXES = TileSet("hexes", (
    Tile("Blank", ("0",) * 6, 3.0),
    Tile("Star", ("1",) * 6, 0.3),
    Tile("Tri", ("1", "0", "1", "0", "1", "0"), 0.6),
    Tile("Line", ("1", "0", "0", "1", "0", "0"), 1.5),
    Tile("Canal", ("2", "0", "0", "2", "0", "0")),
    Tile("Arc", ("1", "1", "0", "0", "0", "0")),
    Tile("Kink", ("1", "0", "1", "0", "0", "0")),
    Tile("Lock", ("1", "0", "0", "2", "0", "0"), 0.7),
    Tile("Twist", ("1", "2", "0", "0", "0", "0"), 0.5),
), "hex")
TOWN_TYPES = ("Pad", "Block", "Roof", "Spire", "Bridge")
SETS = {"roads": ROADS, "hexes": HEXES, "town": None}

# ridge (raised) letters: (half width, height); groove (cut) letters: (half width, depth)
_RIDGE = {"r": (0.15, 0.05), "p": (0.05, 0.09), "1": (0.1, 0.06)}
_GROOVE = {"2": (0.07, 0.08)}


def _m3():  # noqa: ANN202
    import manifold3d as m3

    return m3


def _box(lo, hi):  # noqa: ANN001, ANN202
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return _m3().Manifold.cube((hi - lo).tolist()).translate(lo.tolist())


def _to_trimesh(body) -> trimesh.Trimesh:  # noqa: ANN001
    mesh = body.to_mesh()
    return trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts), process=False)


@lru_cache(maxsize=None)
def tile_mesh(set_name: str, index: int) -> trimesh.Trimesh:
    """A tile's prototype: a plate with a ridge or groove from near its centre out to each
    side per socket letter (two-letter sockets: two, side by side)."""
    ts = SETS[set_name]
    tile = ts.tiles[index]
    n = ts.n_dirs
    if ts.grid == "hex":
        body = _m3().Manifold.cylinder(PLATE, HEX_A / math.cos(math.pi / 6), -1.0, 6).rotate([0, 0, 30])
        reach = HEX_A
    else:
        body = _box((-0.5, -0.5, 0.0), (0.5, 0.5, PLATE))
        reach = 0.5
    for d, sock in enumerate(tile.sides):
        for k, ch in enumerate(sock):
            off = 0.0 if len(sock) == 1 else -0.15 + 0.3 * k / (len(sock) - 1)
            if ch in _RIDGE:
                w, h = _RIDGE[ch]
                piece = _box((0.12, off - w, PLATE), (reach, off + w, PLATE + h))
                body = body + piece.rotate([0, 0, 360.0 * d / n])
            elif ch in _GROOVE:
                w, h = _GROOVE[ch]
                piece = _box((0.12, off - w, PLATE - h), (reach + 0.1, off + w, PLATE + 0.1))
                body = body - piece.rotate([0, 0, 360.0 * d / n])
    return _to_trimesh(body)


@lru_cache(maxsize=None)
def town_mesh(kind: str) -> trimesh.Trimesh:
    """Town prototypes, modelled with their base at z = 0 and centred in x, y."""
    m3 = _m3()
    if kind == "Pad":
        body = _box((-0.5, -0.5, 0), (0.5, 0.5, PLATE))
    elif kind == "Block":  # a storey: a cube with a window recess on every side
        body = _box((-0.5, -0.5, 0), (0.5, 0.5, 1.0))
        for d in range(4):
            body = body - _box((0.42, -0.15, 0.35), (0.6, 0.15, 0.75)).rotate([0, 0, 90.0 * d])
    elif kind == "Roof":  # a gable along x (symmetry 2)
        prism = m3.CrossSection([[(-0.5, 0.0), (0.5, 0.0), (0.0, 0.45)]]).extrude(1.0)
        body = prism.rotate([90, 0, 0]).translate([0, 0.5, 0]).rotate([0, 0, 90])
    elif kind == "Spire":  # a square pyramid on a short drum (symmetry 4)
        body = _box((-0.5, -0.5, 0), (0.5, 0.5, 0.15)) + m3.Manifold.cylinder(
            0.9, 0.5 * math.sqrt(2), 0.0, 4).rotate([0, 0, 45]).translate([0, 0, 0.15])
    elif kind == "Bridge":  # a beam between two columns' faces, with a parapet on one side
        body = _box((-0.5, -0.2, 0), (0.5, 0.2, 0.25)) + _box((-0.5, 0.12, 0.25), (0.5, 0.2, 0.4))
    else:
        raise KeyError(kind)
    return _to_trimesh(body)


# --------------------------------------------------------------------------------------------
# the generator: backtracking, not WFC
# --------------------------------------------------------------------------------------------
Grid = dict  # {cell: option index or None}


def backtrack(ts: TileSet, size: tuple[int, int], seed: int = 0, budget: int = 20000, restarts: int = 50) -> Grid:
    """A valid tiling of the patch `ts.cells(size)`: cells in scan order, each given the first
    (seeded random order, weighted) option that fits its already placed neighbours,
    chronological backtracking; a spent node budget restarts with the next seed."""
    cells = ts.cells(size)
    inside = set(cells)
    steps = ts.steps()
    weights = [ts.tiles[i].weight for i, _ in ts.options]
    for attempt in range(restarts):
        rng = random.Random(seed * 104729 + attempt)
        grid: Grid = {}
        orders: list[list[int]] = []
        nodes = 0

        def order() -> list[int]:
            keys = [(rng.random() ** (1.0 / weights[o]), o) for o in range(len(ts.options))]
            return [o for _, o in sorted(keys, reverse=True)]  # weighted random permutation

        pos = 0
        orders.append(order())
        while 0 <= pos < len(cells) and nodes < budget:
            cell = cells[pos]
            placed = False
            while orders[pos]:
                o = orders[pos].pop(0)
                nodes += 1
                if all(grid.get(nb) is None or ts.fits(ts.options[o], ts.options[grid[nb]], d)
                       for d, nb in enumerate((cell[0] + s[0], cell[1] + s[1]) for s in steps)
                       if nb in inside):
                    grid[cell] = o
                    placed = True
                    break
            if placed:
                pos += 1
                if pos < len(cells):
                    orders.append(order())
            else:
                grid.pop(cell, None)
                orders.pop()
                pos -= 1
                if pos >= 0:
                    grid.pop(cells[pos], None)
        if pos == len(cells):
            return grid
    raise RuntimeError(f"no {ts.name} tiling of {size}")


def socket_violations(ts: TileSet, grid: Grid) -> list[str]:
    out = []
    for cell, o in grid.items():
        if o is None:
            continue
        for d, s in enumerate(ts.steps()):
            nb = (cell[0] + s[0], cell[1] + s[1])
            if grid.get(nb) is not None and not ts.fits(ts.options[o], ts.options[grid[nb]], d):
                out.append(f"{cell} -> {nb}")
    return out


def _pose(ts: TileSet, cell, turn: int, yaw: float = 0.0, offset=(0.0, 0.0, 0.0)) -> np.ndarray:  # noqa: ANN001
    T = trimesh.transformations.rotation_matrix(2 * math.pi * turn / ts.n_dirs, (0, 0, 1))
    T[:2, 3] = ts.centre(cell)
    W = trimesh.transformations.rotation_matrix(math.radians(yaw), (0, 0, 1))
    W[:3, 3] = offset
    return W @ T


def tiling(ts: TileSet, grid: Grid, name: str, yaw: float = 0.0, offset=(0.0, 0.0, 0.0),  # noqa: ANN001
           edits: dict | None = None) -> Assembly:
    """The assembly of a grid, the whole tiling turned by `yaw` degrees and moved by `offset`;
    `edits` maps a cell to an extra 4x4 matrix applied in the tile's own frame (a squashed or
    mirrored tile) or in the world after placement (`("world", M)`: a lifted one)."""
    counts: dict[str, int] = {}
    parts = []
    for cell in sorted(grid, key=lambda c: (c[1], c[0])):
        o = grid[cell]
        if o is None:
            continue
        ti, turn = ts.options[o]
        t = ts.tiles[ti].name
        T = _pose(ts, cell, turn, yaw, offset)
        mesh = tile_mesh(ts.name, ti).copy()
        edit = (edits or {}).get(cell)
        if edit is not None and edit[0] == "copy":  # the tile, and a copy moved by M in the world
            copy = tile_mesh(ts.name, ti).copy()
            copy.apply_transform(edit[1] @ T)
            parts.append(Part(f"{t}.copy", t, copy, edit[1] @ T))
        elif edit is not None:
            where, M = edit
            T = M @ T if where == "world" else T @ M
        mesh.apply_transform(T)
        if np.linalg.det(T[:3, :3]) < 0:
            mesh.invert()
        k = counts.get(t, 0)
        counts[t] = k + 1
        parts.append(Part(f"{t}.{k}", t, mesh, T))
    return Assembly(parts, name=name)


# --------------------------------------------------------------------------------------------
# the town: a stacked set under gravity
# --------------------------------------------------------------------------------------------
Town = dict  # {"size": (nx, ny), "h": {(i, j): storeys}, "spire": (i, j), "bridges": [(j, i0, i1, level)]}


def town(size: tuple[int, int], seed: int = 0) -> Town:
    """Column heights 0-3 (at least two columns of 2+), the spire on the first tallest column,
    then bridges along x in each row between two columns 2 or 3 apart whose gap columns are
    lower than the bridge's storey (a run of 1 or 2 bridge parts, held only sideways)."""
    rng = random.Random(seed)
    nx, ny = size
    while True:
        h = {(i, j): rng.choices((0, 1, 2, 3), (4, 3, 2, 1))[0] for j in range(ny) for i in range(nx)}
        if sum(v >= 2 for v in h.values()) >= 2:
            break
    top = max(h.values())
    spire = min(c for c in h if h[c] == top)
    bridges = []
    for j in range(ny):
        i = 0
        while i < nx:
            if h[(i, j)] >= 2:
                for gap in (2, 3):
                    k = i + gap
                    level = min(h[(i, j)], h.get((k, j), 0)) - 1
                    if k < nx and level >= 1 and all(h[(m, j)] < level for m in range(i + 1, k)) \
                            and rng.random() < 0.7:
                        bridges.append((j, i, k, level))
                        i = k - 1
                        break
            i += 1
    return {"size": size, "h": h, "spire": spire, "bridges": bridges}


def town_parts(t: Town) -> list[tuple[str, np.ndarray]]:
    """(type, pose) of every part of a town, in a fixed order."""
    out = []
    for (i, j), n in sorted(t["h"].items(), key=lambda kv: (kv[0][1], kv[0][0])):
        x, y = i + 0.5, j + 0.5
        out.append(("Pad", _at(x, y, 0.0)))
        for k in range(n):
            out.append(("Block", _at(x, y, PLATE + k)))
        if n:
            out.append(("Spire" if (i, j) == t["spire"] else "Roof", _at(x, y, PLATE + n)))
    for j, i0, i1, level in t["bridges"]:
        for m in range(i0 + 1, i1):
            out.append(("Bridge", _at(m + 0.5, j + 0.5, PLATE + level + 0.3, 180.0 * (m % 2))))
    return out


def _at(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    T = trimesh.transformations.rotation_matrix(math.radians(yaw), (0, 0, 1))
    T[:3, 3] = (x, y, z)
    return T


def town_assembly(t: Town, name: str, yaw: float = 0.0, offset=(0.0, 0.0, 0.0),  # noqa: ANN001
                  parts: list[tuple[str, np.ndarray]] | None = None) -> Assembly:
    W = _at(*offset, yaw)
    counts: dict[str, int] = {}
    out = []
    for kind, T in (parts if parts is not None else town_parts(t)):
        T = W @ T
        mesh = town_mesh(kind).copy()
        mesh.apply_transform(T)
        k = counts.get(kind, 0)
        counts[kind] = k + 1
        out.append(Part(f"{kind}.{k}", kind, mesh, T))
    return Assembly(out, name=name)


# --------------------------------------------------------------------------------------------
# the independent checker: geometry and the tile set's own rules only
# --------------------------------------------------------------------------------------------
RIGID = 1e-3  # vertex error, in part diagonals


def _kabsch(P: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Proper rotation R and translation t minimising |R P + t - Q| (rows are points), and the
    largest vertex error."""
    cp, cq = P.mean(axis=0), Q.mean(axis=0)
    U, _, Vt = np.linalg.svd((P - cp).T @ (Q - cq))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    t = cq - R @ cp
    return R, t, float(np.abs(P @ R.T + t - Q).max())


def _fit(part: Part, proto: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, str | None]:
    P, Q = np.asarray(proto.vertices, float), np.asarray(part.mesh.vertices, float)
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    if P.shape != Q.shape:
        return np.eye(3), Q.mean(axis=0), f"{part.id}: not a copy of its prototype"
    R, t, err = _kabsch(P, Q)
    if err > RIGID * diag:
        return R, t, f"{part.id}: not rigid (vertex error {err / diag:.2%} of the diagonal)"
    if abs(R[2, 2] - 1.0) > 1e-6:
        return R, t, f"{part.id}: not upright"
    return R, t, None


def check(name: str, asm: Assembly) -> list[str]:
    """Every reason the assembly is not a plausible tiling of the set `name` (empty: plausible)."""
    return _check_town(asm) if name == "town" else _check_tiles(SETS[name], asm)


def _check_tiles(ts: TileSet, asm: Assembly) -> list[str]:
    n = ts.n_dirs
    protos = {t.name: (i, tile_mesh(ts.name, i)) for i, t in enumerate(ts.tiles)}
    out: list[str] = []
    placed = []
    for p in asm.parts:
        if p.type not in protos:
            out.append(f"{p.id}: unknown tile")
            continue
        R, t, bad = _fit(p, protos[p.type][1])
        if bad:
            out.append(bad)
            continue
        placed.append((p, math.atan2(R[1, 0], R[0, 0]), t))
    if not placed:
        return out or ["no parts"]
    step = 2 * math.pi / n
    world = placed[0][1] % step
    c, s = math.cos(-world), math.sin(-world)
    origin = placed[0][2]
    grid: dict[tuple[int, int], tuple[int, int]] = {}
    for p, yaw, t in placed:
        if abs(t[2] - origin[2]) > 1e-6 * asm.scale:
            out.append(f"{p.id}: not on the ground (lifted {t[2] - origin[2]:.3f})")
            continue
        d = t - origin
        x, y = c * d[0] - s * d[1], s * d[0] + c * d[1]
        if ts.grid == "hex":
            r = y / (2 * HEX_A * math.sqrt(3) / 2)
            q = x / (2 * HEX_A) - 0.5 * r
        else:
            q, r = x, y
        cell = (round(q), round(r))
        if max(abs(q - cell[0]), abs(r - cell[1])) > 1e-3:
            out.append(f"{p.id}: off the grid")
            continue
        turn = round((yaw - world) / step) % n
        ti = protos[p.type][0]
        opt = next((o for o in ts.options if o[0] == ti and ts.tiles[ti].turned(o[1]) == ts.tiles[ti].turned(turn)))
        if cell in grid:
            out.append(f"{p.id}: a second tile in cell {cell}")
        grid[cell] = opt
    steps = ts.steps()
    for cell, o in grid.items():
        for d, st in enumerate(steps):
            nb = (cell[0] + st[0], cell[1] + st[1])
            if nb in grid and not ts.fits(o, grid[nb], d):
                out.append(f"cell {cell}: its side {d} does not fit {nb}")
    for cell in _gaps(grid, steps):
        out.append(f"hole at {cell}")
    return out


def _gaps(filled, steps) -> list:  # noqa: ANN001
    """Empty cells enclosed by the patch: not reached from outside its bounding range by steps
    over empty cells (a notch in the border is no hole)."""
    qs, rs = [c[0] for c in filled], [c[1] for c in filled]
    q0, q1, r0, r1 = min(qs) - 1, max(qs) + 1, min(rs) - 1, max(rs) + 1
    seen = {(q0, r0)}
    todo = [(q0, r0)]
    while todo:
        c = todo.pop()
        for st in steps:
            nb = (c[0] + st[0], c[1] + st[1])
            if q0 <= nb[0] <= q1 and r0 <= nb[1] <= r1 and nb not in seen and nb not in filled:
                seen.add(nb)
                todo.append(nb)
    return sorted((q, r) for q in range(q0, q1 + 1) for r in range(r0, r1 + 1)
                  if (q, r) not in filled and (q, r) not in seen)


def _check_town(asm: Assembly) -> list[str]:  # long: one pass per rule of the town
    out: list[str] = []
    cells: dict[tuple[int, int, int], str] = {}
    bridges: dict[tuple[int, int, int], np.ndarray] = {}
    placed = []
    for p in asm.parts:
        if p.type not in TOWN_TYPES:
            out.append(f"{p.id}: unknown part")
            continue
        R, t, bad = _fit(p, town_mesh(p.type))
        if bad:
            out.append(bad)
            continue
        placed.append((p, R, t))
    if not placed:
        return out or ["no parts"]
    pad = next((x for x in placed if x[0].type == "Pad"), placed[0])
    yaw = math.atan2(pad[1][1, 0], pad[1][0, 0]) % (math.pi / 2)
    c, s = math.cos(-yaw), math.sin(-yaw)
    o = pad[2]  # a pad's centre: cells are whole steps from it
    for p, R, t in placed:
        d = t - o
        x, y = c * d[0] - s * d[1], s * d[0] + c * d[1]
        z = d[2]
        key_xy = (round(x), round(y))
        if max(abs(x - key_xy[0]), abs(y - key_xy[1])) > 1e-3:
            out.append(f"{p.id}: off the grid")
            continue
        if p.type == "Bridge":
            level = z - PLATE - 0.3
            along = 0 if abs(R[0, 0] * c - R[1, 0] * s) > 0.5 else 1  # its beam along the grid's x or y
            if abs(level - round(level)) > 1e-3:
                out.append(f"{p.id}: a bridge not across a storey")
                continue
            bridges[(*key_xy, round(level))] = along
            continue
        level = 0 if p.type == "Pad" else z - PLATE
        if p.type != "Pad" and abs(level - round(level)) > 1e-3 or (p.type == "Pad" and abs(z) > 1e-3):
            out.append(f"{p.id}: not resting on a storey (z {z:.3f})")
            continue
        key = (*key_xy, -1 if p.type == "Pad" else round(level))
        if key in cells:
            out.append(f"{p.id}: a second part at {key}")
        cells[key] = p.type
    for (i, j, k), kind in sorted(cells.items()):
        below = cells.get((i, j, k - 1))
        if kind != "Pad" and below != ("Pad" if k == 0 and kind == "Block" else "Block"):
            out.append(f"{kind} at {(i, j, k)}: not carried (below: {below})")
        if kind == "Pad" and k != -1:
            out.append(f"pad at {(i, j, k)} above the ground")
    pads = {(i, j) for (i, j, k), kind in cells.items() if kind == "Pad"}
    for cell in _gaps(pads, [(1, 0), (0, 1), (-1, 0), (0, -1)]):
        out.append(f"hole at {cell}")
    for (i, j, k), ax in sorted(bridges.items()):
        step = (1, 0) if ax == 0 else (0, 1)
        if bridges.get((i - step[0], j - step[1], k)) == ax:
            continue
        run = [(i, j)]
        while bridges.get((run[-1][0] + step[0], run[-1][1] + step[1], k)) == ax:
            run.append((run[-1][0] + step[0], run[-1][1] + step[1]))
        ends = (cells.get((i - step[0], j - step[1], k)), cells.get((run[-1][0] + step[0], run[-1][1] + step[1], k)))
        if ends != ("Block", "Block"):
            out.append(f"bridge run at {(i, j, k)}: its ends do not meet two blocks ({ends})")
        if len(run) > 2:
            out.append(f"bridge run at {(i, j, k)}: {len(run)} parts held only sideways (at most 2)")
        for x, y in run:
            if cells.get((x, y, k)) is not None:
                out.append(f"bridge at {(x, y, k)} inside a column")
    spires = sum(kind == "Spire" for kind in cells.values())
    if spires != 1:
        out.append(f"{spires} spires (one per town)")
    return out


# --------------------------------------------------------------------------------------------
# corruptions, each checked broken by `check`
# --------------------------------------------------------------------------------------------
KINDS = ("rotated", "direction", "unseen pair", "hole", "floating", "squashed", "mirrored", "count", "span",
         "overlap")
SQUASH = np.diag([0.9, 1.0, 1.0, 1.0])
MIRROR = np.diag([1.0, -1.0, 1.0, 1.0])


def _shift(dx: float) -> np.ndarray:
    M = np.eye(4)
    M[0, 3] = dx
    return M


def _lift(asm_pose: np.ndarray, dz: float) -> np.ndarray:
    M = np.eye(4)
    M[2, 3] = dz
    return M


def tile_corruptions(ts: TileSet, grid: Grid, seed: int = 0, per_kind: int = 2) -> dict[str, list[Assembly]]:
    """Broken tilings of a valid grid, `per_kind` of each kind that applies (no count or span
    rule in a flat tile set)."""
    rng = random.Random(seed)
    cells = sorted(grid)
    steps = ts.steps()
    n = ts.n_dirs
    cands: dict[str, list[tuple[Grid, dict]]] = {k: [] for k in KINDS}
    for c in cells:
        ti, k = ts.options[grid[c]]
        for dk in range(1, n):
            o = next((j for j, (a, b) in enumerate(ts.options) if a == ti and ts.tiles[a].turned(b)
                      == ts.tiles[a].turned(k + dk)), None)
            if o is not None and o != grid[c]:
                cands["rotated"].append(({**grid, c: o}, {}))
        for d in range(n // 2):
            b = (c[0] + steps[d][0], c[1] + steps[d][1])
            if b in grid and grid[b] != grid[c]:
                cands["direction"].append(({**grid, c: grid[b], b: grid[c]}, {}))
        for o, (oi, _) in enumerate(ts.options):
            if oi != ti:
                cands["unseen pair"].append(({**grid, c: o}, {}))
        inner = all((c[0] + s[0], c[1] + s[1]) in grid for s in steps)
        if inner:
            cands["hole"].append(({**grid, c: None}, {}))
        cands["floating"].append((grid, {c: ("world", _lift(np.eye(4), 0.3))}))
        cands["squashed"].append((grid, {c: ("local", SQUASH)}))
        cands["overlap"].append((grid, {c: ("copy", _lift(np.eye(4), 0.0) @ _shift(0.35))}))
        if ts.tiles[ti].mirrored() not in {ts.tiles[ti].turned(j) for j in range(n)}:
            cands["mirrored"].append((grid, {c: ("local", MIRROR)}))
    out: dict[str, list[Assembly]] = {k: [] for k in KINDS}
    for kind, cs in cands.items():
        rng.shuffle(cs)
        for g, edits in cs:
            if len(out[kind]) >= per_kind:
                break
            if kind in ("rotated", "direction", "unseen pair") and not socket_violations(ts, g):
                continue
            asm = tiling(ts, g, f"{ts.name}_{kind}{len(out[kind])}", edits=edits)
            if check(ts.name, asm):
                out[kind].append(asm)
    return out


def town_corruptions(t: Town, seed: int = 0, per_kind: int = 2) -> dict[str, list[Assembly]]:
    rng = random.Random(seed)
    parts = town_parts(t)
    out: dict[str, list[Assembly]] = {k: [] for k in KINDS}
    cands: dict[str, list[list[tuple[str, np.ndarray]]]] = {k: [] for k in KINDS}
    turn = _at(0, 0, 0, 90.0)
    for i, (kind, T) in enumerate(parts):
        swap = lambda M: parts[:i] + [(kind, M)] + parts[i + 1:]  # noqa: E731
        if kind in ("Bridge", "Roof"):
            cands["rotated"].append(swap(T @ turn))
        if kind in ("Roof", "Spire", "Bridge", "Block"):
            cands["floating"].append(swap(_lift(T, 0.3) @ T))
        cands["squashed"].append(swap(T @ SQUASH))
        if kind == "Block":
            cands["overlap"].append(parts + [("Block", _shift(0.35) @ T)])
        if kind == "Roof" and i > 0 and parts[i - 1][0] == "Block":
            # a column's top storey and its roof exchanged: the roof under a block
            below = parts[i - 1][1]
            cands["direction"].append(parts[:i - 1] + [("Roof", below), ("Block", T)] + parts[i + 1:])
        if kind == "Pad" and i + 1 < len(parts) and parts[i + 1][0] == "Pad":
            cands["unseen pair"].append(parts[:i + 1] + [("Roof", _at(0, 0, PLATE) @ T)] + parts[i + 1:])
        if kind == "Pad":  # an interior pad (all four neighbours there) taken away
            cands["hole"].append(parts[:i] + parts[i + 1:])
        if kind == "Spire":
            cands["count"].append(parts[:i] + [("Roof", T)] + parts[i + 1:])
        if kind == "Roof":
            cands["count"].append(parts[:i] + [("Spire", T)] + parts[i + 1:])
    nx, ny = t["size"]
    for j in range(ny):
        # a row rebuilt as two columns four apart with a run of three bridges between them
        if nx < 5 or t["spire"][1] == j:
            continue
        h = {**t["h"], **{(i, j): 0 for i in range(nx)}, (0, j): 2, (4, j): 2}
        longer = {**t, "h": h, "bridges": [b for b in t["bridges"] if b[0] != j] + [(j, 0, 4, 1)]}
        cands["span"].append(town_parts(longer))
    for kind, cs in cands.items():
        rng.shuffle(cs)
        for ps in cs:
            if len(out[kind]) >= per_kind:
                break
            asm = town_assembly(t, f"town_{kind}{len(out[kind])}", parts=ps)
            if check("town", asm):
                out[kind].append(asm)
    return out


# --------------------------------------------------------------------------------------------
# the acceptance matrix
# --------------------------------------------------------------------------------------------
TRAIN = {"roads": [(5, 5), (6, 4), (4, 6), (6, 6), (7, 5), (5, 7)],
         "hexes": [(5, 5), (6, 4), (4, 6), (6, 6), (7, 5), (5, 7)],
         "town": [(5, 4), (6, 3), (4, 5), (6, 5), (5, 5), (7, 3)]}
HELD = {"roads": [(8, 6), (3, 3), (9, 4), (3, 8), (7, 7)],
        "hexes": [(8, 6), (3, 3), (9, 4), (3, 8), (7, 7)],
        "town": [(8, 4), (4, 4), (7, 6), (3, 6), (6, 6)]}
TURN = (30.0, (3.7, -2.2, 0.0))  # a held-out tiling also tried turned by 30 degrees and moved


def make(name: str, size: tuple[int, int], seed: int, label: str, turned: bool | float = False):  # noqa: ANN201
    """(valid assembly, the data it came from: a grid or a town); `turned`: True for TURN, or
    a yaw in degrees."""
    yaw, off = TURN if turned is True else (float(turned), (1.3, 0.4, 0.0)) if turned else (0.0, (0.0, 0.0, 0.0))
    if name == "town":
        t = town(size, seed)
        return town_assembly(t, label, yaw, off), t
    g = backtrack(SETS[name], size, seed)
    return tiling(SETS[name], g, label, yaw, off), g


def notched(name: str, data, size: tuple[int, int], label: str) -> Assembly | None:  # noqa: ANN001
    """The valid tiling with a 2 x 2 block of cells cut from one corner (a new outline: its
    inner corner puts tiles on the border where the examples had none); None when too small
    (or, for the town, when the spire stands there)."""
    nx, ny = size
    if nx < 4 or ny < 4:
        return None
    if name == "town":
        cut = {(i, j) for i in range(nx - 2, nx) for j in range(ny - 2, ny)}
        if data["spire"] in cut:
            return None
        t = {**data, "h": {c: v for c, v in data["h"].items() if c not in cut},
             "bridges": [b for b in data["bridges"] if not (b[0] >= ny - 2 and b[2] >= nx - 2)]}
        return town_assembly(t, label)
    ts = SETS[name]
    cells = ts.cells(size)
    cut = {cells[r * nx + q] for r in range(ny - 2, ny) for q in range(nx - 2, nx)}
    return tiling(ts, {c: o for c, o in data.items() if c not in cut}, label)


def corrupt(name: str, data, seed: int, per_kind: int) -> dict[str, list[Assembly]]:  # noqa: ANN001
    return town_corruptions(data, seed, per_kind) if name == "town" else \
        tile_corruptions(SETS[name], data, seed, per_kind)


def acceptance(name: str, folder: Path, *, held_out: int | None = None, per_kind: int = 2, seed: int = 0,
               train: int | None = None, turn_train: bool = False, **learn_options) -> dict:
    """Learn (defaults unless `learn_options` say otherwise) from tilings of TRAIN[name]
    written as GLB files, print the grammar and load it back; validate held-out tilings of
    HELD[name] (other seeds and sizes), each also turned by TURN, and `per_kind`
    corruptions of each kind per held-out tiling (`turn_train`: the training tilings each
    turned by 11 + 17 i degrees, off the world axes). Every tiling is first judged by `check`.
    Held-out tilings are also cut to a notched outline (`notched`).
    Returns {"valid": [accepted, n], "turned": [...], "notched": [...], kind: [rejected, n],
    "failures": [...]}."""
    from grammarkit.dsl import load
    from grammarkit.printer import print_grammar
    from grammarkit.tiling import learn, validate, write_assembly

    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for i, size in enumerate(TRAIN[name][:train]):
        asm, _ = make(name, size, seed * 1000 + 10 + i, f"{name}_train{i}", 11.0 + 17 * i if turn_train else False)
        assert not check(name, asm), check(name, asm)
        files.append(write_assembly(asm, folder / f"{name}_train{i}.glb"))
    grammar = learn(files, name=name, **learn_options)
    path = folder / f"{name}.grammar"
    path.write_text(print_grammar(grammar))
    grammar = load(path)
    result: dict = {"valid": [0, 0], "turned": [0, 0], "notched": [0, 0], **{k: [0, 0] for k in KINDS}, "failures": [],
                    "grammar": path}
    for i, size in enumerate(HELD[name][:held_out]):
        for col, turned in (("valid", False), ("turned", True)):
            asm, data = make(name, size, seed * 1000 + 100 + i, f"{name}_held{i}{'_turned' if turned else ''}", turned)
            assert not check(name, asm), check(name, asm)
            report = validate(grammar, asm)
            result[col][0] += report.ok
            result[col][1] += 1
            if not report.ok:
                result["failures"].append(f"{col} held-out {size}: {report.format()}")
        cut = notched(name, data, size, f"{name}_held{i}_notched")
        if cut is not None:
            assert not check(name, cut), check(name, cut)
            report = validate(grammar, cut)
            result["notched"][0] += report.ok
            result["notched"][1] += 1
            if not report.ok:
                result["failures"].append(f"notched held-out {size}: {report.format()}")
        for kind, bads in corrupt(name, data, seed + i, per_kind).items():
            for bad in bads:
                ok = validate(grammar, bad).ok
                result[kind][0] += not ok
                result[kind][1] += 1
                if ok:
                    result["failures"].append(f"{kind} of held-out {size} accepted: {check(name, bad)[:3]}")
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=sorted(SETS), default="roads")
    ap.add_argument("--size", type=int, nargs=2, default=[6, 5])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--out", type=Path, default=Path("tiling.glb"))
    args = ap.parse_args(argv)
    from grammarkit.tiling import write_assembly

    asm, _ = make(args.set, tuple(args.size), args.seed, f"{args.set}_{args.size[0]}x{args.size[1]}_s{args.seed}")
    write_assembly(asm, args.out)
    print(f"{args.out}: {len(asm)} parts, implausible: {check(args.set, asm) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
