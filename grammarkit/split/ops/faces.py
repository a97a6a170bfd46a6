"""`comp(f)`: a shape's faces as shapes of their own (CGA semantics).

`comp(f)` **consumes** the shape, as in CGA: its faces go to the block's branches, and the
volume itself is gone unless the block keeps it with the `volume:` selector (the volume goes
to that branch unchanged; `volume: Mass.` emits it as a solid). Faces remember the volume
they came from (`Shape.on`): if that very volume is emitted as a solid, face terminals on it
colour its surface and `recess` cuts into it; otherwise face terminals are emitted as
surfaces (grammarkit.geometry.surfaces) and a recess shows its reveal.

What `comp(f)` decomposes:

- a box or a footprint prism, in CGA's order: the bottom (index 0), the top (1), then one
  side face per contour edge (x along the edge, y up, z the
  outward normal), the top (the volume's axes) and the bottom (x along the volume's x, z down);
  side faces carry CGA's trim planes (the bisector planes with their neighbours), which clip
  inserted meshes at the corners;
- a general solid (roof, taper, insert) or an open inserted mesh: its planar faces
  (grammarkit.geometry.planar); x along the lowest edge (the eave of a roof plane), y up the
  face, z the outward normal; horizontal faces keep the volume's x axis;
- a face: the face itself (selected by `top`, `all`, `horizontal` and the index 0).

Selectors (each face goes to the first branch that selects it): `front`, `back`, `left`,
`right` (side faces whose outward normal is closest to the scope's -y, +y, -x, +x), `top`,
`bottom` (normal within 45 degrees of the scope's +z / -z), `side` (the others), `vertical`
/ `horizontal` (normal within 1 degree of horizontal / vertical), `aslant` / `nutant`
(pointing up / down, neither horizontal nor vertical), `all`, an index `0`, `1`, ... (the
face's position in the decomposition), and `volume` (the shape itself, see above).
`comp.index` / `comp.total` are the face's index and the number of faces.
"""
from __future__ import annotations

import math
from typing import Any


from ..shape import FACE, Shape
from .helpers import fp, lazy_module, manifold3d, piece

np = lazy_module("numpy")
planar = lazy_module("grammarkit.geometry.planar")
surfaces = lazy_module("grammarkit.geometry.surfaces")

__all__ = ["faces_of"]

_SIN1 = math.sin(math.radians(1.0))
_COS45 = math.cos(math.radians(45.0))
# comp(f) of a general solid: more triangles than this is refused (each face is a shape)
MAX_COMP_TRIANGLES = 200_000


def _classify(nx: float, ny: float) -> str:
    if abs(ny) >= abs(nx):
        return "front" if ny < 0 else "back"
    return "right" if nx > 0 else "left"


def _selectors(n: tuple[float, float, float]) -> frozenset:
    """Selector names of a face with unit normal `n` in the volume's scope coordinates."""
    nx, ny, nz = n
    out = ["all"]
    if nz > _COS45:
        out.append("top")
    elif nz < -_COS45:
        out.append("bottom")
    else:
        out += ["side", _classify(nx, ny)]
    if abs(nz) <= _SIN1:
        out.append("vertical")
    elif abs(nz) >= 1 - 1e-9 or abs(nz) >= math.cos(math.radians(1.0)):
        out.append("horizontal")
    elif nz > 0:
        out.append("aslant")
    else:
        out.append("nutant")
    return frozenset(out)


