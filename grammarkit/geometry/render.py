"""A CPU-only renderer (numpy + Pillow; no OpenGL on these machines) for previews and sketches.

Styles:
- "shaded": z-buffer, flat Lambert + ambient shading of each face's colour.
- "lines": hidden-line drawing: silhouette, crease, boundary (and colour-boundary) edges, with
  parts hidden behind surfaces removed by a test against the z-buffer.
- "shaded+lines": both.

How it stays fast in pure numpy: no Python loop over triangles. All triangles' scanline spans
(the covered pixel run of each pixel row) are computed at once from their barycentric
half-planes, expanded into one fragment per covered pixel with `np.repeat`, and the depth test
packs a quantised depth and the triangle id into one int64 so that a single `np.minimum.at`
resolves all fragments (in chunks that bound memory). Back faces of closed meshes are culled. The image
is rendered at `supersample` times the size and box-filtered down (anti-aliasing).

The same line renderer renders the training sketches of the sketch recognizer, so the camera
(`Camera`) and the line style (`LineStyle`, including a seeded "sketchy" mode) are explicit,
and `prepare()` lets a caller reuse one model's edge topology across many cameras.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import trimesh
from PIL import Image, ImageChops, ImageDraw

from ..errors import ShapeError
from .camera import Camera, View

__all__ = ["STYLES", "LineStyle", "Raster", "RenderGeometry", "prepare", "rasterize", "render",
           "save_image"]

STYLES = ("shaded", "lines", "shaded+lines")
DEFAULT_FACE_COLOR = (0.80, 0.80, 0.78)
MAX_TRIANGLES = 4_000_000
_ID_BITS = 24  # triangle id bits in the packed z-buffer value (so at most 16.7M triangles)
_DEPTH_LEVELS = (1 << (63 - _ID_BITS)) - 1


@dataclass(frozen=True)
class LineStyle:
    """How edges are drawn. Widths and jitter are in output-image pixels.

    Which edges: `silhouettes` (between a front- and a back-facing face), `creases` (faces
    meeting at more than `crease_angle` degrees), `boundaries` (edges of one face only, and
    non-manifold edges), `material_edges` (neighbouring faces of different colour, e.g. a
    window flush with its wall).
    `sketchy` turns each visible stroke into a hand-drawn-looking one: ends overshoot by up to
    `overshoot` px, the stroke wobbles by up to `jitter` px, `strokes` passes per edge; all
    random draws come from `seed`, so the same seed gives the same picture.
    """

    width: float = 1.5
    color: tuple[int, int, int] = (25, 25, 25)
    crease_angle: float = 30.0
    silhouettes: bool = True
    creases: bool = True
    boundaries: bool = True
    material_edges: bool = True
    sketchy: bool = False
    jitter: float = 1.0
    overshoot: float = 4.0
    strokes: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 < self.width < math.inf:
            raise ValueError(f"line width must be positive, got {self.width}")
        if not 0 <= self.crease_angle <= 180:
            raise ValueError(f"crease_angle must be within [0, 180] degrees, got {self.crease_angle}")
        if self.strokes < 1:
            raise ValueError(f"strokes must be at least 1, got {self.strokes}")
        if self.jitter < 0 or self.overshoot < 0:
            raise ValueError("jitter and overshoot must be >= 0")

    @classmethod
    def sketch(cls, seed: int = 0, **kw) -> "LineStyle":
        """A hand-drawn look for synthetic training sketches."""
        kw.setdefault("width", 1.2)
        kw.setdefault("jitter", 1.2)
        kw.setdefault("overshoot", 5.0)
        kw.setdefault("strokes", 2)
        return cls(sketchy=True, seed=seed, **kw)


# ------------------------------------------------------------------------------------------
# Geometry gathering: any model-ish object -> one indexed triangle set with edge topology
# ------------------------------------------------------------------------------------------
@dataclass
class RenderGeometry:
    """Triangles of a model in world coordinates plus the edge topology the line renderer needs.

    Vertices are welded per source mesh (not across meshes), so edges between separately
    modelled parts are drawn and triangle soups (STL) get their shared edges back.
    """

    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (F, 3) int64
    face_colors: np.ndarray  # (F, 3) float64 in [0, 1]
    normals: np.ndarray  # (F, 3) unit normals, zero for degenerate faces
    closed: np.ndarray  # (F,) face belongs to a closed, outward-oriented mesh (cullable)
    edges: np.ndarray  # (E, 2) vertex indices
    edge_faces: np.ndarray  # (E, 2) face indices; second is -1 for a boundary edge
    edge_angle: np.ndarray  # (E,) dihedral angle between the two face normals, degrees
    edge_material: np.ndarray  # (E,) the two faces have different colours
    edge_open: np.ndarray  # (E,) boundary or non-manifold edge

    @property
    def triangles(self) -> int:
        return int(len(self.faces))


def _face_colors(mesh: trimesh.Trimesh) -> np.ndarray:
    n = len(mesh.faces)
    visual = mesh.visual
    try:
        kind = visual.kind
        if kind in ("face", "vertex"):
            return np.asarray(visual.face_colors, dtype=np.float64)[:, :3] / 255.0
        if kind == "texture":  # no texture sampling: use the material's main colour
            main = np.asarray(visual.material.main_color, dtype=np.float64)[:3] / 255.0
            return np.broadcast_to(main, (n, 3)).copy()
    except (AttributeError, ValueError, IndexError):
        pass
    return np.broadcast_to(np.asarray(DEFAULT_FACE_COLOR), (n, 3)).copy()


def _iter_meshes(obj: Any) -> Iterable[tuple[trimesh.Trimesh, np.ndarray | None]]:
    if isinstance(obj, trimesh.Trimesh):
        yield obj, None
    elif isinstance(obj, trimesh.Scene):
        for node in obj.graph.nodes_geometry:
            matrix, name = obj.graph[node]
            geom = obj.geometry.get(name)
            if isinstance(geom, trimesh.Trimesh):  # paths and point clouds are not rendered
                yield geom, np.asarray(matrix, dtype=np.float64)
    elif isinstance(getattr(obj, "mesh", None), trimesh.Trimesh):  # a derived Model, a Part
        if len(obj.mesh.faces):
            yield obj.mesh, None
        surface = getattr(obj, "surface_mesh", None)  # a model's surface layer (open faces)
        if isinstance(surface, trimesh.Trimesh):
            yield surface, None
    elif hasattr(obj, "parts") and not isinstance(obj, (str, bytes)):  # an Assembly
        for part in obj.parts:
            yield from _iter_meshes(part)
    elif callable(getattr(obj, "to_scene", None)):
        yield from _iter_meshes(obj.to_scene())
    elif isinstance(obj, (list, tuple)):
        for item in obj:
            yield from _iter_meshes(item)
    else:
        raise ShapeError(f"cannot render a {type(obj).__name__}: expected a trimesh.Trimesh, "
                         "a trimesh.Scene, a model or an assembly")


def _row_groups(rows: np.ndarray) -> np.ndarray:
    """Group id per row, equal rows sharing one (np.unique(axis=0) is ~20x slower here)."""
    order = np.lexsort(rows.T[::-1])
    srt = rows[order]
    new = np.r_[True, (srt[1:] != srt[:-1]).any(axis=1)]
    groups = np.empty(len(rows), dtype=np.int64)
    groups[order] = np.cumsum(new) - 1
    return groups


# long: one numpy pass from gathered triangles to welded edge topology sharing its arrays
def prepare(obj: Any, *, max_triangles: int = MAX_TRIANGLES) -> RenderGeometry:
    """Gather the triangles of a Trimesh / Scene / Model / Assembly and compute edge topology."""
    if isinstance(obj, RenderGeometry):
        return obj
    verts, faces, colors, mesh_ids = [], [], [], []
    offset = 0
    total = 0
    for i, (mesh, matrix) in enumerate(_iter_meshes(obj)):
        v = np.asarray(mesh.vertices, dtype=np.float64)
        f = np.asarray(mesh.faces, dtype=np.int64)
        if len(f) == 0:
            continue
        total += len(f)
        if total > max_triangles:
            raise ShapeError(f"model has more than {max_triangles} triangles; refusing to render "
                             "(raise max_triangles if this is intended)")
        if matrix is not None:
            v = v @ matrix[:3, :3].T + matrix[:3, 3]
        verts.append(v)
        faces.append(f + offset)
        colors.append(_face_colors(mesh))
        mesh_ids.append(np.full(len(f), i, dtype=np.int64))
        offset += len(v)
    if not faces:
        empty = np.zeros((0, 3))
        return RenderGeometry(empty, np.zeros((0, 3), np.int64), empty, empty,
                              np.zeros(0, bool), np.zeros((0, 2), np.int64),
                              np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(0, bool),
                              np.zeros(0, bool))
    V = np.concatenate(verts)
    F = np.concatenate(faces)
    C = np.concatenate(colors)
    M = np.concatenate(mesh_ids)
    if not np.isfinite(V).all():
        raise ShapeError("model has NaN or infinite vertex coordinates; cannot render it")

    tri = V[F]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    scale = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    good = norm > 1e-14 * scale * scale
    normals = np.zeros_like(cross)
    normals[good] = cross[good] / norm[good, None]

    # Weld vertices per source mesh: the key is (mesh id, quantised position).
    vert_mesh = np.zeros(len(V), dtype=np.int64)
    vert_mesh[F.ravel()] = np.repeat(M, 3)
    quant = np.round((V - V.min(axis=0)) / (scale * 1e-9)).astype(np.int64)
    weld = _row_groups(np.column_stack([vert_mesh, quant]))
    n_weld = int(weld.max()) + 1
    WF = weld[F]

    half = WF[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # directed half-edges, 3 per face
    orig = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    face_of = np.repeat(np.arange(len(F)), 3)
    lo, hi = half.min(axis=1), half.max(axis=1)
    key = lo * n_weld + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    start = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    count = np.diff(np.r_[start, len(ks)])
    f1 = face_of[order[start]]
    f2 = np.where(count >= 2, face_of[order[np.minimum(start + 1, len(ks) - 1)]], -1)
    edges = orig[order[start]]
    edge_open = count != 2

    # A mesh is closed (back faces cullable) when every edge has two faces traversing it in
    # opposite directions and its signed volume is positive (normals point outwards).
    open_mesh = np.zeros(len(mesh_ids), dtype=bool)
    open_mesh[M[f1[edge_open]]] = True
    dkey = half[:, 0] * n_weld + half[:, 1]
    dsorted = np.sort(dkey)
    dup = np.flatnonzero(dsorted[1:] == dsorted[:-1])
    if len(dup):
        dup_keys = dsorted[dup]
        open_mesh[M[face_of[np.isin(dkey, dup_keys)]]] = True
    signed_vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))
    vol = np.bincount(M, weights=signed_vol, minlength=len(mesh_ids))
    open_mesh |= vol <= 0
    closed = ~open_mesh[M]

    both = f2 >= 0
    cos = np.ones(len(edges))
    cos[both] = np.einsum("ij,ij->i", normals[f1[both]], normals[f2[both]])
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    degenerate = ~good[f1] | (both & ~good[np.maximum(f2, 0)])
    angle[degenerate] = 0.0  # a sliver's normal is noise: never call its edges creases
    material = np.zeros(len(edges), dtype=bool)
    material[both] = np.abs(C[f1[both]] - C[f2[both]]).max(axis=1) > 0.5 / 255.0
    return RenderGeometry(V, F, C, normals, closed, edges, np.column_stack([f1, f2]), angle,
                          material, edge_open)


# ------------------------------------------------------------------------------------------
# Rasterisation
# ------------------------------------------------------------------------------------------
class Raster:
    """Per-pixel front-most face, per-face screen planes of the depth key (see
    `View.project`): key(x, y) = a*x + b*y + c in pixel units (NaN for undrawn faces), and
    the per-pixel key image, computed on first use (the line renderer does not need it)."""

    def __init__(self, face: np.ndarray, plane: np.ndarray, front: np.ndarray):
        self.face = face  # (H, W) int64, -1 where nothing was drawn
        self.plane = plane  # (F, 3)
        self.front = front  # (F,) face is front-facing
        self._key: np.ndarray | None = None

    @property
    def key(self) -> np.ndarray:
        """(H, W) float64 depth key at pixel centres, +inf where nothing was drawn."""
        if self._key is None:
            H, W = self.face.shape
            key = np.full((H, W), np.inf)
            yy, xx = np.nonzero(self.face >= 0)
            f = self.face[yy, xx]
            key[yy, xx] = self.plane[f, 0] * (xx + 0.5) + self.plane[f, 1] * (yy + 0.5) + \
                self.plane[f, 2]
            self._key = key
        return self._key

    def key_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The key at the centres of pixels (x, y) (integer arrays), +inf for background."""
        f = self.face[y, x]
        pl = self.plane[np.maximum(f, 0)]
        k = pl[:, 0] * (x + 0.5) + pl[:, 1] * (y + 0.5) + pl[:, 2]
        return np.where(f < 0, np.inf, k)


