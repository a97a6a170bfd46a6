"""Inputs built apart from everything else in the project, to attack `learn` and `validate`
(issue 28, hostile round): a triangle tile set with edge sockets, a stacked-block set with
cantilevered overhangs, and a chiral part placed at quarter turns and mirrored.

Nothing here uses grammars/tiling/: the geometry is made with manifold3d, the tilings by an
edge-labelling generator (choose a socket for every edge of a triangle grid, then each
triangle's tile and turn follow from its three edges: every tiling made is valid by
construction), and every corruption is judged broken by `triangle_socket_errors`, which reads
only the placed parts' poses (a Kabsch fit to the prototype) and the sockets.
"""
from __future__ import annotations

import math
import random

import numpy as np
import trimesh

from grammarkit.tiling import Assembly, Part

SQ3 = math.sqrt(3.0)
PLATE = 0.15
# a triangle tile's sockets, counter-clockwise from the edge opposite its first corner;
# "r" is a raised road to the edge's midpoint, "-" is none. The tile types are the distinct
# socket triples up to turns: Blank (---, z3), End (r--, none), Bend (rr-, none), Hub (rrr, z3).
TILES = {"Blank": "---", "End": "r--", "Bend": "rr-", "Hub": "rrr"}


def _m3():  # noqa: ANN202
    import manifold3d as m3

    return m3


def _mesh(body) -> trimesh.Trimesh:  # noqa: ANN001
    m = body.to_mesh()
    return trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts), process=False)


def _corners() -> np.ndarray:
    """An 'up' triangle of side 1 centred on its centroid (corner 0 at the top)."""
    r = 1.0 / SQ3
    return np.array([[r * math.cos(math.radians(a)), r * math.sin(math.radians(a))] for a in (90, 210, 330)])


def triangle_mesh(tile: str, scale: float = 1.0) -> trimesh.Trimesh:
    """A triangular plate with a ridge from near its centre to the midpoint of every road edge.
    Edge k is the one opposite corner k."""
    m3 = _m3()
    c = _corners()
    body = m3.CrossSection([c.tolist()]).extrude(PLATE)
    for k, sock in enumerate(TILES[tile]):
        if sock != "r":
            continue
        a, b = c[(k + 1) % 3], c[(k + 2) % 3]
        mid = (a + b) / 2
        ang = math.degrees(math.atan2(mid[1], mid[0]))
        length = float(np.linalg.norm(mid))
        ridge = m3.Manifold.cube([length - 0.05, 0.1, 0.06]).translate([0.05, -0.05, PLATE])
        body = body + ridge.rotate([0, 0, ang])
    mesh = _mesh(body)
    mesh.vertices *= scale
    return mesh


def _lattice(i: int, j: int) -> np.ndarray:
    return np.array([i + 0.5 * j, SQ3 / 2 * j])


def triangle_cells(nx: int, ny: int) -> list[tuple[int, int, int]]:
    """(i, j, d): d = 0 the up triangle of rhombus (i, j), d = 1 its down triangle."""
    return [(i, j, d) for j in range(ny) for i in range(nx) for d in (0, 1)]


def _cell_edges(cell: tuple[int, int, int]) -> list[tuple]:
    """The cell's three edges as sorted lattice-point pairs, edge k opposite corner k, with
    corners counter-clockwise starting from the apex (up: top corner; down: bottom corner)."""
    i, j, d = cell
    if d == 0:
        pts = [(i, j + 1), (i, j), (i + 1, j)]  # apex at top, then lower left, lower right
    else:
        pts = [(i + 1, j), (i + 1, j + 1), (i, j + 1)]  # apex at bottom, upper right, upper left
    return [tuple(sorted((pts[(k + 1) % 3], pts[(k + 2) % 3]))) for k in range(3)]


def _tile_and_turn(socks: tuple[str, str, str]) -> tuple[str, int]:
    for name, pattern in TILES.items():
        for turn in range(3):
            # turning the tile by `turn` thirds moves its edge k to position k + turn
            if tuple(pattern[(k - turn) % 3] for k in range(3)) == socks:
                return name, turn
    raise AssertionError(socks)


def triangle_grid(nx: int, ny: int, seed: int, p_road: float = 0.45) -> dict:
    """{cell: (tile, turn)}: a random road label on every edge; a tiling valid by construction.
    Border edges get no road (a road leads nowhere off the tiling)."""
    rng = random.Random(seed)
    cells = triangle_cells(nx, ny)
    count: dict[tuple, int] = {}
    for c in cells:
        for e in _cell_edges(c):
            count[e] = count.get(e, 0) + 1
    label = {e: ("r" if n == 2 and rng.random() < p_road else "-") for e, n in sorted(count.items())}
    return {c: _tile_and_turn(tuple(label[e] for e in _cell_edges(c))) for c in cells}


def triangle_pose(cell: tuple[int, int, int], turn: int, yaw: float = 0.0, scale: float = 1.0) -> np.ndarray:
    i, j, d = cell
    if d == 0:
        centre = (_lattice(i, j) + _lattice(i + 1, j) + _lattice(i, j + 1)) / 3
    else:
        centre = (_lattice(i + 1, j) + _lattice(i + 1, j + 1) + _lattice(i, j + 1)) / 3
    angle = 120.0 * turn + (180.0 if d else 0.0)
    T = trimesh.transformations.rotation_matrix(math.radians(angle), (0, 0, 1))
    T[:2, 3] = centre * scale
    W = trimesh.transformations.rotation_matrix(math.radians(yaw), (0, 0, 1))
    return W @ T


