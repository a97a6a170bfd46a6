"""CGA's `scatter(domain, n, distribution [, mean, stddev]) { all: Rule }` (docs/operations.md,
"Scatter"): point shapes placed at random on or in the current shape.

- `surface`: on the shape's geometry (a face, or the surface of a volume / inserted mesh);
  uniform points are area-weighted over its triangles. Each point's scope has z along the
  surface normal there (CGA turns the point's y, its up axis, to the normal; grammarkit's
  faces have their normal along z) and x along the shape's x projected into the surface.
- `volume`: inside a closed solid (rejection sampling in the scope box; an open mesh or a
  face falls back to `surface`, as in CGA); the points keep the shape's axes.
- `scope`: in the scope box; the points keep the shape's axes.

`gaussian` draws each coordinate from a normal distribution about `mean` (a point of the scope:
`center`, or the middle of its `front`/`back`/`left`/`right`/`top`/`bottom` side) with a
standard deviation of `stddev` times the scope's size on that axis (CGA's relative `'0.16`, the
default); a draw outside the domain is drawn again (up to MAX_TRIES times, then the closest
point of the domain is taken), so the points follow the normal distribution restricted to the
domain. Points have a zero-size scope (CGA: the child's geometry is a single vertex): a rule
gives them geometry with `s()` and `i()`.

Randomness comes from the shape's own generator (seeded from the run seed and the shape's
derivation path), so the same seed gives the same points whatever the number of workers.
"""
from __future__ import annotations

import math
from typing import Any


from ...registry import Param
from ..shape import FACE, Shape
from .helpers import lazy_module, manifold3d, operation

np = lazy_module("numpy")
surfaces = lazy_module("grammarkit.geometry.surfaces")

__all__ = ["DOMAINS", "DISTRIBUTIONS", "MEANS", "MAX_POINTS", "op_scatter", "scatter_points"]

DOMAINS = ("surface", "volume", "scope")
DISTRIBUTIONS = ("uniform", "gaussian")
MEANS = ("center", "front", "back", "left", "right", "top", "bottom")
MAX_POINTS = 100_000  # one scatter() makes at most this many shapes (each is derived on)
MAX_TRIES = 64  # rejection-sampling rounds for points outside the domain


def _triangles(s: Shape) -> tuple[np.ndarray, np.ndarray]:
    """The shape's surface as triangles (T, 3, 3) in scope coordinates and their unit normals."""
    if s.kind == FACE:
        rings = [np.asarray(c, dtype=np.float64) for c in s.contours()]
        tris = np.asarray(manifold3d.triangulate(rings), dtype=np.int64).reshape(-1, 3)
        pts2 = np.concatenate(rings)
        V = np.column_stack([pts2, np.zeros(len(pts2))])
        F = tris
    elif isinstance(s.solid, surfaces.SurfaceMesh):
        V, F = np.asarray(s.solid.V, dtype=np.float64), np.asarray(s.solid.F, dtype=np.int64)
    else:
        from ..scope_solid import local_solid

        m, _oid, _n = local_solid(s)
        if m is None:
            return np.zeros((0, 3, 3)), np.zeros((0, 3))
        mesh = m.to_mesh()
        V = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        F = np.asarray(mesh.tri_verts, dtype=np.int64).reshape(-1, 3)
    T = V[F]
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    ln = np.linalg.norm(n, axis=1)
    keep = ln > 1e-12
    return T[keep], n[keep] / ln[keep, None]


def _closed_solid(s: Shape) -> Any:
    """The shape's closed solid (manifold3d) in scope coordinates, or None (a face, an open mesh)."""
    if s.kind == FACE or isinstance(s.solid, surfaces.SurfaceMesh):
        return None
    from ..scope_solid import local_solid

    m, _oid, _n = local_solid(s)
    return m if m is not None and m.volume() > 1e-12 else None


def _mean(s: Shape, where: str) -> np.ndarray:
    sx, sy, sz = s.sz
    m = np.array([sx / 2, sy / 2, sz / 2])
    # grammarkit's scope sides: front y = 0, back y = sy, left x = 0, right x = sx, bottom z = 0
    axis, value = {"front": (1, 0.0), "back": (1, sy), "left": (0, 0.0), "right": (0, sx),
                   "bottom": (2, 0.0), "top": (2, sz)}.get(where, (None, 0.0))
    if axis is not None:
        m[axis] = value
    return m