def _front_facing(geom: RenderGeometry, view: View) -> np.ndarray:
    centroids = geom.vertices[geom.faces].mean(axis=1)
    return np.einsum("ij,ij->i", geom.normals, view.view_vectors(centroids)) < 0


# long: chunked edge-function z-buffer fill; the stages share the per-frame depth buffers
def rasterize(geom: RenderGeometry, view: View, *, cull: bool = True,
              chunk: int = 1 << 20) -> Raster:
    """Z-buffer `geom` for `view` (pixel centres at i + 0.5)."""
    W, H = view.size
    F = len(geom.faces)
    front = _front_facing(geom, view)
    plane = np.full((F, 3), np.nan)
    buf = np.full(W * H, np.iinfo(np.int64).max, dtype=np.int64)
    if F == 0:
        return Raster(np.full((H, W), -1, np.int64), plane, front)

    px, key = view.project(geom.vertices)
    P = px[geom.faces]  # (F, 3, 2)
    K = key[geom.faces]
    draw = np.isfinite(P).all(axis=(1, 2)) & np.isfinite(K).all(axis=1)
    if view.perspective:  # triangles reaching behind the camera are dropped, not clipped
        depth = view.depth(geom.vertices)
        draw &= (depth[geom.faces] > 0).all(axis=1)
    if cull:
        draw &= front | ~geom.closed
    x0, y0 = P[:, 0, 0], P[:, 0, 1]
    e1 = P[:, 1] - P[:, 0]
    e2 = P[:, 2] - P[:, 0]
    with np.errstate(invalid="ignore"):
        area = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        draw &= np.abs(area) > 1e-12
        xmin = np.clip(np.ceil(P[..., 0].min(axis=1) - 0.5), 0, W)
        xmax = np.clip(np.floor(P[..., 0].max(axis=1) - 0.5), -1, W - 1)
        ymin = np.clip(np.ceil(P[..., 1].min(axis=1) - 0.5), 0, H)
        ymax = np.clip(np.floor(P[..., 1].max(axis=1) - 0.5), -1, H - 1)
    draw &= (xmax >= xmin) & (ymax >= ymin)
    idx = np.flatnonzero(draw)
    if len(idx) == 0:
        return Raster(np.full((H, W), -1, np.int64), plane, front)
    x0, y0, e1, e2, area, K = x0[idx], y0[idx], e1[idx], e2[idx], area[idx], K[idx]
    xmin, ymin = xmin[idx].astype(np.int64), ymin[idx].astype(np.int64)
    w = xmax[idx].astype(np.int64) - xmin + 1
    h = ymax[idx].astype(np.int64) - ymin + 1

    # Barycentrics l1, l2 and the key as affine functions of the pixel position.
    inv = 1.0 / area
    a1, b1 = e2[:, 1] * inv, -e2[:, 0] * inv
    a2, b2 = -e1[:, 1] * inv, e1[:, 0] * inv
    dk1, dk2 = K[:, 1] - K[:, 0], K[:, 2] - K[:, 0]
    ak, bk = a1 * dk1 + a2 * dk2, b1 * dk1 + b2 * dk2
    ck = K[:, 0] - (x0 * ak + y0 * bk)
    plane[idx] = np.column_stack([ak, bk, ck])
    kmin, kmax = float(K.min()), float(K.max())
    qscale = _DEPTH_LEVELS / (kmax - kmin) if kmax > kmin else 0.0
    # Inside test as three half-planes A*dx + B*dy + C >= 0 (dx, dy from vertex 0), the
    # barycentrics l1, l2, l0 = 1 - l1 - l2, with a small slack so that pixel centres on a
    # shared edge go to both triangles (no cracks; the depth test picks one).
    eps = 1e-7
    halfplanes = ((a1, b1, np.full_like(a1, eps)), (a2, b2, np.full_like(a2, eps)),
                  (-(a1 + a2), -(b1 + b2), np.full_like(a1, 1.0 + eps)))
    xmax_i = xmin + w - 1

    # Scanline spans: per triangle and pixel row, the exact run of covered pixel centres;
    # then one fragment per covered pixel. Chunks bound the memory by the bounding-box area.
    area_cum = np.cumsum(w * h)
    cuts = np.searchsorted(area_cum, np.arange(chunk, int(area_cum[-1]), chunk), side="right")
    bounds = np.unique(np.r_[0, np.minimum(cuts, len(idx)), len(idx)])
    for lo_t, hi_t in zip(bounds[:-1], bounds[1:]):
        t = np.arange(lo_t, hi_t)
        ht = h[t]
        row_t = np.repeat(t, ht)  # triangle (position in idx) of each row
        first_row = np.repeat(np.cumsum(ht) - ht, ht)
        y = ymin[row_t] + (np.arange(len(row_t)) - first_row)
        dy = y + 0.5 - y0[row_t]
        lo = np.full(len(row_t), -np.inf)
        hi = np.full(len(row_t), np.inf)
        empty = np.zeros(len(row_t), dtype=bool)
        for A, B, C in halfplanes:
            Ar, rhs = A[row_t], B[row_t] * dy + C[row_t]  # need Ar * dx >= -rhs
            with np.errstate(divide="ignore", invalid="ignore"):
                bound = -rhs / Ar
            pos, neg = Ar > 0, Ar < 0
            lo = np.where(pos, np.maximum(lo, bound), lo)
            hi = np.where(neg, np.minimum(hi, bound), hi)
            empty |= (Ar == 0) & (rhs < 0)
        xr0 = x0[row_t]
        xs = np.maximum(np.ceil(np.clip(xr0 + lo, -1.0, W + 1.0) - 0.5), xmin[row_t])
        xe = np.minimum(np.floor(np.clip(xr0 + hi, -1.0, W + 1.0) - 0.5), xmax_i[row_t])
        n = np.where(empty, 0, np.maximum(xe - xs + 1, 0)).astype(np.int64)
        total = int(n.sum())
        if total == 0:
            continue
        row_of = np.repeat(np.arange(len(row_t)), n)
        x = xs.astype(np.int64)[row_of] + (np.arange(total) - np.repeat(np.cumsum(n) - n, n))
        tr = row_t[row_of]
        krow = ck[row_t] + bk[row_t] * (y + 0.5)  # the key along the row is krow + ak * x
        kq = (krow[row_of] + ak[tr] * (x + 0.5) - kmin) * qscale
        q = np.clip(kq, 0, _DEPTH_LEVELS).astype(np.int64)
        np.minimum.at(buf, y[row_of] * W + x, (q << _ID_BITS) | idx[tr])

    hit = buf != np.iinfo(np.int64).max
    face = np.full(W * H, -1, dtype=np.int64)
    face[hit] = buf[hit] & ((1 << _ID_BITS) - 1)
    return Raster(face.reshape(H, W), plane, front)


