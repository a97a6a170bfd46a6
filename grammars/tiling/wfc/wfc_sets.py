"""Edge-socket tile sets in the style of the public Wave Function Collapse "simple tiled" sets,
a WFC solver for them, and corruptions of valid tilings (issue 28's acceptance test).

    python grammars/tiling/wfc/wfc_sets.py [--set knots] [--size 6 5] [--seed 0] [-o tiling.glb]

None of these sets is one of the project's own examples. Each tile states, per side, a *socket*:
a string read counter-clockwise around the tile; two tiles may be neighbours across a side when
one's socket is the other's reversed (a one-letter socket: when they are equal). Rotations of a
tile are the same tile turned (its symmetry class — X, I, L, T, \\ in WFC's words — follows from
its sockets); the solver uses every distinct turn. Up and down sockets (the stacked set) do
not turn and match when equal. The sets:

- `knots`: line (I), corner (L), T (T), cross and empty (X); socket 1 = a strand, 0 = none;
- `circuit`: substrate, wire, track, bridge (wire over track), turn, T-junction, and a
  transition from track to wire (no symmetry); sockets 0 substrate, 1 wire, 2 track;
- `summer`: a corner-labelled terrain (grass `g`, sand `s`): grass, sand, a sand corner, an
  edge, a diagonal (z2) and an inner corner; two-letter sockets, so direction matters and
  grass never meets sand;
- `pipes3d`: stacked cubes with horizontal and vertical pipes (solid, straight, bend, vertical,
  riser, drop): a 3D grid, every cell filled.

Geometry: every tile is a rigid mesh whose shape has exactly the tile's turn symmetry: an
octagonal plate (2D) or a cube with chamfered edges (3D) — so that only face neighbours touch —
with a channel cut from near its centre out through each side for each socket letter (letter-specific
width and depth), so rotated tiles are told apart by their geometry alone.

`solve(tile_set, size, seed)` is WFC: every cell starts with every (tile, turn); repeatedly the
cell with the fewest options is collapsed (weighted draw), and arc consistency is propagated to
its neighbours; a contradiction restarts with the next seed (bounded). `tiling(tile_set, grid)`
builds the assembly; `corruptions(...)` makes tilings broken in one way each, every one checked
against the tile set's own rules (`rule_violations`), so a test can rely on them being invalid.
Deterministic for a given seed.
"""
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

# directions: 0 east (+x), 1 north (+y), 2 west, 3 south; 4 up, 5 down
STEPS = ((1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))
OPPOSITE = (2, 3, 0, 1, 5, 4)
CHAMFER = 0.15
PLATE_H = 0.2


@dataclass(frozen=True)
class Tile:
    name: str
    sides: tuple[str, str, str, str]  # E, N, W, S sockets, read counter-clockwise
    vertical: tuple[str, str] = ("", "")  # up, down (stacked sets)
    weight: float = 1.0

    def turned(self, k: int) -> tuple[str, ...]:
        """Sockets after k quarter turns counter-clockwise (E, N, W, S, up, down)."""
        s = self.sides
        return tuple(s[(d - k) % 4] for d in range(4)) + self.vertical


@dataclass
class TileSet:
    name: str
    tiles: tuple[Tile, ...]
    dims: int = 2  # 2: a grid of plates, 3: stacked cubes
    options: list[tuple[int, int]] = field(default_factory=list)  # (tile index, turns)

    def __post_init__(self) -> None:
        for i, t in enumerate(self.tiles):
            seen = set()
            for k in range(4):
                s = t.turned(k)
                if s not in seen:
                    seen.add(s)
                    self.options.append((i, k))

    def sockets(self, option: tuple[int, int]) -> tuple[str, ...]:
        return self.tiles[option[0]].turned(option[1])

    def fits(self, a: tuple[int, int], b: tuple[int, int], d: int) -> bool:
        """May option b sit next to option a in direction d of a?"""
        sa, sb = self.sockets(a)[d], self.sockets(b)[OPPOSITE[d]]
        return sa == sb if d >= 4 else sa == sb[::-1]