def _closest_on_triangles(p: np.ndarray, T: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The closest points to `p` (k, 3) on the triangles `T` (trimesh's exact point-triangle
    test, in chunks to bound memory) and the normal of the triangle each is on."""
    from trimesh.triangles import closest_point

    k, t = len(p), len(T)
    q, nq = np.empty((k, 3)), np.empty((k, 3))
    step = max(1, 200_000 // max(t, 1))
    for i in range(0, k, step):
        pc = p[i:i + step]
        m = len(pc)
        cand = closest_point(np.broadcast_to(T[None], (m, t, 3, 3)).reshape(-1, 3, 3),
                             np.repeat(pc, t, axis=0)).reshape(m, t, 3)
        best = np.argmin(np.linalg.norm(cand - pc[:, None], axis=2), axis=1)
        q[i:i + m], nq[i:i + m] = cand[np.arange(m), best], N[best]
    return q, nq


def _on_surface(rng: np.random.Generator, T: np.ndarray, N: np.ndarray, n: int, gauss: Any) -> tuple:
    """n points on the triangles: (points, the normal of the triangle each is on)."""
    if gauss is None:
        area = np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
        tri = rng.choice(len(T), size=n, p=area / area.sum())
        r1, r2 = rng.random(n), rng.random(n)
        flip = r1 + r2 > 1.0  # fold the unit square onto the triangle: uniform barycentrics
        r1[flip], r2[flip] = 1.0 - r1[flip], 1.0 - r2[flip]
        a, b, c = T[tri, 0], T[tri, 1], T[tri, 2]
        return a + r1[:, None] * (b - a) + r2[:, None] * (c - a), N[tri]
    mean, sd = gauss
    planar = bool(np.all(np.abs(T[:, :, 2]) < 1e-9))
    p = mean + rng.standard_normal((n, 3)) * sd
    if planar:  # a face: a 2D normal distribution in its plane, draws outside it drawn again
        p[:, 2] = 0.0
        for _ in range(MAX_TRIES):
            out = ~_in_triangles_2d(p[:, :2], T)
            if not out.any():
                break
            p[out] = mean + rng.standard_normal((int(out.sum()), 3)) * sd
            p[out, 2] = 0.0
    # on a 3D surface (or what rejection left outside a face): the closest surface point
    return _closest_on_triangles(p, T, N)


def _in_triangles_2d(p: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c = T[:, 0, :2], T[:, 1, :2], T[:, 2, :2]

    def side(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return (v[None, :, 0] - u[None, :, 0]) * (p[:, None, 1] - u[None, :, 1]) - \
               (v[None, :, 1] - u[None, :, 1]) * (p[:, None, 0] - u[None, :, 0])

    d1, d2, d3 = side(a, b), side(b, c), side(c, a)
    neg = (d1 < -1e-12) | (d2 < -1e-12) | (d3 < -1e-12)
    pos = (d1 > 1e-12) | (d2 > 1e-12) | (d3 > 1e-12)
    return (~(neg & pos)).any(axis=1)


def _in_box(rng: np.random.Generator, s: Shape, n: int, gauss: Any, inside: Any) -> np.ndarray:
    """n points in the scope box (and, with `inside`, in the solid), uniform or gaussian."""
    size = np.asarray(s.sz, dtype=np.float64)

    def draw(k: int) -> np.ndarray:
        if gauss is None:
            return rng.random((k, 3)) * size
        return gauss[0] + rng.standard_normal((k, 3)) * gauss[1]

    def bad(p: np.ndarray) -> np.ndarray:
        out = ((p < -1e-12) | (p > size + 1e-12)).any(axis=1)
        if inside is not None:
            out |= ~inside(p)
        return out

    p = draw(n)
    out = bad(p)
    tries = 0
    while out.any() and tries < 4 * MAX_TRIES:  # uniform in a thin solid may need many rounds
        p[out] = draw(int(out.sum()))
        out = bad(p)
        tries += 1
    if out.any():  # what is still outside: the closest point of the box
        p[out] = np.clip(p[out], 0.0, size)
    return p


def scatter_points(s: Shape, domain: str, n: int, distribution: str, mean: str = "center",
                   stddev: float = 0.16) -> tuple[np.ndarray, np.ndarray | None]:
    """The points (n, 3) in scope coordinates, and their surface normals (None off surfaces)."""
    rng = np.random.default_rng(s.rng().getrandbits(64))
    gauss = None
    if distribution == "gaussian":
        gauss = (_mean(s, mean), float(stddev) * np.asarray(s.sz, dtype=np.float64))
    if n <= 0:
        return np.zeros((0, 3)), None
    if domain == "scope":
        return _in_box(rng, s, n, gauss, None), None
    if domain == "volume":
        solid = _closed_solid(s)
        if solid is not None:
            import trimesh

            mesh = solid.to_mesh()
            tm = trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3],
                                 np.asarray(mesh.tri_verts).reshape(-1, 3), process=False)
            return _in_box(rng, s, n, gauss, tm.contains), None
        # not closed: CGA falls back to the surface
    T, N = _triangles(s)
    if len(T) == 0:
        return np.zeros((0, 3)), None
    return _on_surface(rng, T, N, n, gauss)


def _frame_on(s: Shape, nrm: np.ndarray) -> tuple:
    """World axes of a point's scope on a surface: z = the normal, x = the scope's x in the surface."""
    M = np.asarray(s.ax, dtype=np.float64)  # rows: scope axes in world coordinates
    z = nrm / (np.linalg.norm(nrm) or 1.0)
    x = np.array([1.0, 0.0, 0.0]) - z * z[0]
    if np.linalg.norm(x) < 1e-6:  # the normal along the scope's x: take its y
        x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return tuple(tuple(float(v) for v in (a @ M)) for a in (x, y, z))


@operation("scatter", (Param("domain", "axis", choices=("surface", "volume", "scope")), Param("count"),
                       Param("distribution", "axis", choices=("uniform", "gaussian")),
                       Param("mean", "axis", required=False, default="center",
                             choices=("center", "front", "back", "left", "right", "top", "bottom")),
                       Param("stddev", required=False, default=0.16,
                             doc="times the scope's size on each axis (CGA's '0.16)")),
           block="selectors", selectors=("all",),
           doc="Random point shapes (zero-size scopes) on the surface, in the volume or in the "
               "scope of the shape, uniform or gaussian; `{ all: Rule }` derives each point.")
def op_scatter(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    domain, count, distribution, mean, stddev = str(args[0]), args[1], str(args[2]), str(args[3]), args[4]
    if domain not in DOMAINS:
        raise ValueError(f"scatter domain must be one of {', '.join(DOMAINS)}, got {domain!r}")
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"scatter distribution must be one of {', '.join(DISTRIBUTIONS)}, got {distribution!r}")
    if mean not in MEANS:
        raise ValueError(f"scatter mean must be one of {', '.join(MEANS)}, got {mean!r}")
    count, stddev = float(count), float(stddev)
    if not math.isfinite(count) or not math.isfinite(stddev) or stddev < 0:
        raise ValueError(f"scatter needs a finite number of points and stddev >= 0, got {count}, {stddev}")
    n = max(0, int(math.floor(count + 0.5)))  # CGA's nPoints is a float: rounded
    if n > MAX_POINTS:
        raise ValueError(f"scatter of {n} points (more than {MAX_POINTS})")
    slots = [slot for slot in block if slot.sel == "all"]
    if not slots or n == 0:
        return []
    pts, normals = scatter_points(s, domain, n, distribution, mean, stddev)
    out = []
    for i, p in enumerate(pts):
        ax = _frame_on(s, normals[i]) if normals is not None else None
        c = s.derived(s.world(float(p[0]), float(p[1]), float(p[2])), (0.0, 0.0, 0.0), None, FACE, ax=ax)
        c.entry = (c.o, c.ax, c.sz)
        for slot in slots:
            out.append((c if slot is slots[0] else c.copy(), slot, i, len(pts)))
    return out