def triangle_tiling(grid: dict, name: str, *, yaw: float = 0.0, scale: float = 1.0,
                    edits: dict | None = None) -> Assembly:
    """The assembly of a grid; `edits` maps a cell to a 4x4 matrix applied after its pose in
    world coordinates, or to None to leave the cell empty."""
    parts = []
    counts: dict[str, int] = {}
    for cell in sorted(grid, key=lambda c: (c[1], c[0], c[2])):
        tile, turn = grid[cell]
        T = triangle_pose(cell, turn, yaw, scale)
        if edits and cell in edits:
            if edits[cell] is None:
                continue
            T = edits[cell] @ T
        mesh = triangle_mesh(tile, scale)
        mesh.apply_transform(T)
        k = counts.get(tile, 0)
        counts[tile] = k + 1
        parts.append(Part(f"{tile}.{k}", tile, mesh, T))
    return Assembly(parts, name=name)


def interior_cells(grid: dict) -> list:
    """Cells all three of whose edges are shared with another cell."""
    count: dict[tuple, int] = {}
    for c in grid:
        for e in _cell_edges(c):
            count[e] = count.get(e, 0) + 1
    return [c for c in grid if all(count[e] == 2 for e in _cell_edges(c))]


def triangle_socket_errors(grid: dict) -> list[str]:
    """The independent judge: every shared edge has the same socket on both sides."""
    seen: dict[tuple, str] = {}
    errors = []
    for c, (tile, turn) in grid.items():
        for k, e in enumerate(_cell_edges(c)):
            s = TILES[tile][(k - turn) % 3]
            if e in seen and seen[e] != s:
                errors.append(f"{c} edge {e}: {s} meets {seen[e]}")
            seen.setdefault(e, s)
    return errors


def about(T_part: np.ndarray, M: np.ndarray) -> np.ndarray:
    """M applied about the part's own origin (its pose's translation), in world axes."""
    c = np.eye(4)
    c[:3, 3] = T_part[:3, 3]
    return c @ M @ np.linalg.inv(c)


def rot_z(deg: float) -> np.ndarray:
    return trimesh.transformations.rotation_matrix(math.radians(deg), (0, 0, 1))


# --------------------------------------------------------------------------------------------
# stacked blocks with cantilevered overhangs (support and max_span)
# --------------------------------------------------------------------------------------------
def _box_mesh(ext, centre) -> trimesh.Trimesh:  # noqa: ANN001
    m = trimesh.creation.box(extents=ext)
    m.apply_translation(centre)
    return m


def stack(columns: list[int], overhangs: list[tuple[int, int, int]], name: str,
          lift: dict | None = None) -> Assembly:
    """Columns of unit Blocks on a Slab (x = 0, 4, 8, ... metres), and Ledges: (column, storey,
    length) is a run of `length` 1 x 1 x 0.3 ledges out of the column's +x face at that storey,
    each held only by the side of the previous one (a cantilever). `lift` moves a part by id."""
    parts = []
    width = 4.0 * len(columns)
    parts.append(Part("Slab.0", "Slab", _box_mesh((width, 3, 0.4), (width / 2 - 0.5, 0, 0.2)),
                      _translation((width / 2 - 0.5, 0, 0.2))))
    nb = nl = 0
    for c, h in enumerate(columns):
        for s in range(h):
            centre = (4.0 * c, 0, 0.4 + 0.5 + s)
            parts.append(Part(f"Block.{nb}", "Block", _box_mesh((1, 1, 1), centre), _translation(centre)))
            nb += 1
    for c, s, length in overhangs:
        for k in range(length):
            centre = (4.0 * c + 1.0 + k, 0, 0.4 + s + 0.15)
            parts.append(Part(f"Ledge.{nl}", "Ledge", _box_mesh((1, 1, 0.3), centre), _translation(centre)))
            nl += 1
    if lift:
        parts = [p.transformed(_translation(lift[p.id])) if p.id in lift else p for p in parts]
    return Assembly(parts, name=name)


def _translation(t) -> np.ndarray:  # noqa: ANN001
    T = np.eye(4)
    T[:3, 3] = t
    return T


# --------------------------------------------------------------------------------------------
# a chiral part (an L with a notch) at quarter turns, and mirrored
# --------------------------------------------------------------------------------------------
def chiral_mesh() -> trimesh.Trimesh:
    """A flat L: a 2 x 1 bar with a 1 x 1 foot on its +y side at its -x end, and a small
    cube on top of the foot's +x side so that no mirror plane maps it to itself."""
    m3 = _m3()
    body = (m3.Manifold.cube([2, 1, 0.5]).translate([-1, -1, 0]) + m3.Manifold.cube([1, 1, 0.5]).translate([-1, 0, 0])
            + m3.Manifold.cube([0.3, 0.3, 0.3]).translate([-0.4, 0.6, 0.5]))
    return _mesh(body)


def pinwheel(n: int, name: str, *, mirror_one: int | None = None, turns=(0, 90, 180, 270)) -> Assembly:  # noqa: ANN001
    """Square Pads in a row along x, each with an L on top turned by turns[k % 4] degrees;
    `mirror_one`: that L is reflected (y -> -y) in its own frame, the node transform keeps
    the reflection (a modeller's scale -1)."""
    parts = []
    for k in range(n):
        pad_c = (3.0 * k, 0, 0.25)
        parts.append(Part(f"Pad.{k}", "Pad", _box_mesh((3, 3, 0.5), pad_c), _translation(pad_c)))
        T = rot_z(turns[k % len(turns)])
        T[:3, 3] = (3.0 * k, 0, 0.5)
        if mirror_one == k:
            T = T @ np.diag([1.0, -1.0, 1.0, 1.0])
        mesh = chiral_mesh()
        mesh.apply_transform(T)
        if np.linalg.det(T[:3, :3]) < 0:
            mesh.invert()
        parts.append(Part(f"Ell.{k}", "Ell", mesh, T))
    return Assembly(parts, name=name)