# ------------------------------------------------------------------------------------------
# Lines
# ------------------------------------------------------------------------------------------
def _feature_edges(geom: RenderGeometry, front: np.ndarray, style: LineStyle) -> np.ndarray:
    """Indices of edges to draw (before the visibility test)."""
    f1, f2 = geom.edge_faces[:, 0], geom.edge_faces[:, 1]
    both = f2 >= 0
    fr1 = front[f1]
    fr2 = np.where(both, front[np.maximum(f2, 0)], fr1)
    want = np.zeros(len(f1), dtype=bool)
    if style.boundaries:
        want |= geom.edge_open
    if style.silhouettes:
        want |= both & (fr1 != fr2)
    if style.creases:
        want |= both & (geom.edge_angle > style.crease_angle)
    if style.material_edges:
        want |= geom.edge_material
    # Edges between two back faces of a closed mesh can never be seen.
    hidden = geom.closed[f1] & ~fr1 & ~fr2
    return np.flatnonzero(want & ~hidden)


def _visible_samples(geom: RenderGeometry, view: View, raster: Raster, edges: np.ndarray,
                     spacing: float = 1.0):
    """Sample the chosen edges every `spacing` pixels; return (edge index per sample, t along
    the edge, pixel positions, visible flags), ordered by edge then t."""
    px, key = view.project(geom.vertices)
    e = geom.edges[edges]
    p0, p1 = px[e[:, 0]], px[e[:, 1]]
    k0, k1 = key[e[:, 0]], key[e[:, 1]]
    ok = np.isfinite(p0).all(axis=1) & np.isfinite(p1).all(axis=1) & np.isfinite(k0) & \
        np.isfinite(k1)
    if view.perspective:
        depth = view.depth(geom.vertices)
        ok &= (depth[e[:, 0]] > 0) & (depth[e[:, 1]] > 0)
    W, H = view.size
    # Skip edges whose bounding box misses the image entirely.
    with np.errstate(invalid="ignore"):
        ok &= (np.maximum(p0[:, 0], p1[:, 0]) >= 0) & (np.minimum(p0[:, 0], p1[:, 0]) <= W)
        ok &= (np.maximum(p0[:, 1], p1[:, 1]) >= 0) & (np.minimum(p0[:, 1], p1[:, 1]) <= H)
    sel = np.flatnonzero(ok)
    p0, p1, k0, k1 = p0[sel], p1[sel], k0[sel], k1[sel]
    length = np.linalg.norm(p1 - p0, axis=1)
    n = np.maximum(2, np.ceil(length / spacing).astype(np.int64) + 1)
    # Guard against absurd sample counts from edges far outside the image.
    n = np.minimum(n, 4 * (W + H) + 2)
    eid = np.repeat(np.arange(len(sel)), n)
    first = np.repeat(np.cumsum(n) - n, n)
    t = (np.arange(len(eid)) - first) / np.repeat(n - 1, n)
    pos = p0[eid] + (p1 - p0)[eid] * t[:, None]
    sk = k0[eid] + (k1 - k0)[eid] * t

    ix = np.floor(pos[:, 0]).astype(np.int64)
    iy = np.floor(pos[:, 1]).astype(np.int64)
    inside = (ix >= 0) & (ix < W) & (iy >= 0) & (iy < H)
    finite_keys = key[np.isfinite(key)]
    krange = float(np.ptp(finite_keys)) if finite_keys.size else 1.0
    tol = 1e-6 * (krange or 1.0)

    def passes(dx: int, dy: int, which: np.ndarray) -> np.ndarray:
        """A sample passes at a neighbour pixel if nothing is drawn there or the sample is not
        behind the plane of the face drawn there (evaluated at the sample's own position)."""
        jx = np.clip(ix[which] + dx, 0, W - 1)
        jy = np.clip(iy[which] + dy, 0, H - 1)
        f = raster.face[jy, jx]
        res = f < 0
        drawn = ~res
        fd = f[drawn]
        pl = raster.plane[fd]
        wpos = pos[which][drawn]
        surface = pl[:, 0] * wpos[:, 0] + pl[:, 1] * wpos[:, 1] + pl[:, 2]
        res[drawn] = sk[which][drawn] <= surface + tol
        return res

    visible = np.zeros(len(eid), dtype=bool)
    cand = np.flatnonzero(inside)
    visible[cand] = passes(0, 0, cand)
    # Cheap conservative rejection before the neighbour tests: a face's plane evaluated at a
    # sample at most ~2.2 px from the face's pixel centre differs from the z-buffer value there
    # by at most 2.2 * |gradient|. A sample behind that bound for all 9 pixels is hidden.
    cand = cand[~visible[cand]]
    if len(cand):
        grad = np.hypot(raster.plane[:, 0], raster.plane[:, 1])
        bound = np.full(len(cand), -np.inf)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                jx = np.clip(ix[cand] + dx, 0, W - 1)
                jy = np.clip(iy[cand] + dy, 0, H - 1)
                f = raster.face[jy, jx]
                b = raster.key_at(jx, jy) + 2.2 * grad[np.maximum(f, 0)]
                np.maximum(bound, b, out=bound)
        cand = cand[sk[cand] <= bound + tol]
    # Samples hidden at their own pixel get a second chance from the 8 neighbours: near a
    # silhouette of a faceted surface the pixel may belong to a grazing neighbour facet.
    for dx, dy in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1), (-1, 1), (1, -1)):
        if len(cand) == 0:
            break
        visible[cand] = passes(dx, dy, cand)
        cand = cand[~visible[cand]]
    return eid, t, pos, visible, length


