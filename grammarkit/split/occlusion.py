"""CGA's occlusion queries `inside()`, `overlaps()`, `touches()` and the `label()` operation.

The queries test the current shape's geometry against the *occluders* of the model derived
so far: every terminal made before (volumes and faces), and every shape given a label with
`label("name")` (its geometry at that moment). Shapes the current shape descends from are
never occluders of it (they contain it). `inside("intra", "wall")` looks only at occluders
labelled "wall". The targets are CGA's: `"intra"` (this building's shapes; the default) and
`"all"` mean the same here, because a derivation builds one lot; `"inter"` (other lots) finds
nothing.

Candidates are found by their scope boxes in an R-tree (the `rtree` package, a grammarkit
dependency); only those are built as solids (once) and tested exactly with manifold3d booleans:

- `overlaps()`: the shape shrunk by a tolerance T (1 mm) on every side intersects an occluder;
- `touches()`: it does not overlap any, but the shape grown by T intersects one (shared faces,
  edges or corners);
- `inside()`: the shrunk shape minus the union of the occluders is empty (within 1e-9 of its
  volume), and it overlaps one.

A face is a slab (±T/10 shrunk, ±T grown) about its plane; edges and vertices (no area) are
never inside, overlapping or touching anything.

Open surfaces (a `SurfaceMesh`: an inserted asset whose mesh is not closed, a face turned out
of its scope plane) follow CGA's reference ("inside / overlaps / touches": the tests are made
only against geometry that forms a closed surface, a watertight mesh without border edges):

- as an *occluder* an open surface is never seen (it has no inside), in either surfaces mode
  (the default mode closes such a mesh for the written solid, but the query is about the
  geometry CGA inserted, and a derivation must not depend on its output mode);
- as the *queried* shape it is tested by its geometry, as a face is: each triangle a slab
  (±T/10 thick, the mesh shrunk by T; ±T grown) about its plane.

Anything a query still cannot evaluate is a located DerivationError naming the query and the
rule, never an internal error.
"""
from __future__ import annotations

import threading
from typing import Any

import manifold3d

from ..geometry.footprints import cross_section
from ..geometry.solids import frame_matrix
from ..geometry.surfaces import SurfaceMesh
from .shape import FACE, Shape, fail

__all__ = ["OCCLUSION_FUNCTIONS", "Occlusion", "TOLERANCE", "active", "query"]

Manifold = manifold3d.Manifold
TOLERANCE = 1e-3
OCCLUSION_FUNCTIONS = ("inside", "overlaps", "touches")
TARGETS = ("intra", "inter", "all")

_active = threading.local()  # the derivation running on this thread (Derivation.run sets it)


def active() -> Any:
    return getattr(_active, "derivation", None)


def set_active(derivation: Any) -> Any:
    previous = getattr(_active, "derivation", None)
    _active.derivation = derivation
    return previous


def _solid(s: Shape, grow: float, thick: float) -> Any:
    """The shape's geometry in world coordinates, grown (grow > 0) or shrunk by `grow` on every
    side; a face as a slab of half-thickness `thick`. None without area or volume."""
    from .scope_solid import local_solid

    sx, sy, sz = s.sz
    if s.kind == FACE:
        if sx <= 1e-9 or sy <= 1e-9:
            return None
        base = Manifold.extrude(cross_section(s.contours()), 2 * thick).translate((0.0, 0.0, -thick))
        dims = (sx, sy, 0.0)
    elif isinstance(s.solid, SurfaceMesh):
        # an open surface, queried: by its geometry, as a face (see the module doc)
        mesh = s.solid
        if grow:
            x0, y0, z0, x1, y1, z1 = mesh.bounding_box()
            c = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
            f = [max(d + 2 * grow, 0.0) / d if d > 1e-9 else 1.0 for d in (x1 - x0, y1 - y0, z1 - z0)]
            if min(f) <= 0:
                return None
            mesh = mesh.translate(tuple(-v for v in c)).scale(tuple(f)).translate(c)
        base = _mesh_slabs(mesh, thick if grow <= 0 else grow)
        if base is None:
            return None
        solid = base.transform(frame_matrix(s.o, s.ax))
        return None if solid.is_empty() else solid
    else:
        base, _oid, _n = local_solid(s)
        if base is None:
            return None
        x0, y0, z0, x1, y1, z1 = base.bounding_box()
        dims = (x1 - x0, y1 - y0, z1 - z0)
        sx, sy, sz = dims
    if grow:
        x0, y0, z0, x1, y1, z1 = base.bounding_box()
        c = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
        f = [max(d + 2 * grow, 0.0) / d if d > 1e-9 else 1.0 for d in dims]
        if min(f) <= 0:
            return None
        base = base.translate(tuple(-v for v in c)).scale(tuple(f)).translate(c)
    solid = base.transform(frame_matrix(s.o, s.ax))
    return None if solid.is_empty() else solid


