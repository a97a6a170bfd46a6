"""Faces a scope turn left out of the scope's xy plane, for the operations that work in a
face's plane (CGA's rotateScope keeps the geometry, normal included, and turns only the scope).

grammarkit's faces lie in their scope's xy plane and look along its z, so a face turned any
other way is carried as an open surface mesh in the new scope (grammarkit/split/ops/
scope_ops.py, `reframe`): its normal stays the geometry's, as in CGA (an `extrude` after it
goes the way the face looks; `alignScopeToAxes`/`alignScopeToGeometry` make it a face again).
Two such turns keep the face in a plane of the scope, and CGA's face operations still work on
it there:

- a half turn about an axis in its plane (`rotateScope(180, 0, 0)`): the face in the scope's
  xy plane, looking along -z (turned over);
- a quarter turn about an axis in its plane (`rotateScope(90, 0, 0)`): the face in the
  scope's xz (or yz) plane. This is what a CGA lot becomes after CGA's `rotateScope(90, 0, 0)`
  (a lot's CGA scope is y-up, so the lot then lies in CGA's scope xy plane).

The operations that need a face and work in its plane only (setbacks, shapeL/U/O,
innerRectangle, offset, splitArea: TURNED_FACE_OPS) run on such a flat mesh as on a face: the
face in a frame whose xy plane is the face's, its outline the same; their edge selectors are
classified by the edges' outward normals in the *turned scope's* quadrants, as CGA's are (a
face in the scope's xz plane has no front or back edges, its edges along z are top/bottom);
each face they make is put back in the turned scope as a flat mesh facing the geometry's way.
"""
from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any, Callable

from .shape import FACE, VOLUME, Shape

if TYPE_CHECKING:
    from ..geometry.surfaces import SurfaceMesh

# numpy and the geometry layer are imported inside the functions: steps.py wraps operations
# with `on_turned_faces` when a grammar is compiled, and `grammarkit check` must not load them
# (tests/core/test_startup_imports.py)

__all__ = ["TURNED_FACE_OPS", "naming_axes", "on_turned_faces", "turned_face", "turned_back"]

# operations that need a face and work in its plane only
TURNED_FACE_OPS = frozenset({"setback", "setbackPerEdge", "setbackToArea", "shapeL", "shapeU",
                             "shapeO", "innerRectangle", "offset", "splitArea"})

_FLAT = 1e-7
_naming = threading.local()  # the turned scope's axes while an operation runs on its face


def naming_axes() -> Any:
    """The world axes edge selectors are classified in while a face operation runs on a
    turned face (lots.edge_names), else None."""
    return getattr(_naming, "axes", None)


def _plane(mesh: SurfaceMesh, sz: tuple) -> tuple[int, float] | None:
    """(the scope axis the flat mesh is perpendicular to, the sign its triangles face along
    it), or None when the mesh does not lie flat in a plane of the scope through its origin."""
    import numpy as np

    for k in (2, 1, 0):
        if abs(sz[k]) > _FLAT or np.abs(mesh.V[:, k]).max() > _FLAT:
            continue
        a, b, c = (mesh.V[mesh.F[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)[:, k]
        live = np.abs(n) > 1e-12
        if not live.any():
            return None
        if (n[live] > 0).all():
            return k, 1.0
        if (n[live] < 0).all():
            return k, -1.0
        return None
    return None


# the face's frame, rows in the turned scope's coordinates, per plane (right-handed: the face
# in its xy plane, its z the plane's normal)
_FRAMES = {2: ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
           1: ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)),
           0: ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0))}


def turned_face(s: Shape) -> tuple[Shape, bool] | None:
    """(the face, whether its geometry looks along the face's -z) of a shape that is a face
    turned out of its scope's xy plane into a plane of the scope; else None."""
    import numpy as np

    from ..geometry.surfaces import SurfaceMesh
    from .ops.scope_ops import _flat_outline, _rect_or_poly

    mesh = s.solid
    if type(mesh) is not SurfaceMesh or len(mesh.F) == 0:
        return None
    found = _plane(mesh, s.sz)
    if found is None:
        return None
    k, sign = found
    T = np.asarray(_FRAMES[k])
    V = mesh.V @ T.T  # in the face's frame: the plane is z = 0
    flipped = (T[2] @ np.eye(3)[k]) * sign < 0  # the geometry looks along the frame's -z
    lo = V.min(axis=0)
    V = V - lo
    V[:, 2] = 0.0
    F = mesh.F[:, ::-1] if flipped else mesh.F
    outline = _flat_outline(SurfaceMesh(V, F))
    if outline is None:
        return None
    ax = tuple(tuple(float(sum(T[j][i] * s.ax[i][c] for i in range(3))) for c in range(3)) for j in range(3))
    o = tuple(s.o[c] + sum(ax[j][c] * lo[j] for j in range(2)) for c in range(3))
    hi = V.max(axis=0)
    c = s.copy()
    c.kind, c.solid, c.on = FACE, None, None
    c.o, c.ax = o, ax  # type: ignore[assignment]
    c.sz = (float(hi[0]), float(hi[1]), 0.0)
    c.poly = _rect_or_poly(outline, c.sz[0], c.sz[1])
    return c, bool(flipped)


def turned_back(r: Shape, scope: Shape, flipped: bool) -> Shape:
    """A face an operation made from a turned face, put back in the turned scope's axes (those
    of `scope`) as a flat mesh facing the geometry's way; other shapes are returned as they
    are."""
    import numpy as np

    from ..geometry.surfaces import SurfaceMesh, face_triangles

    if r.kind != FACE:
        return r
    W, F = face_triangles(r.o, r.ax, r.sz, r.poly)  # world vertices
    if len(F) == 0:
        return r
    A = np.asarray(scope.ax, dtype=np.float64)
    L = (W - np.asarray(scope.o)) @ A.T  # in the turned scope's coordinates
    lo, hi = L.min(axis=0), L.max(axis=0)
    c = r.copy()
    c.kind, c.poly, c.on = VOLUME, None, None
    c.ax = scope.ax
    c.o = tuple(scope.o[k] + sum(A[j][k] * lo[j] for j in range(3)) for k in range(3))  # type: ignore[assignment]
    ext = hi - lo
    ext[np.abs(ext) < _FLAT] = 0.0
    c.sz = (float(ext[0]), float(ext[1]), float(ext[2]))
    L = L - lo
    L[np.abs(L) < _FLAT] = 0.0
    c.solid = SurfaceMesh(L, F[:, ::-1] if flipped else F)
    return c


def on_turned_faces(apply: Callable) -> Callable:
    """`apply` (an operation of TURNED_FACE_OPS) that also runs on a turned face."""
    def run(ctx: Any, s: Shape, args: Any, block: Any) -> Any:
        found = turned_face(s) if s.solid is not None else None  # turned_face checks the kind of mesh
        if found is None:
            return apply(ctx, s, args, block)
        face, flipped = found
        previous = getattr(_naming, "axes", None)
        _naming.axes = s.ax
        try:
            r = apply(ctx, face, args, block)
        finally:
            _naming.axes = previous
        if type(r) is list:
            return [(turned_back(item[0], s, flipped), *item[1:]) for item in r]
        return turned_back(r, s, flipped) if isinstance(r, Shape) else r
    return run