KNOTS = TileSet("knots", (
    Tile("Empty", ("0", "0", "0", "0")),
    Tile("Cross", ("1", "1", "1", "1")),
    Tile("Line", ("1", "0", "1", "0"), weight=2.0),
    Tile("Corner", ("1", "1", "0", "0"), weight=2.0),
    Tile("Tee", ("1", "1", "1", "0")),
))
CIRCUIT = TileSet("circuit", (
    Tile("Substrate", ("0", "0", "0", "0"), weight=2.0),
    Tile("Wire", ("1", "0", "1", "0")),
    Tile("Track", ("2", "0", "2", "0")),
    Tile("Bridge", ("1", "2", "1", "2"), weight=0.5),
    Tile("Turn", ("1", "1", "0", "0")),
    Tile("Junction", ("1", "1", "1", "0"), weight=0.5),
    Tile("Transition", ("2", "0", "1", "0"), weight=0.5),
))


def _corner_tile(name: str, ne: str, nw: str, sw: str, se: str, weight: float = 1.0) -> Tile:
    # each side read counter-clockwise: E from SE to NE, N from NE to NW, W from NW to SW, S from SW to SE
    return Tile(name, (se + ne, ne + nw, nw + sw, sw + se), weight=weight)


SUMMER = TileSet("summer", (
    _corner_tile("Grass", "g", "g", "g", "g", 2.0),
    _corner_tile("Sand", "s", "s", "s", "s", 2.0),
    _corner_tile("Bay", "s", "g", "g", "g"),
    _corner_tile("Beach", "s", "s", "g", "g"),
    _corner_tile("Diagonal", "s", "g", "s", "g", 0.5),
    _corner_tile("Cape", "s", "s", "s", "g"),
))
PIPES3D = TileSet("pipes3d", (
    Tile("Solid", ("0", "0", "0", "0"), ("0", "0"), 2.0),
    Tile("Straight", ("1", "0", "1", "0"), ("0", "0")),
    Tile("Bend", ("1", "1", "0", "0"), ("0", "0")),
    Tile("Vertical", ("0", "0", "0", "0"), ("1", "1")),
    Tile("Riser", ("1", "0", "0", "0"), ("1", "0")),
    Tile("Drop", ("1", "0", "0", "0"), ("0", "1")),
), dims=3)
SETS = {s.name: s for s in (KNOTS, CIRCUIT, SUMMER, PIPES3D)}

# (width, depth) of the channel each socket letter cuts; "0" and "s" cut none
_CHANNEL = {"1": (0.16, 0.08), "2": (0.08, 0.13), "g": (0.1, 0.06)}


def _box(lo, hi):  # noqa: ANN001, ANN202
    import manifold3d as m3

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return m3.Manifold.cube((hi - lo).tolist()).translate(lo.tolist())


def _hull(points: np.ndarray):  # noqa: ANN202
    import manifold3d as m3

    return m3.Manifold.hull_points(points.tolist())


def _rot2(v: tuple[float, float], d: int) -> tuple[float, float]:
    c, s = round(math.cos(d * math.pi / 2)), round(math.sin(d * math.pi / 2))
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def _side_channels(sock: str, d: int, z_lo: float, z_hi: float) -> list:
    """Channels for one side's socket letters: along the side's outward axis from near the
    centre past the side, letter k at its place along the side (counter-clockwise)."""
    out = []
    n = len(sock)
    for k, ch in enumerate(sock):
        if ch not in _CHANNEL:
            continue
        w, depth = _CHANNEL[ch]
        off = 0.0 if n == 1 else -0.2 + 0.4 * k / (n - 1)
        # in the east side's frame: x outwards, y along the side (counter-clockwise: +y)
        lo, hi = (0.3, off - w / 2), (0.6, off + w / 2)  # apart: no coplanar overlaps
        corners = [_rot2(p, d) for p in (lo, hi)]
        xs, ys = sorted(c[0] for c in corners), sorted(c[1] for c in corners)
        out.append(_box((xs[0], ys[0], z_hi - depth if z_lo is None else z_lo),
                        (xs[1], ys[1], z_hi + 0.1 if z_lo is None else z_lo + depth)))
    return out


