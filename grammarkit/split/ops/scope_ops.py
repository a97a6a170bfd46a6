"""Scope operations that turn or flip the scope but not the geometry (CGA's rotateScope,
alignScopeToAxes, alignScopeToGeometry, mirrorScope), and `mirror`, which flips the geometry
inside the scope.

CGA's semantics (its reference manual): the geometry stays where it is in the world; the new
scope's axes are the turned ones and its origin and size are the geometry's bounding box in
them. grammarkit's geometry kinds constrain how the result is carried:

- a turn about the scope's z axis keeps every kind as it is (the outline is turned in its
  plane: `turn_scope`);
- a box turned by multiples of 90 degrees stays a box (its sizes permuted); a footprint prism
  turned upside down stays a prism (its outline mirrored);
- any other turn of a volume makes it a general solid (manifold3d) in the new scope: still
  watertight, split, comp'd and emitted like a roof or an insert;
- a face keeps its outline in the scope's xy plane with z its normal. A turn that takes the
  face out of that plane (or turns its normal to -z) makes it an open surface mesh in the new
  scope (as an inserted open asset: it can be moved, split, comp'd back into faces, textured
  and emitted in the surface layer). One still lying in a plane of the new scope (turned
  over by a half turn about an axis in its plane, or into the xz/yz plane by a quarter turn)
  is still a face for the operations that work in its plane (setbacks, shapeL/U/O,
  innerRectangle, offset, splitArea: grammarkit/split/turned.py), and `extrude` follows its
  geometry's normal, as CGA's does.

grammarkit's scopes are right-handed (z = x cross y, which faces and comp rely on), so
`mirrorScope` flips an even number of axes (a half turn); flipping one or three is an error.
"""
from __future__ import annotations

import math
from typing import Any


from ...registry import Param
from ..shape import FACE, VOLUME, Shape
from .helpers import fp, lazy_module, operation

np = lazy_module("numpy")

__all__ = ["op_align_scope_to_geometry", "op_align_scope_to_axes", "op_mirror", "op_mirror_scope",
           "op_reverse_normals", "op_rotate_scope", "reframe", "turn_scope"]

EPS = 1e-9
_TOL = 1e-9  # a matrix entry this close to 0 or +-1 is taken as exact (axis-aligned turns)

Mat = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


def _rect_or_poly(poly: Any, sx: float, sy: float) -> Any:
    if len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7):
        return None
    return poly