def _cross(a: tuple, b: tuple) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _box_faces(s: Shape) -> list[tuple[frozenset, Shape]]:
    sx, sy, h = s.sz
    ax, ay, az = s.ax
    on = (s.gid, (s.o, s.ax, s.sz))
    faces: list[tuple[frozenset, Shape]] = []
    for contour in s.contours():
        n = len(contour)
        hole = fp.area(contour) < 0
        dirs = []
        for i in range(n):
            (x0, y0), (x1, y1) = contour[i], contour[(i + 1) % n]
            ln = math.hypot(x1 - x0, y1 - y0)
            dirs.append(((x1 - x0) / ln, (y1 - y0) / ln, ln) if ln >= 1e-9 else None)
        for i in range(n):
            d = dirs[i]
            if d is None:
                continue
            ux, uy, ln = d
            x0, y0 = contour[i]
            ex = (ax[0] * ux + ay[0] * uy, ax[1] * ux + ay[1] * uy, ax[2] * ux + ay[2] * uy)
            ez = _cross(ex, az)
            side = _classify(uy, -ux)  # outward normal of a CCW contour edge is (dy, -dx)
            names = ("side", "all", side, "vertical", "hole") if hole else ("side", "all", side, "vertical")
            f = s.derived(s.world(x0, y0, 0.0), (ln, h, 0.0), None, FACE, ax=(ex, az, ez))
            f.on = on
            f.trims = _trims(s, contour, dirs, i)
            faces.append((frozenset(names), f))
    top = s.derived(s.world(0.0, 0.0, h), (sx, sy, 0.0), s.poly, FACE)
    top.on = on
    faces.append((frozenset(("top", "all", "horizontal")), top))
    bpoly = None if s.poly is None else tuple(tuple(reversed([(x, sy - y) for x, y in c])) for c in s.poly)
    neg_y = (-ay[0], -ay[1], -ay[2])
    neg_z = (-az[0], -az[1], -az[2])
    bottom = s.derived(s.world(0.0, sy, 0.0), (sx, sy, 0.0), bpoly, FACE, ax=(ax, neg_y, neg_z))
    bottom.on = on
    faces.append((frozenset(("bottom", "all", "horizontal")), bottom))
    # CGA's order for an extruded face: the bottom (the face extruded) is 0, the top 1, then
    # the sides in the order of the footprint's edges; index selectors and comp.index use it
    return [faces[-1], faces[-2], *faces[:-2]]


def _trims(s: Shape, contour: Any, dirs: list, i: int) -> tuple:
    """CGA's trim planes of side face i: at each end, the vertical plane bisecting the angle
    with the neighbouring face; (world point, world normal), kept side dot(n, p - q) >= 0."""
    n = len(contour)
    cur = dirs[i]
    out = []
    for end, k_other in ((0, (i - 1) % n), (1, (i + 1) % n)):
        other = dirs[k_other]
        if other is None or n < 3:
            continue
        ux, uy = cur[0], cur[1]
        vx, vy = other[0], other[1]
        if end == 0:  # at the start vertex: the previous edge runs into it
            nx, ny = ux + vx, uy + vy
            px, py = contour[i]
        else:  # at the end vertex: keep the side back along this edge
            nx, ny = -(ux + vx), -(uy + vy)
            px, py = contour[(i + 1) % n]
        ln = math.hypot(nx, ny)
        if ln < 1e-6:
            continue
        nx, ny = nx / ln, ny / ln
        ax, ay = s.ax[0], s.ax[1]
        wn = (ax[0] * nx + ay[0] * ny, ax[1] * nx + ay[1] * ny, ax[2] * nx + ay[2] * ny)
        out.append((s.world(px, py, 0.0), wn))
    return tuple(out)