@lru_cache(maxsize=None)
def _tile_mesh(set_name: str, index: int) -> trimesh.Trimesh:
    ts = SETS[set_name]
    tile = ts.tiles[index]
    a, c = 0.5, 0.5 - CHAMFER
    if ts.dims == 2:
        ring = np.array([(a, -c), (a, c), (c, a), (-c, a), (-a, c), (-a, -c), (-c, -a), (c, -a)])
        body = _hull(np.array([(x, y, z) for x, y in ring for z in (0.0, PLATE_H)]))
        cuts = [b for d, s in enumerate(tile.sides) for b in _side_channels(s, d, None, PLATE_H)]
    else:
        pts = set()
        for perm in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            for sx in (-1, 1):
                for sy in (-1, 1):
                    for sz in (-1, 1):
                        v = (a * sx, c * sy, c * sz)
                        pts.add(tuple(v[perm.index(i)] for i in range(3)))
        body = _hull(np.array(sorted(pts)) + [0, 0, 0.5])
        # horizontal pipes: tunnels at mid height, from the centre out through the side
        cuts = [b for d, s in enumerate(tile.sides) for b in _side_channels(s, d, 0.42, 0.0)]
        up, down = tile.vertical
        if up == "1" or down == "1":
            cuts.append(_box((-0.08, -0.08, 0.3 if down != "1" else -0.1), (0.08, 0.08, 0.7 if up != "1" else 1.1)))
    for cut in cuts:
        body = body - cut
    mesh = body.to_mesh()
    return trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts), process=False)


def tile_meshes(ts: TileSet) -> dict[str, trimesh.Trimesh]:
    return {t.name: _tile_mesh(ts.name, i).copy() for i, t in enumerate(ts.tiles)}


# --------------------------------------------------------------------------------------------
# WFC
# --------------------------------------------------------------------------------------------
Grid = dict  # {(i, j, k): option index or None (a hole)}


def _cells(size: tuple[int, ...]) -> list[tuple[int, int, int]]:
    nx, ny, nz = (*size, 1)[:3]
    return [(i, j, k) for k in range(nz) for j in range(ny) for i in range(nx)]


def _neighbour(cell, d):  # noqa: ANN001, ANN202
    return tuple(c + s for c, s in zip(cell, STEPS[d]))


def _directions(ts: TileSet) -> range:
    return range(6) if ts.dims == 3 else range(4)


def solve(ts: TileSet, size: tuple[int, ...], seed: int = 0, restarts: int = 200) -> Grid:
    """A valid tiling of `size` cells (nx, ny[, nz]) by WFC: min-count observation, weighted
    draw, arc-consistency propagation; a contradiction restarts with the next seed."""
    n_opt = len(ts.options)
    fits = {(a, d): {b for b in range(n_opt) if ts.fits(ts.options[a], ts.options[b], d)}
            for a in range(n_opt) for d in _directions(ts)}
    weights = [ts.tiles[i].weight for i, _ in ts.options]
    cells = _cells(size)
    inside = set(cells)
    for attempt in range(restarts):
        rng = random.Random(seed * 7919 + attempt)
        domain = {c: set(range(n_opt)) for c in cells}
        ok = True
        while ok:
            open_cells = [c for c in cells if len(domain[c]) > 1]
            if not open_cells:
                break
            fewest = min(len(domain[c]) for c in open_cells)
            cell = rng.choice([c for c in open_cells if len(domain[c]) == fewest])
            opts = sorted(domain[cell])
            domain[cell] = {rng.choices(opts, [weights[o] for o in opts])[0]}
            queue = [cell]
            while queue and ok:
                a = queue.pop()
                for d in _directions(ts):
                    b = _neighbour(a, d)
                    if b not in inside:
                        continue
                    allowed = set().union(*(fits[(o, d)] for o in domain[a]))
                    shrunk = domain[b] & allowed
                    if shrunk != domain[b]:
                        if not shrunk:
                            ok = False
                            break
                        domain[b] = shrunk
                        queue.append(b)
        if ok:
            return {c: next(iter(domain[c])) for c in cells}
    raise RuntimeError(f"WFC found no {ts.name} tiling of {size} in {restarts} restarts")