def turn_scope(s: Shape, ux: float, uy: float) -> Shape:
    """`s` with its scope turned about z so that the new x axis is (ux, uy) in the old scope's
    xy coordinates (a unit vector); the geometry stays where it is in the world."""
    if abs(ux - 1.0) < 1e-12 and abs(uy) < 1e-12:
        return s
    ex, ey, ez = s.ax
    nx = tuple(ux * ex[k] + uy * ey[k] for k in range(3))
    ny = tuple(-uy * ex[k] + ux * ey[k] for k in range(3))

    def to_new(x: float, y: float) -> tuple[float, float]:
        return x * ux + y * uy, -x * uy + y * ux
    rings = [[to_new(x, y) for x, y in c] for c in s.contours()]
    c = s.copy()
    if s.solid is not None:
        # a general solid (roof, insert): turn it with the scope, then re-fit the box to it
        m = [[ux, uy, 0.0, 0.0], [-uy, ux, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
        solid = s.solid.transform(m)
        x0, y0, z0, x1, y1, z1 = solid.bounding_box()
        c.solid = solid.translate((-x0, -y0, -z0))
        c.o = tuple(s.o[k] + nx[k] * x0 + ny[k] * y0 + ez[k] * z0 for k in range(3))  # type: ignore[assignment]
        c.sz = (x1 - x0, y1 - y0, z1 - z0)
        c.ax = (nx, ny, ez)  # type: ignore[assignment]
        c.poly = None
        return c
    pts = [p for r in rings for p in r]
    x0 = min(p[0] for p in pts)
    y0 = min(p[1] for p in pts)
    x1 = max(p[0] for p in pts)
    y1 = max(p[1] for p in pts)
    poly = tuple(tuple((x - x0, y - y0) for x, y in r) for r in rings)
    c.o = tuple(s.o[k] + nx[k] * x0 + ny[k] * y0 for k in range(3))  # type: ignore[assignment]
    c.ax = (nx, ny, ez)  # type: ignore[assignment]
    c.sz = (x1 - x0, y1 - y0, s.sz[2])
    c.poly = _rect_or_poly(poly, x1 - x0, y1 - y0)
    return c


# -- the general change of scope ---------------------------------------------------------------
def _snap(A: Any) -> Mat:
    """Entries within _TOL of 0 or +-1 made exact (cos(90) is 6e-17, not 0)."""
    def one(v: float) -> float:
        for t in (0.0, 1.0, -1.0):
            if abs(v - t) < _TOL:
                return t
        return float(v)
    return tuple(tuple(one(v) for v in row) for row in A)  # type: ignore[return-value]


def _is_signed_permutation(A: Mat) -> bool:
    return all(sum(1 for v in row if v != 0.0) == 1 and all(v in (0.0, 1.0, -1.0) for v in row)
               for row in A)


def _as_mesh(s: Shape) -> Any:
    """The geometry of `s` in its scope coordinates as a manifold3d solid (a volume) or an
    open SurfaceMesh (a face, a volume without thickness, an open insert)."""
    from ...geometry.surfaces import SurfaceMesh, face_triangles
    from ..scope_solid import local_solid

    if s.solid is not None:
        return s.solid
    if s.kind == VOLUME:
        solid, _, _ = local_solid(s)
        if solid is not None:
            return solid
    V, F = face_triangles((0.0, 0.0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), s.sz, s.poly)
    return SurfaceMesh(V, F)


def reframe(s: Shape, A: Any) -> Shape:
    """`s` with the scope whose axes are the rows of `A` (unit vectors in the old scope's
    coordinates, right-handed); the geometry stays in the world, and the new scope's origin
    and size are its bounding box along the new axes (CGA's rotateScope / alignScope*)."""
    A = _snap(A)
    if abs(np.linalg.det(np.asarray(A)) - 1.0) > 1e-6:
        raise ValueError("the new scope axes must be orthonormal and right-handed")
    if A == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        return s
    if A[2] == (0.0, 0.0, 1.0):  # a turn about z: every kind keeps its representation
        return turn_scope(s, A[0][0], A[0][1])
    ax = s.ax
    new_ax = tuple(tuple(sum(A[j][i] * ax[i][k] for i in range(3)) for k in range(3)) for j in range(3))
    c = s.copy()
    c.ax = new_ax  # type: ignore[assignment]
    if s.kind == VOLUME and s.solid is None and s.poly is None and _is_signed_permutation(A):
        # a box turned by quarter turns is the box of the permuted sizes
        corner = [0.0, 0.0, 0.0]
        size = [0.0, 0.0, 0.0]
        for j in range(3):
            i = next(i for i in range(3) if A[j][i] != 0.0)
            size[j] = s.sz[i]
            corner[j] = 0.0 if A[j][i] > 0 else -s.sz[i]
        c.o = tuple(s.o[k] + sum(new_ax[j][k] * corner[j] for j in range(3)) for k in range(3))  # type: ignore[assignment]
        c.sz = tuple(size)  # type: ignore[assignment]
        return c
    if s.kind == VOLUME and s.solid is None and A[2] == (0.0, 0.0, -1.0):
        # a prism upside down: its outline mirrored (rings reversed to stay counter-clockwise)
        rings = [[(A[0][0] * x + A[0][1] * y, A[1][0] * x + A[1][1] * y) for x, y in r][::-1]
                 for r in s.contours()]
        pts = [p for r in rings for p in r]
        x0, y0 = min(p[0] for p in pts), min(p[1] for p in pts)
        x1, y1 = max(p[0] for p in pts), max(p[1] for p in pts)
        z0 = -s.sz[2]
        c.o = tuple(s.o[k] + new_ax[0][k] * x0 + new_ax[1][k] * y0 + new_ax[2][k] * z0 for k in range(3))  # type: ignore[assignment]
        c.sz = (x1 - x0, y1 - y0, s.sz[2])
        c.poly = _rect_or_poly(tuple(tuple((x - x0, y - y0) for x, y in r) for r in rings), x1 - x0, y1 - y0)
        return c
    mesh = _as_mesh(s).transform([[*A[0], 0.0], [*A[1], 0.0], [*A[2], 0.0]])
    x0, y0, z0, x1, y1, z1 = mesh.bounding_box()
    c.o = tuple(s.o[k] + new_ax[0][k] * x0 + new_ax[1][k] * y0 + new_ax[2][k] * z0 for k in range(3))  # type: ignore[assignment]
    c.sz = (x1 - x0, y1 - y0, z1 - z0)
    mesh = mesh.translate((-x0, -y0, -z0))
    poly = _flat_outline(mesh)
    if poly is not None:  # an open mesh that is a face of the new scope's xy plane: a face again
        c.kind, c.solid, c.poly = FACE, None, _rect_or_poly(poly, x1 - x0, y1 - y0)
        return c
    c.solid = mesh
    c.poly = None
    c.kind = VOLUME  # a face out of its plane is an open surface mesh (see the module doc)
    c.on = None
    return c


def _flat_outline(mesh: Any) -> Any:
    """The contours of an open mesh lying in the plane z = 0 and facing +z (counter-clockwise
    outer contours, clockwise holes), or None if it is not such a face."""
    import manifold3d

    from ...geometry.surfaces import SurfaceMesh

    if not isinstance(mesh, SurfaceMesh) or len(mesh.F) == 0 or np.abs(mesh.V[:, 2]).max() > 1e-7:
        return None
    a, b, c = (mesh.V[mesh.F[:, k], :2] for k in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    live = cross > 1e-12
    if (cross < -1e-12).any() or not live.any():
        return None
    # the union of the triangles is the face (manifold3d's 2D booleans give its contours)
    tris = [manifold3d.CrossSection([t.tolist()]) for t in np.stack([a, b, c], axis=1)[live]]
    region = manifold3d.CrossSection.batch_boolean(tris, manifold3d.OpType.Add)
    rings = tuple(tuple((float(x), float(y)) for x, y in ring) for ring in region.to_polygons())
    return rings or None


def _world_to_scope(s: Shape, axes_world: Any) -> Mat:
    """Rows: world directions expressed in the scope's coordinates."""
    return tuple(tuple(sum(d[k] * s.ax[i][k] for k in range(3)) for i in range(3))  # type: ignore[return-value]
                 for d in axes_world)


def _unit(v: Any) -> tuple[float, float, float] | None:
    n = math.sqrt(sum(x * x for x in v))
    return None if n < 1e-9 else tuple(x / n for x in v)  # type: ignore[return-value]


def _cross(a: Any, b: Any) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


# -- rotateScope ---------------------------------------------------------------------------------
@operation("rotateScope", (Param("x"), Param("y"), Param("z")),
           doc="Turn the scope (not the geometry) by x, y, z degrees about its own axes, x "
               "first; the scope becomes the geometry's bounding box in the turned axes.")
def op_rotate_scope(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`rotateScope(x, y, z)`: turn the scope (not the geometry) by these angles in degrees
    about its own axes, x first (the convention of `r()`); the scope becomes the geometry's
    bounding box in the turned axes."""
    from .helpers import rotation

    angles = []
    for v in args[:3]:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"rotateScope(): the angles must be finite numbers, got {v!r}")
        angles.append(float(v))
    R = rotation(*angles)
    # new axis j = sum_i R[i][j] * old axis i (as r()): the rows of A are R's columns
    return reframe(s, tuple(tuple(R[i][j] for i in range(3)) for j in range(3)))


# -- alignScopeToAxes ----------------------------------------------------------------------------
_WORLD = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
# the axis kept (projected) when one axis is aligned: CGA's table mapped to grammarkit's z-up
# world (CGA world.y -> grammarkit z, x projected; world.z -> y, x projected; world.x -> x,
# CGA's z (grammarkit's -y) projected)
_PROJECTED = {"x": "y", "y": "x", "z": "x"}
_INDEX = {"x": 0, "y": 1, "z": 2}


def align_axes(s: Shape, axis: str = "xyz") -> Mat:
    """The new scope axes (world directions) of alignScopeToAxes(axis)."""
    if axis == "xyz":
        return (_WORLD["x"], _WORLD["y"], _WORLD["z"])
    if axis not in _WORLD:
        raise ValueError(f"alignScopeToAxes(): the axis must be \"x\", \"y\", \"z\" or \"xyz\", got {axis!r}")
    w = _WORLD[axis]
    a = _INDEX[axis]
    keep = _INDEX[_PROJECTED[axis]]
    third = 3 - a - keep
    new: list[Any] = [None, None, None]
    new[a] = w
    # the kept axis projected onto the plane normal to w; if it is parallel to w (the scope
    # looks straight along w), the third axis is projected instead and the kept one follows
    for k, rest in ((keep, third), (third, keep)):
        v = s.ax[k]
        d = sum(v[m] * w[m] for m in range(3))
        p = _unit(tuple(v[m] - d * w[m] for m in range(3)))
        if p is not None:
            new[k] = p
            # the remaining axis completes a right-handed frame: e_r = e_(r+1) x e_(r+2)
            new[rest] = _cross(new[(rest + 1) % 3], new[(rest + 2) % 3])
            break
    return tuple(new)  # type: ignore[return-value]


@operation("alignScopeToAxes", (Param("axis", "any", required=False, default="xyz"),),
           doc="Turn the scope so its axes (\"xyz\", the default) or one of them (\"x\", "
               "\"y\", \"z\") are parallel to the world's; the geometry stays.")
def op_align_scope_to_axes(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`alignScopeToAxes()` (all three scope axes parallel to the world's) or
    `alignScopeToAxes("x"|"y"|"z")`: that scope axis along the world axis, the next one
    (y for x; x for y and z) its old direction projected onto the plane normal to it."""
    axis = str(args[0]) if args else "xyz"
    return reframe(s, _world_to_scope(s, align_axes(s, axis)))


# -- alignScopeToGeometry ------------------------------------------------------------------------
def _faces(s: Shape) -> list[Shape]:
    """The faces of the geometry in CGA's comp(f) order (a face: itself)."""
    from .faces import _box_faces, _mesh_faces

    if s.kind == FACE:
        return [s]
    if s.solid is not None:
        return [f for _, f in _mesh_faces(s)]
    if s.sz[2] <= EPS:  # a volume without thickness: its footprint
        return [s]
    return [f for _, f in _box_faces(s)]


def _face_area(f: Shape) -> float:
    return abs(sum(fp.area(c) for c in f.contours()))


def _edges(f: Shape) -> list[tuple[tuple, tuple, float]]:
    """(world start, world end, length) of the edges of a face's outer contour, in order."""
    ring = f.contours()[0]
    n = len(ring)
    out = []
    for i in range(n):
        (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
        out.append((f.world(x0, y0, 0.0), f.world(x1, y1, 0.0), math.dist((x0, y0), (x1, y1))))
    return out


def _pick_edge(f: Shape, edge: Any) -> int | None:
    edges = _edges(f)
    n = len(edges)
    if isinstance(edge, str):
        live = [k for k in range(n) if edges[k][2] >= EPS]
        if not live:
            return None
        if edge == "longest":
            return max(live, key=lambda k: (round(edges[k][2], 9), -k))
        if edge == "lowest":
            return min(live, key=lambda k: (round((edges[k][0][2] + edges[k][1][2]) / 2, 6),
                                            -round(edges[k][2], 9), k))
        raise ValueError(f"alignScopeToGeometry(): edge must be a number, \"longest\" or \"lowest\", got {edge!r}")
    if isinstance(edge, bool) or not isinstance(edge, (int, float)) or not float(edge).is_integer():
        raise ValueError(f"alignScopeToGeometry(): edge must be a whole number, got {edge!r}")
    return int(edge) % n


@operation("alignScopeToGeometry", (Param("edge", "any", required=False, default=0),
                                    Param("face", "any", required=False, default=0)),
           doc="Turn the scope so z is the normal of a face of the geometry (face: an index, "
               "\"largest\", \"lowest\", \"any\"; a face shape: itself) and x runs along "
               "an edge of it (an index, \"longest\", \"lowest\"); the geometry stays.")
def op_align_scope_to_geometry(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`alignScopeToGeometry(edge, face)`: z along the normal of face `face` of the geometry
    (a face: itself; a volume: its faces in comp(f) order, `"largest"`, `"lowest"` (the lowest
    centre) or `"any"` (the face whose edge is the best by `edge`)), x along edge `edge` of
    its outer contour (an index, negative from the end, `"longest"` or `"lowest"`: CGA's
    world.lowest, the lowest midpoint, the longest of those), y = z cross x."""
    edge = args[0] if args else 0
    face = args[1] if len(args) > 1 else 0
    faces = _faces(s)
    if isinstance(face, str):
        if face == "largest":
            fi = max(range(len(faces)), key=lambda k: (round(_face_area(faces[k]), 9), -k))
        elif face == "lowest":
            def centre(k: int) -> float:
                ring = faces[k].contours()[0]
                return sum(faces[k].world(x, y, 0.0)[2] for x, y in ring) / len(ring)
            fi = min(range(len(faces)), key=lambda k: (round(centre(k), 6), k))
        elif face == "any":
            if not isinstance(edge, str):
                raise ValueError("alignScopeToGeometry(): face \"any\" needs an edge selector "
                                 "(\"longest\" or \"lowest\")")
            best = []
            for k, f in enumerate(faces):
                e = _pick_edge(f, edge)
                if e is None:
                    continue
                a, b, ln = _edges(f)[e]
                best.append(((-round(ln, 9),) if edge == "longest" else
                             (round((a[2] + b[2]) / 2, 6), -round(ln, 9)), k))
            if not best:
                raise ValueError("alignScopeToGeometry(): the geometry has no edge")
            fi = min(best)[1]
        else:
            raise ValueError("alignScopeToGeometry(): face must be a number, \"largest\", \"lowest\" "
                             f"or \"any\", got {face!r}")
    elif isinstance(face, bool) or not isinstance(face, (int, float)) or not float(face).is_integer():
        raise ValueError(f"alignScopeToGeometry(): face must be a whole number, got {face!r}")
    else:
        fi = int(face) % len(faces)
    f = faces[fi]
    ei = _pick_edge(f, edge)
    if ei is None:
        raise ValueError("alignScopeToGeometry(): the face has no edge")
    a, b, ln = _edges(f)[ei]
    if ln < EPS:
        raise ValueError(f"alignScopeToGeometry(): edge {ei} has no length")
    x = tuple((b[k] - a[k]) / ln for k in range(3))
    z = f.ax[2]
    # the edge lies in the face's plane, so x is normal to z; y completes the frame
    return reframe(s, _world_to_scope(s, (x, _cross(z, x), z)))


# -- mirrorScope, mirror ---------------------------------------------------------------------------
def _flags(args: Any, what: str) -> tuple[bool, bool, bool]:
    out = []
    for v in args[:3]:
        if not isinstance(v, bool):
            raise ValueError(f"{what}(): the flags must be true or false, got {v!r}")
        out.append(v)
    return tuple(out)  # type: ignore[return-value]


@operation("mirrorScope", (Param("x", "any"), Param("y", "any"), Param("z", "any")),
           doc="Reverse the flagged scope axes (two of them: scopes stay right-handed), the "
               "origin moved to the other side; the geometry stays.")
def op_mirror_scope(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`mirrorScope(x, y, z)`: the flagged scope axes reversed, the origin moved to the other
    side of the box along them; the geometry stays. Two flags (a half turn about the third
    axis) or none: a scope is right-handed in grammarkit."""
    flags = _flags(args, "mirrorScope")
    n = sum(flags)
    if n == 0:
        return s
    if n % 2:
        shown = ", ".join("true" if f else "false" for f in flags)
        raise ValueError(f"mirrorScope({shown}): reversing {n} scope ax{'is' if n == 1 else 'es'} "
                         "makes a left-handed scope, which grammarkit's faces and volumes cannot "
                         "carry; reverse two axes (a half turn), or mirrorGeometry() to reflect the geometry")
    A = tuple(tuple((-1.0 if flags[j] else 1.0) if i == j else 0.0 for i in range(3)) for j in range(3))
    return reframe(s, A)


@operation("mirrorGeometry", (Param("x", "any"), Param("y", "any"), Param("z", "any")),
           doc="Reflect the geometry across the scope's mid-planes along the flagged axes "
               "(CGA's mirror); the scope stays (a solid stays watertight).")
def op_mirror(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`mirrorGeometry(x, y, z)` (CGA's `mirror`; `mirror` is a reserved word of grammarkit's
    language): the geometry reflected across the mid-planes of the scope along the flagged axes;
    the scope stays. A solid stays a watertight solid with its outside out; a face mirrored
    along z looks the other way (an open surface mesh)."""
    flags = _flags(args, "mirrorGeometry")
    if not any(flags):
        return s
    c = s.copy()
    c.on = None
    sx, sy, sz = s.sz
    if s.solid is None and (s.kind == VOLUME or not flags[2]):
        # outlines (a face, a prism's footprint) mirrored in their plane; a prism or a box is
        # symmetric along z
        if s.poly is not None and (flags[0] or flags[1]):
            def m(x: float, y: float) -> tuple[float, float]:
                return (sx - x if flags[0] else x, sy - y if flags[1] else y)
            rings = tuple(tuple(m(x, y) for x, y in r) for r in s.poly)
            c.poly = rings if (flags[0] and flags[1]) else tuple(r[::-1] for r in rings)
        return c
    mesh = _as_mesh(s)
    diag = [-1.0 if f else 1.0 for f in flags]
    shift = [sz_ if f else 0.0 for f, sz_ in zip(flags, (sx, sy, sz))]
    c.solid = mesh.transform([[diag[0], 0.0, 0.0, shift[0]], [0.0, diag[1], 0.0, shift[1]],
                              [0.0, 0.0, diag[2], shift[2]]])
    c.poly = None
    c.kind = VOLUME
    return c


@operation("reverseNormals", (),
           doc="Turn a face (or an open mesh) to look the other way; a closed volume keeps its outside.")
def op_reverse_normals(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `reverseNormals`: a face turned to look the other way (x kept, y and z reversed:
    the scope is mirrored across its x axis, the outline stays in place); an open mesh's
    triangles flipped. A closed volume keeps its outside (turning it inside out would break
    the solid), with a warning."""
    from ...geometry.surfaces import SurfaceMesh
    from ..shape import FACE

    if isinstance(s.solid, SurfaceMesh):
        c = s.copy()
        c.solid = SurfaceMesh(s.solid.V, s.solid.F[:, ::-1])
        return c
    if s.kind != FACE:
        ctx.warn(f"reverseNormals in rule {s.rule_name!r}: a closed volume keeps its outside "
                 "(it stays a watertight solid)")
        return s
    ex, ey, ez = s.ax
    sy = s.sz[1]
    c = s.copy()
    c.o = tuple(s.o[k] + ey[k] * sy for k in range(3))  # type: ignore[assignment]
    c.ax = (ex, tuple(-v for v in ey), tuple(-v for v in ez))  # type: ignore[assignment]
    if s.poly is not None:
        c.poly = tuple(tuple(reversed([(x, sy - y) for x, y in ring])) for ring in s.poly)
    c.on = None  # it no longer faces out of its volume
    return c