def _mesh_faces(s: Shape) -> list[tuple[frozenset, Shape]]:
    """The planar faces of a general solid or an open mesh, in the volume's frame."""
    solid = s.solid
    if isinstance(solid, surfaces.SurfaceMesh):
        V, F = solid.V, solid.F
    else:
        mesh = solid.to_mesh()
        V = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        F = np.asarray(mesh.tri_verts, dtype=np.int64).reshape(-1, 3)
    if len(F) > MAX_COMP_TRIANGLES:
        raise ValueError(f"comp(f) of a mesh with {len(F)} triangles (more than "
                         f"{MAX_COMP_TRIANGLES}): simplify the asset")
    on = (s.gid, (s.o, s.ax, s.sz))
    M = np.asarray(s.ax, dtype=np.float64)  # rows: scope axes in world coordinates
    out: list[tuple[frozenset, Shape]] = []
    for pf in planar.planar_faces(V, F):
        nrm = pf.normal
        if abs(nrm[2]) >= math.cos(math.radians(1.0)):
            # horizontal: keep the volume's axes (the bottom looks down, y flipped)
            ex = np.array([1.0, 0.0, 0.0])
            ez = np.array([0.0, 0.0, 1.0 if nrm[2] > 0 else -1.0])
            ey = np.cross(ez, ex)
        else:
            # x along the lowest boundary edge of the outer loop (a roof plane's eave), in the
            # loop's (counter-clockwise) direction; y up the face
            loop = max(pf.loops, key=lambda lp: _loop_area(lp, nrm))
            mids = (loop + np.roll(loop, -1, axis=0)) / 2
            lens = np.linalg.norm(np.roll(loop, -1, axis=0) - loop, axis=1)
            z = np.round(mids[:, 2], 9)
            cand = np.lexsort((-lens, z))
            k = int(cand[0])
            ex = loop[(k + 1) % len(loop)] - loop[k]
            ex = ex - nrm * (ex @ nrm)
            ex /= np.linalg.norm(ex)
            ez = nrm
            ey = np.cross(ez, ex)
        pts2 = [np.column_stack([lp @ ex, lp @ ey]) for lp in pf.loops]
        allp = np.concatenate(pts2)
        x0, y0 = allp.min(axis=0)
        x1, y1 = allp.max(axis=0)
        if x1 - x0 < 1e-9 or y1 - y0 < 1e-9:
            continue
        polys = tuple(tuple((float(x - x0), float(y - y0)) for x, y in p) for p in pts2)
        plane = float(pf.loops[0][0] @ ez)
        origin_local = ex * x0 + ey * y0 + ez * plane
        o = tuple(float(v) for v in (origin_local @ M + np.asarray(s.o)))
        wax = tuple(tuple(float(v) for v in (axis @ M)) for axis in (ex, ey, ez))
        poly = _rect_or_poly(polys, x1 - x0, y1 - y0)
        f = s.derived(o, (float(x1 - x0), float(y1 - y0), 0.0), poly, FACE, ax=wax)  # type: ignore[arg-type]
        f.on = on
        out.append((_selectors(tuple(float(v) for v in nrm)), f))
    return out


def _loop_area(loop: np.ndarray, n: np.ndarray) -> float:
    return float(np.cross(loop, np.roll(loop, -1, axis=0)).sum(axis=0) @ n) / 2


def _rect_or_poly(poly: Any, sx: float, sy: float) -> Any:
    if len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7):
        return None
    return poly


def _face_pieces(s: Shape) -> list[Shape]:
    """A face's faces: itself, or, when its geometry is several outer contours and no holes
    (what convexify() makes), each contour as a face of its own (CGA's comp(f) of a
    multi-face shape)."""
    poly = s.poly
    if poly is None or len(poly) < 2:
        return [s.copy()]

    def signed(c: Any) -> float:
        return 0.5 * sum(c[i][0] * c[(i + 1) % len(c)][1] - c[(i + 1) % len(c)][0] * c[i][1] for i in range(len(c)))

    if any(signed(c) <= 0 for c in poly):
        return [s.copy()]
    out = []
    for c in poly:
        cs = manifold3d.CrossSection([[list(p) for p in c]], manifold3d.FillRule.Positive)
        f = None if cs.is_empty() else piece(s, cs, FACE)
        if f is not None:
            out.append(f)
    return out


def faces_of(s: Shape) -> list[tuple[frozenset, Shape]]:
    """comp(f)'s faces of a shape, in comp(f)'s order: (selector names, face shape)."""
    if s.kind == FACE:
        return [(frozenset(("top", "all", "horizontal")), f) for f in _face_pieces(s)]
    if s.solid is not None:
        return _mesh_faces(s)
    return _box_faces(s)
