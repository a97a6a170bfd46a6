"""What the final union of a derivation can leave out, and how its result is checked cheaply.

- `free_parts`: the default mode cuts CGA's window openings (`extrude(-d) comp(f)`) out of the
  closing solid and inserts the window asset in the hole. A part that lies entirely inside
  such an opening (a box test in the opening's own frame) and whose box meets no other part,
  cut or opening, cannot touch anything once it is shrunk by FREE_CLEARANCE about its scope's
  centre (instead of being grown by the weld that makes touching parts overlap): it is a closed
  body of its own, `FREE_CLEARANCE` clear of the reveal on every side, and needs no boolean.
  candler: 278 windows (100,000 of the union's 114,000 triangles) leave the union.
- `with_free_parts`: those parts' triangles appended to the union's mesh (their runs and
  original IDs, so their tags, kept), one manifold of the whole.
- `may_have_slivers`: whether the union may hold a sliver shell (numpy; manifold3d's decompose
  costs seconds on a mesh of hundreds of shells).
"""
from __future__ import annotations

from typing import Any

import manifold3d
import numpy as np

from .engine import CUT_WELD, _box_of, welded_frame
from .pinches import coincident_groups, components, separate

__all__ = ["FREE_CLEARANCE", "FREE_PARTS", "LazySolid", "SLIVER_PRECHECK", "SLIVER_THICKNESS", "SLIVER_VOLUME", "free_parts",
           "may_have_slivers", "with_free_parts"]

Manifold = manifold3d.Manifold

# A shell of the union whose volume is below this (cubic model units) is a degenerate sliver
# (two faces of the same zero-thickness wedge, e.g. where a recess cut grazes a roof's knife-edge
# eave): it has no material, only pinched edges that break watertightness on reading back.
SLIVER_VOLUME = 1e-9

# A shell whose volume per area of surface (m) is below SLIVER_THICKNESS (or whose volume is
# below ten times SLIVER_VOLUME) may be a sliver: then the exact test (manifold3d's decompose
# and volumes) decides. A true sliver's volume from float32 positions is at most about
# (position error) x (area), 1e-6 x area at 20 m: far below the test.
SLIVER_THICKNESS = 1e-4

# The numpy pre-check before manifold3d's decompose (on), or decompose always (off: before
# issue 27's third step, as FREE_PARTS).
SLIVER_PRECHECK = True

# Parts inside an opening leave the union (on), or are united like the others (off: the
# default before issue 27's third step; benchmarks/bench_prt.py --previous measures it).
FREE_PARTS = True

# How much a free part is shrunk on every side (m): with the opening grown by CUT_WELD, a window
# fitted to it is 1 mm clear of the reveal at the sides and 0.5 mm clear of its bottom.
FREE_CLEARANCE = CUT_WELD

_EPS = 1e-6  # strictly inside the opening, by this much