def _draw_lines(size: tuple[int, int], samples, style: LineStyle, ss: int) -> Image.Image:
    """Coverage mask ("L" image) of the visible runs of the sampled edges."""
    W, H = size
    eid, t, pos, visible, length = samples
    cover = Image.new("L", (W, H), 0)
    if not visible.any():
        return cover
    draw = ImageDraw.Draw(cover)
    width_px = max(1, int(round(style.width * ss)))
    radius = style.width * ss / 2.0
    same = np.r_[False, eid[1:] == eid[:-1]]
    starts = np.flatnonzero(visible & ~(same & np.r_[False, visible[:-1]]))
    nxt_same = np.r_[eid[1:] == eid[:-1], False]
    ends = np.flatnonzero(visible & ~(nxt_same & np.r_[visible[1:], False]))
    rng = np.random.default_rng(style.seed)
    for s, e in zip(starts.tolist(), ends.tolist()):
        a, b = pos[s], pos[e]
        if not style.sketchy:
            if e == s:
                continue
            draw.line([(a[0], a[1]), (b[0], b[1])], fill=255, width=width_px)
            if width_px >= 4:  # round caps so corners do not show notches
                for p in (a, b):
                    draw.ellipse([p[0] - radius, p[1] - radius, p[0] + radius, p[1] + radius],
                                 fill=255)
            continue
        seg = b - a
        seg_len = float(np.hypot(seg[0], seg[1]))
        if seg_len < 0.5 * ss:
            continue
        direction = seg / seg_len
        normal = np.array([-direction[1], direction[0]])
        # Short edges (small windows) get proportionally smaller overshoot and wobble, as a
        # person would draw them; otherwise small details turn into scribbles.
        over = min(style.overshoot * ss, 0.25 * seg_len)
        j = min(style.jitter * ss, 0.08 * seg_len)
        for _ in range(style.strokes):
            # Overshoot only where the run reaches a true end of the edge.
            o0 = rng.uniform(0.3, 1.0) * over if t[s] <= 0.0 else 0.0
            o1 = rng.uniform(0.3, 1.0) * over if t[e] >= 1.0 else 0.0
            c0, c1 = rng.uniform(-j, j, 2)
            amp = rng.uniform(-j, j) * 0.6
            phase = rng.uniform(0, 2 * math.pi)
            k = int(min(24, max(2, seg_len / (6 * ss))))
            u = np.linspace(0.0, 1.0, k + 1)
            offset = c0 * (1 - u) + c1 * u + amp * np.sin(math.pi * u + phase)
            along = -o0 + u * (seg_len + o0 + o1)
            pts = a + direction * along[:, None] + normal * offset[:, None]
            draw.line([tuple(p) for p in pts.tolist()], fill=255, width=width_px, joint="curve")
    return cover