def _mesh_slabs(mesh: SurfaceMesh, thick: float) -> Any:
    """The triangles of an open mesh, each a slab of half-thickness `thick` about its plane,
    united; None without area."""
    import numpy as np

    from ..geometry.surfaces import unit_normals

    keep, n, _ = unit_normals(mesh.V, mesh.F)
    if not keep.any():
        return None
    n = n * thick
    tris = mesh.V[mesh.F[keep]]  # (T, 3, 3)
    pieces = []
    for tri, d in zip(tris, n):
        pts = np.vstack([tri + d, tri - d])
        piece = Manifold.hull_points(np.ascontiguousarray(pts, dtype=np.float64))
        if not piece.is_empty():
            pieces.append(piece)
    if not pieces:
        return None
    return pieces[0] if len(pieces) == 1 else Manifold.batch_boolean(pieces, manifold3d.OpType.Add)


class Occlusion:
    """The occluders of one derivation: (tree node, label, world solid) with an R-tree of their
    bounding boxes."""

    def __init__(self) -> None:
        # (tree node, label, the shape, its solid once a query needed it)
        self.items: list[list] = []
        self._index: Any = None

    def add(self, s: Shape, label: str | None) -> None:
        if s.kind == FACE and (s.sz[0] <= 1e-9 or s.sz[1] <= 1e-9):
            return  # an edge or a vertex: never an occluder
        if isinstance(s.solid, SurfaceMesh):
            return  # an open surface: CGA tests only against closed geometry (module doc)
        if self._index is None:
            from rtree import index

            props = index.Property()
            props.dimension = 3
            self._index = index.Index(properties=props)
        # the scope box (which holds the geometry) grown by the tolerance: the solid itself is
        # built only when a query's box meets this one
        self._index.insert(len(self.items), _scope_box(s))
        self.items.append([s.node, label, s, None])

    def candidates(self, box: tuple, exclude: set[int], label: str | None) -> list[Any]:
        if self._index is None:
            return []
        out = []
        for i in sorted(self._index.intersection(box)):  # deterministic order
            item = self.items[i]
            if item[0] in exclude or (label is not None and item[1] != label):
                continue
            if item[3] is None:
                item[3] = _solid(item[2], 0.0, TOLERANCE / 10) or False
            if item[3] is not False:
                out.append(item[3])
        return out


def _scope_box(s: Shape) -> tuple:
    """World bounding box of the scope, grown by the tolerance."""
    xs, ys, zs = [], [], []
    for cx in (0.0, s.sz[0]):
        for cy in (0.0, s.sz[1]):
            for cz in (0.0, s.sz[2]):
                x, y, z = s.world(cx, cy, cz)
                xs.append(x)
                ys.append(y)
                zs.append(z)
    t = TOLERANCE
    return (min(xs) - t, min(ys) - t, min(zs) - t, max(xs) + t, max(ys) + t, max(zs) + t)


def _ancestors(derivation: Any, node: int) -> set[int]:
    out = {node}
    nodes = derivation.nodes
    while 0 <= node < len(nodes):
        node = nodes[node][0]
        out.add(node)
    return out


def _volume(m: Any) -> float:
    return 0.0 if m.is_empty() else abs(m.volume())


def query(kind: str, s: Shape, target: str = "intra", label: str | None = None) -> bool:
    """`inside()`, `overlaps()` or `touches()` of shape `s` (see the module doc)."""
    if target not in TARGETS:
        raise ValueError(f"{kind}(): the target must be one of {', '.join(TARGETS)}, got {target!r}")
    derivation = active()
    if derivation is None or target == "inter":
        return False
    try:
        return _query(kind, s, derivation, label)
    except Exception as exc:  # noqa: BLE001 - a located error, never an internal one
        from ..errors import GrammarkitError

        if isinstance(exc, GrammarkitError):
            raise
        raise fail(s, f"{kind}(): the occlusion query cannot be evaluated on this shape "
                      f"({'a face' if s.kind == FACE else 'a volume'} of size "
                      f"{' x '.join(f'{v:g}' for v in s.sz)}): {type(exc).__name__}: {exc}") from exc


def _query(kind: str, s: Shape, derivation: Any, label: str | None) -> bool:
    occ = derivation.occlusion
    if occ is None or not occ.items:
        return False
    grown = _solid(s, TOLERANCE, TOLERANCE)
    if grown is None:
        return False
    x0, y0, z0, x1, y1, z1 = grown.bounding_box()
    found = occ.candidates((x0, y0, z0, x1, y1, z1), _ancestors(derivation, s.node), label)
    if not found:
        return False
    shrunk = _solid(s, -TOLERANCE, TOLERANCE / 10)
    vol = _volume(shrunk) if shrunk is not None else 0.0
    eps = 1e-12 + 1e-9 * vol
    overlapping = [b for b in found if shrunk is not None and _volume(shrunk ^ b) > eps]
    if kind == "overlaps":
        return bool(overlapping)
    if kind == "inside":
        if not overlapping:
            return False
        union = overlapping[0] if len(overlapping) == 1 else Manifold.batch_boolean(
            overlapping, manifold3d.OpType.Add)
        return _volume(shrunk - union) <= eps
    # touches: in contact (the grown shape meets one) but overlapping none
    if overlapping:
        return False
    return any(_volume(grown ^ b) > 1e-15 for b in found)