def rule_violations(ts: TileSet, grid: Grid) -> list[str]:
    """The tile set's own verdict: every face-neighbour pair that does not fit, and every
    empty cell (a hole: the grids are filled)."""
    out = []
    for cell, o in grid.items():
        if o is None:
            out.append(f"hole at {cell}")
            continue
        for d in _directions(ts):
            b = _neighbour(cell, d)
            if grid.get(b) is not None and not ts.fits(ts.options[o], ts.options[grid[b]], d):
                out.append(f"{cell} -> {b}")
    return out


def tiling(ts: TileSet, grid: Grid, name: str, offset=(0.0, 0.0, 0.0)) -> Assembly:  # noqa: ANN001
    """The assembly of a grid: one part per filled cell, its tile turned and moved into place."""
    counts: dict[str, int] = {}
    parts = []
    for cell in sorted(grid, key=lambda c: (c[2], c[1], c[0])):
        o = grid[cell]
        if o is None:
            continue
        ti, turns = ts.options[o]
        t = ts.tiles[ti].name
        T = trimesh.transformations.rotation_matrix(turns * math.pi / 2, (0, 0, 1))
        T[:3, 3] = (cell[0] + 0.5 + offset[0], cell[1] + 0.5 + offset[1], cell[2] + offset[2])
        mesh = _tile_mesh(ts.name, ti).copy()
        mesh.apply_transform(T)
        k = counts.get(t, 0)
        counts[t] = k + 1
        parts.append(Part(f"{t}.{k}", t, mesh, T))
    return Assembly(parts, name=name)


def _interior(ts: TileSet, grid: Grid, cell) -> bool:  # noqa: ANN001
    return all(grid.get(_neighbour(cell, d)) is not None for d in _directions(ts))


def corruptions(ts: TileSet, grid: Grid, seed: int = 0, per_kind: int = 2,
                seen_pairs: set[frozenset] | None = None) -> dict[str, list[Grid]]:
    """Grids broken in one way each, every one invalid by `rule_violations`:

    - `rotated`: one tile turned in place by a quarter, a half or three quarters;
    - `direction`: two neighbouring tiles exchanged, so each pair now meets in a direction
      the rules do not allow (the same tiles and turns, only their order along an axis);
    - `unseen pair`: one tile replaced by another tile (any turn) so that it meets a neighbour
      across a side it may not; types that never touch in `seen_pairs` are tried first;
    - `hole`: one interior cell (every face neighbour present) left empty."""
    rng = random.Random(seed)
    cells = sorted(grid)
    out: dict[str, list[Grid]] = {"rotated": [], "direction": [], "unseen pair": [], "hole": []}

    def bad(g: Grid) -> bool:
        return any(not v.startswith("hole") for v in rule_violations(ts, g))

    def take(kind: str, candidates: list[Grid]) -> None:
        rng.shuffle(candidates)
        keep = [g for g in candidates if bad(g)][:per_kind]
        out[kind].extend(keep)

    rot = []
    for c in cells:
        ti, k = ts.options[grid[c]]
        for dk in (1, 2, 3):
            o = ts.options.index((ti, (k + dk) % 4)) if (ti, (k + dk) % 4) in ts.options else None
            if o is not None and o != grid[c]:
                rot.append({**grid, c: o})
    take("rotated", rot)
    swaps = []
    for c in cells:
        for d in _directions(ts):
            b = _neighbour(c, d)
            if d in (0, 1, 4) and b in grid and grid[b] != grid[c]:
                swaps.append({**grid, c: grid[b], b: grid[c]})
    take("direction", swaps)
    subs, strangers = [], []
    for c in cells:
        here = ts.options[grid[c]][0]
        for o, (ti, _) in enumerate(ts.options):
            if ti == here:
                continue
            g = {**grid, c: o}
            near = {ts.tiles[ts.options[grid[_neighbour(c, d)]][0]].name
                    for d in _directions(ts) if grid.get(_neighbour(c, d)) is not None}
            new = ts.tiles[ti].name
            if seen_pairs is not None and any(frozenset((new, m)) not in seen_pairs for m in near):
                strangers.append(g)
            else:
                subs.append(g)
    rng.shuffle(strangers)
    take("unseen pair", [g for g in strangers if bad(g)][:1] + subs)
    holes = [{**grid, c: None} for c in cells if _interior(ts, grid, c)]
    rng.shuffle(holes)
    out["hole"] = holes[:per_kind]
    return out