def _overlaps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) booleans: closed boxes (x0, y0, z0, x1, y1, z1) meet."""
    return np.asarray(((a[:, None, :3] <= b[None, :, 3:]) & (b[None, :, :3] <= a[:, None, 3:])).all(axis=2))


def _inside(m: list, local: tuple, o: tuple, ax: tuple, size: tuple) -> bool:
    """Whether the local box `local` under the affine map `m` (3 x 4) lies strictly inside the
    box [0, size] of the frame (o, ax) (orthonormal axes)."""
    M = np.asarray(m, dtype=np.float64)
    x0, y0, z0, x1, y1, z1 = local
    corners = np.array([(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)])
    q = (corners @ M[:, :3].T + M[:, 3] - np.asarray(o)) @ np.asarray(ax, dtype=np.float64).T
    return bool((q > _EPS).all() and (q < np.asarray(size) - _EPS).all())


# long: one pass of numpy filters (boxes in openings, boxes clear of every other box), then the
# exact frame test per candidate; split up it would hand five arrays between helpers
def free_parts(ctx: Any) -> dict[int, Any]:
    """Index in `ctx.adds` -> the part as a world solid shrunk by FREE_CLEARANCE, for every
    part that lies inside a box opening and meets no other part (see the module docstring)."""
    if not (FREE_PARTS and ctx.opening_boxes and ctx.add_local) or len(ctx.add_boxes) != len(ctx.adds):
        return {}
    closing = {rec[0] for rec in ctx.opening_boxes}
    c = FREE_CLEARANCE
    index, frames, boxes = [], [], []
    for i, (_solid, o, ax, sz, local) in ctx.add_local.items():
        if i in closing or min(sz) <= 4 * c:
            continue
        m = welded_frame(o, ax, sz, -c)
        index.append(i)
        frames.append(m)
        boxes.append(_box_of(m, local))
    if not index:
        return {}
    cand = np.asarray(boxes, dtype=np.float64)
    op = np.asarray([_box_of([[a[0][r], a[1][r], a[2][r], o[r]] for r in range(3)], (0.0, 0.0, 0.0, *size))
                     for _k, o, a, size in ctx.opening_boxes], dtype=np.float64)
    inside = np.asarray(((cand[:, None, :3] > op[None, :, :3]) & (cand[:, None, 3:] < op[None, :, 3:])).all(axis=2))
    hits = _overlaps(cand, np.asarray(ctx.add_boxes, dtype=np.float64))
    # cuts and solids added after them would reach into the part: a part meeting one stays
    others = [tuple(x[0].bounding_box()) for x in ctx.cuts] + [tuple(p.bounding_box()) for p in ctx.post_adds]
    blocked = _overlaps(cand, np.asarray(others, dtype=np.float64)).any(axis=1) if others else None
    free: dict[int, Any] = {}
    for row in np.nonzero(inside.sum(axis=1) == 1)[0].tolist():
        if blocked is not None and blocked[row]:
            continue
        i = index[row]
        k = int(np.nonzero(inside[row])[0][0])
        owner, o, ax, size = ctx.opening_boxes[k]
        met = set(np.nonzero(hits[row])[0].tolist()) - {i, owner}
        if met or not _inside(frames[row], ctx.add_local[i][4], o, ax, size):
            continue
        free[i] = ctx.add_local[i][0].transform(frames[row])
    return free


def with_free_parts(body: Any, mesh: Any, free: list) -> tuple[Any, Any]:
    """(LazySolid, Mesh) of the union `body` (its mesh `mesh`) and the free parts side by side:
    their triangles appended, runs and original IDs kept, pinched vertices pulled apart
    (pinches.py), one manifold of the whole (built when asked for). Falls back to manifold3d's union (which,
    the parts being apart, only composes them) if the meshes do not fit together."""
    meshes = [mesh] + [f.to_mesh() for f in free]
    if len({np.asarray(m.vert_properties).shape[1] for m in meshes}) != 1:
        united = Manifold.batch_boolean([body, *free], manifold3d.OpType.Add)
        return united, united.to_mesh()
    verts, tris, runs, ids, m_from, m_to = [], [], [], [], [], []
    nv = nt = 0
    for m in meshes:
        v = np.asarray(m.vert_properties, dtype=np.float32)
        t = np.asarray(m.tri_verts, dtype=np.uint32).reshape(-1, 3)
        verts.append(v)
        tris.append(t + np.uint32(nv))
        runs.append(np.asarray(m.run_index, dtype=np.int64)[:-1] + 3 * nt)
        ids.append(np.asarray(m.run_original_id, dtype=np.uint32))
        m_from.append(np.asarray(m.merge_from_vert, dtype=np.int64) + nv)
        m_to.append(np.asarray(m.merge_to_vert, dtype=np.int64) + nv)
        nv += len(v)
        nt += len(t)
    runs.append(np.array([3 * nt], dtype=np.int64))
    kw = {}
    if sum(len(x) for x in m_from):
        kw = {"merge_from_vert": np.concatenate(m_from).astype(np.uint32),
              "merge_to_vert": np.concatenate(m_to).astype(np.uint32)}
    out = manifold3d.Mesh(vert_properties=np.ascontiguousarray(np.concatenate(verts)),
                          tri_verts=np.ascontiguousarray(np.concatenate(tris)),
                          run_index=np.concatenate(runs).astype(np.uint32),
                          run_original_id=np.concatenate(ids), **kw)
    groups = coincident_groups(out.vert_properties)
    if groups:
        _none, out = separate(None, out, groups, build=False)
    return LazySolid(out, lambda: Manifold.batch_boolean([body, *free], manifold3d.OpType.Add)), out


class LazySolid:
    """The manifold of a mesh known to be one (disjoint closed manifolds side by side, or a
    manifold with positions moved: pinches.separate), built when first asked for
    (`Model.manifold`): building it is ~0.1 s for candler's 117,000 triangles, which a derive
    that only writes or measures the mesh does not need. If manifold3d rejects the mesh after
    all (never expected), `fallback()` gives the solid."""

    def __init__(self, mesh: Any, fallback: Any):
        self.mesh = mesh
        self.fallback = fallback

    def build(self) -> Any:
        solid = Manifold(self.mesh)
        return solid if solid.status() == manifold3d.Error.NoError else self.fallback()


def may_have_slivers(mesh: Any) -> bool:
    """Whether some shell of the mesh may be a sliver (see SLIVER_THICKNESS): its shells
    (triangles joined by shared manifold vertices) and their signed volumes and areas, in numpy.
    Cheap where manifold3d's decompose is not (candler: 453 shells, 3.0 s decompose, ~10 ms)."""
    if not SLIVER_PRECHECK:
        return True
    tris = np.asarray(mesh.tri_verts, dtype=np.int64).reshape(-1, 3)
    if len(tris) == 0:
        return False
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    nv = len(verts)
    ids = np.arange(nv)
    merge_from, merge_to = np.asarray(mesh.merge_from_vert), np.asarray(mesh.merge_to_vert)
    if len(merge_from):  # property seams: copies of one manifold vertex
        ids[merge_from.astype(np.int64)] = merge_to.astype(np.int64)
    t = ids[tris]
    root = components(nv, np.concatenate([t[:, 0], t[:, 0]]), np.concatenate([t[:, 1], t[:, 2]]))
    roots, shell = np.unique(root[t[:, 0]], return_inverse=True)
    count = len(roots)
    if count < 2:
        return False  # one shell is kept whatever its volume (as decompose's one piece)
    shell = shell.reshape(-1)
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    # about each shell's first vertex, so that float errors scale with the shell, not the model
    ref = np.zeros((count, 3))
    ref[shell[::-1]] = a[::-1]
    a, b, c = a - ref[shell], b - ref[shell], c - ref[shell]
    cross = np.cross(b - a, c - a)
    volume = np.bincount(shell, np.einsum("ij,ij->i", a, cross), minlength=count) / 6.0
    area = np.bincount(shell, np.linalg.norm(cross, axis=1), minlength=count) / 2.0
    return bool((np.abs(volume) < np.maximum(10 * SLIVER_VOLUME, SLIVER_THICKNESS * area)).any())