# ------------------------------------------------------------------------------------------
# Public entry points
# ------------------------------------------------------------------------------------------
def _rgba(color: Sequence[float] | None) -> tuple[np.ndarray, float] | None:
    if color is None:
        return None
    c = np.asarray(color, dtype=np.float64)
    if c.shape not in ((3,), (4,)):
        raise ValueError(f"colour must be (r, g, b) or (r, g, b, a), got {color!r}")
    if c.max() > 1.0:  # 0-255 given
        c = c / 255.0
    return c[:3], float(c[3]) if len(c) == 4 else 1.0


def render(obj: Any, camera: Camera | View | None = None, style: str = "shaded",
           size: tuple[int, int] = (512, 512), line_style: LineStyle | None = None,
           background: Sequence[float] | None = (255, 255, 255), *, supersample: int = 2,
           light: Sequence[float] = (-0.35, 0.6, 0.7), ambient: float = 0.45,
           max_triangles: int = MAX_TRIANGLES) -> Image.Image:
    """Render a Trimesh, Scene, Model, Assembly (or a `prepare`d geometry) to a PIL image.

    `camera`: a `Camera` (default: Nishida's pitch 30 / yaw -45 / fov 45, framed) or an
    already resolved `View` of the same size. `background=None` gives a transparent RGBA image.
    `light` is a direction in camera space (x right, y up, z towards the viewer).
    """
    if style not in STYLES:
        raise ValueError(f"unknown render style {style!r}; expected one of {', '.join(STYLES)}")
    if supersample < 1 or supersample > 4:
        raise ValueError(f"supersample must be 1..4, got {supersample}")
    W, H = int(size[0]), int(size[1])
    if W < 1 or H < 1 or W * H > 64_000_000:
        raise ValueError(f"image size must be positive and at most 64 megapixels, got {size}")
    geom = prepare(obj, max_triangles=max_triangles)
    if isinstance(camera, View):
        if camera.size != (W, H):
            raise ValueError(f"the View was resolved for size {camera.size}, not {(W, H)}")
        view = camera
    else:
        view = (camera or Camera()).resolve(geom.vertices, (W, H))
    ss = int(supersample)
    sview = view.scaled(ss) if ss > 1 else view
    raster = rasterize(geom, sview)
    drawn = raster.face >= 0
    bg = _rgba(background)
    bg_rgb = bg[0] if bg is not None else np.ones(3)
    bg_u8 = tuple(int(round(c * 255)) for c in bg_rgb)

    # Compose at the supersampled size in uint8 with Pillow's C routines, then box-filter down.
    if style in ("shaded", "shaded+lines"):
        L = np.asarray(light, dtype=np.float64)
        L = L[0] * view.right + L[1] * view.up - L[2] * view.forward
        L /= np.linalg.norm(L)
        n = np.where(raster.front[:, None], geom.normals, -geom.normals)  # two-sided
        lambert = np.clip(n @ L, 0.0, 1.0)
        shade = geom.face_colors * (ambient + (1.0 - ambient) * lambert)[:, None]
        shade_u8 = np.clip(np.round(shade * 255.0), 0, 255).astype(np.uint8)
        table = np.vstack([shade_u8, np.asarray(bg_u8, dtype=np.uint8)])  # face -1: background
        img = Image.fromarray(table[raster.face], "RGB")
    else:  # hidden-line drawing: surfaces only hide, they are not painted
        img = Image.new("RGB", sview.size, bg_u8)
    alpha = Image.fromarray(drawn.astype(np.uint8) * 255, "L")
    if style in ("lines", "shaded+lines"):
        ls = line_style or LineStyle()
        edges = _feature_edges(geom, raster.front, ls)
        samples = _visible_samples(geom, sview, raster, edges)
        cover = _draw_lines(sview.size, samples, ls, ss)
        lc = tuple(int(round(c * 255)) for c in _rgba(ls.color)[0])
        img = Image.composite(Image.new("RGB", sview.size, lc), img, cover)
        alpha = ImageChops.lighter(alpha, cover)
    if ss > 1:
        img = img.reduce(ss)
        alpha = alpha.reduce(ss)
    if bg is None or bg[1] < 1.0:
        base = 0.0 if bg is None else bg[1]
        a = np.asarray(alpha, dtype=np.float64) / 255.0
        a_out = base + (1.0 - base) * a
        rgb = np.asarray(img, dtype=np.float64) / 255.0
        if bg is None:  # un-mix the background colour out of anti-aliased edge pixels
            with np.errstate(invalid="ignore", divide="ignore"):
                rgb = np.where(a[..., None] > 0,
                               (rgb - (1.0 - a[..., None]) * bg_rgb) / a[..., None], 0.0)
        out = np.dstack([np.clip(np.round(rgb * 255.0), 0, 255),
                         np.clip(np.round(a_out * 255.0), 0, 255)]).astype(np.uint8)
        return Image.fromarray(out, "RGBA")
    return img


def save_image(img: Image.Image, path: str | Path, format: str | None = None) -> Path:
    """Write `img` atomically (temporary file in the same folder, then rename)."""
    from ..fileio import atomic_output

    path = Path(path)
    fmt = format or Image.registered_extensions().get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"{path}: unknown image format {path.suffix!r}; use .png, .jpg, ...")
    with atomic_output(path) as tmp:
        img.save(tmp, format=fmt)
    return path