def type_pairs(ts: TileSet, grid: Grid) -> set[frozenset]:
    """The unordered pairs of tile types that touch in a grid."""
    out = set()
    for c, o in grid.items():
        for d in _directions(ts):
            b = grid.get(_neighbour(c, d))
            if o is not None and b is not None:
                out.add(frozenset((ts.tiles[ts.options[o][0]].name, ts.tiles[ts.options[b][0]].name)))
    return out


# training and held-out sizes per set: held-out ones are other sizes and shapes
TRAINING_SIZES = {2: [(5, 5), (6, 4), (4, 6), (6, 6), (7, 5), (5, 7)],
                  3: [(4, 4, 3), (5, 3, 3), (3, 5, 3), (4, 4, 4)]}
HELD_OUT_SIZES = {2: [(8, 6), (4, 4), (9, 4), (3, 8), (7, 7)],
                  3: [(5, 4, 3), (3, 3, 4), (6, 3, 3)]}


KINDS = ("rotated", "direction", "unseen pair", "hole")


def acceptance(ts: TileSet, folder: Path, *, held_out: int | None = None, per_kind: int = 2,
               seed: int = 0, **learn_options) -> dict:
    """Issue 28's acceptance on one tile set: learn (grammarkit defaults unless
    `learn_options` say otherwise) from WFC tilings of TRAINING_SIZES written as GLB files,
    print the grammar to `folder` and load it back, then validate held-out WFC tilings of
    HELD_OUT_SIZES (other seeds and sizes) and `per_kind` corruptions of each per kind.
    Returns {"accepted": (n, total), kind: (rejected, total), "failures": [...], "grammar": path}."""
    from grammarkit.dsl import load
    from grammarkit.printer import print_grammar
    from grammarkit.tiling import learn, validate, write_assembly

    folder.mkdir(parents=True, exist_ok=True)
    train_grids = [solve(ts, size, seed * 1000 + 10 + i) for i, size in enumerate(TRAINING_SIZES[ts.dims])]
    files = [write_assembly(tiling(ts, g, f"{ts.name}_train{i}"), folder / f"{ts.name}_train{i}.glb")
             for i, g in enumerate(train_grids)]
    grammar = learn(files, name=ts.name, **learn_options)
    path = folder / f"{ts.name}.grammar"
    path.write_text(print_grammar(grammar))
    grammar = load(path)
    seen = set().union(*(type_pairs(ts, g) for g in train_grids))
    sizes = HELD_OUT_SIZES[ts.dims][:held_out]
    result: dict = {"accepted": [0, 0], **{k: [0, 0] for k in KINDS}, "failures": [], "grammar": path}
    for i, size in enumerate(sizes):
        grid = solve(ts, size, seed * 1000 + 100 + i)
        assert not rule_violations(ts, grid)
        report = validate(grammar, tiling(ts, grid, f"{ts.name}_held{i}"))
        result["accepted"][0] += report.ok
        result["accepted"][1] += 1
        if not report.ok:
            result["failures"].append(f"held-out {size}: {report.format()}")
        for kind, grids in corruptions(ts, grid, seed + i, per_kind, seen).items():
            for k, bad in enumerate(grids):
                ok = validate(grammar, tiling(ts, bad, f"{ts.name}_held{i}_{kind}{k}")).ok
                result[kind][0] += not ok
                result[kind][1] += 1
                if ok:
                    result["failures"].append(f"{kind} of held-out {size} accepted: {rule_violations(ts, bad)}")
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=sorted(SETS), default="knots")
    ap.add_argument("--size", type=int, nargs="+", default=[6, 5])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--out", type=Path, default=Path("tiling.glb"))
    args = ap.parse_args(argv)
    from grammarkit.tiling import write_assembly

    ts = SETS[args.set]
    grid = solve(ts, tuple(args.size), args.seed)
    write_assembly(tiling(ts, grid, f"{ts.name}_{'x'.join(map(str, args.size))}_s{args.seed}"), args.out)
    print(f"{args.out}: {len(grid)} tiles, rule violations: {len(rule_violations(ts, grid))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
