"""`comp(e)`, `comp(fe)` and `comp(v)`: a shape's edges, face edges and vertices as shapes of
their own (CGA).

The edges are those of the shape's planar faces (a face's outline; a volume's feature edges,
where two planar faces meet: a box has 12, a gable roof's ridge is one): each becomes a shape
with x along the edge, y the component's normal (the mean of the normals of the faces it
bounds: CGA's "y-normal") and z = x × y; its size is (length, 0, 0). A vertex (a corner of
the outlines) is a shape of size 0 at the point, y its normal (the mean of its faces'), x along
its first edge. A component's scope can then be given a size (`s()`), centred on the component
(`center()` in the branch refers to the component's scope) and filled (`i()`), as CGA rules do
with pipes along edges.

`comp(fe)` (face edges) hands out each edge of each face separately, as CGA does: an edge two
faces share comes once per face, with y the normal of that face (so a box's top face gives
four edges whose y-normal is up, and the side faces' edges look sideways); its index is its
position in face order, edge order within each face (the face's outline from its first
point; a lot's edges in the lot's order).

Selectors (a component goes to the first branch that selects it), classified by the y-normal
in the shape's scope like `comp(f)`'s faces but with CGA's angle ranges for components:
`front`, `back`, `left`, `right`, `top`, `bottom`, `side`; `vertical` (the normal within
11.25 degrees of horizontal: a wall's corner edge), `horizontal` (within 11.25 degrees of
vertical), `aslant` / `nutant` (pointing up / down in between); `border` (an edge of one face
only: a face's outline, an open mesh's rim; a vertex on such an edge) and `inside`; the roof
edges `eave` (the lower, horizontal edge of a sloped face, where it meets a wall, a fascia or
the roof's bottom), `ridge` (two sloped faces meeting
in a horizontal convex edge), `hip` (a sloped convex one), `valley` (a concave one); `all`;
an index.
"""
from __future__ import annotations

import math
from typing import Any


from ..shape import FACE, Shape
from .helpers import lazy_module

np = lazy_module("numpy")
planar = lazy_module("grammarkit.geometry.planar")
surfaces = lazy_module("grammarkit.geometry.surfaces")

__all__ = ["EDGE_SELECTORS", "edge_components", "face_edge_components", "op_comp_edges", "op_comp_face_edges",
           "op_comp_vertices", "vertex_components"]

EDGE_SELECTORS = ("front", "back", "left", "right", "top", "bottom", "side", "vertical", "horizontal", "aslant",
                  "nutant", "border", "inside", "eave", "ridge", "hip", "valley", "all")
_SIN_CGA = math.sin(math.radians(11.25))  # CGA's component ranges: ]-11.25, 11.25] is vertical
_COS45 = math.cos(math.radians(45.0))
_SLOPED = (math.sin(math.radians(1.0)), math.cos(math.radians(1.0)))  # neither vertical nor flat
# comp(e)/comp(v) of a mesh with more triangles than this is refused (each edge is a shape)
MAX_TRIANGLES = 200_000


def _faces(s: Shape) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """(unit normal, outline loops) of the shape's planar faces, in scope coordinates."""
    if s.kind == FACE:
        return [(np.array([0.0, 0.0, 1.0]), [np.array([(x, y, 0.0) for x, y in c]) for c in s.contours()])]
    solid = s.solid
    if isinstance(solid, surfaces.SurfaceMesh):
        V, F = solid.V, solid.F
    else:
        from ..scope_solid import local_solid

        m, _oid, _n = local_solid(s)
        if m is None:
            return []
        mesh = m.to_mesh()
        V = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        F = np.asarray(mesh.tri_verts, dtype=np.int64).reshape(-1, 3)
    if len(F) > MAX_TRIANGLES:
        raise ValueError(f"a mesh with {len(F)} triangles (more than {MAX_TRIANGLES}): simplify the asset")
    return [(pf.normal, pf.loops) for pf in planar.planar_faces(V, F)]


def _names(n: np.ndarray) -> set[str]:
    """Orientation selectors of a component whose y-normal is `n` (scope coordinates)."""
    nx, ny, nz = (float(v) for v in n)
    out = {"all"}
    if nz > _COS45:
        out.add("top")
    elif nz < -_COS45:
        out.add("bottom")
    else:
        out |= {"side", ("front" if ny < 0 else "back") if abs(ny) >= abs(nx) else ("right" if nx > 0 else "left")}
    if abs(nz) <= _SIN_CGA:
        out.add("vertical")
    elif abs(nz) > math.cos(math.radians(11.25)):
        out.add("horizontal")
    else:
        out.add("aslant" if nz > 0 else "nutant")
    return out


def _key(p: np.ndarray) -> tuple:
    return tuple(np.round(p, 7).tolist())


def _frame(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal frame with x as given and y as close to `y` as possible."""
    x = x / (np.linalg.norm(x) or 1.0)
    y = y - x * float(y @ x)
    if np.linalg.norm(y) < 1e-9:  # y along the edge: any perpendicular
        y = np.cross(x, [0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.cross(x, [1.0, 0.0, 0.0])
    y = y / np.linalg.norm(y)
    return x, y, np.cross(x, y)


def _shape(s: Shape, o: np.ndarray, ex: np.ndarray, ey: np.ndarray, ez: np.ndarray, length: float) -> Shape:
    M = np.asarray(s.ax, dtype=np.float64)  # rows: scope axes in world coordinates
    wax = tuple(tuple(float(v) for v in (a @ M)) for a in (ex, ey, ez))
    c = s.derived(s.world(*(float(v) for v in o)), (length, 0.0, 0.0), None, FACE, ax=wax)  # type: ignore[arg-type]
    # center() in the branch centres on the component (CGA: a pipe centred on its edge), not
    # on the decomposed shape
    c.entry = (c.o, c.ax, c.sz)
    return c


def _outline_segments(faces: list):  # noqa: ANN202
    """(face index, start, end) of every segment of the faces' outlines, in outline order."""
    for fi, (_n, loops) in enumerate(faces):
        for loop in loops:
            k = len(loop)
            for i in range(k):
                yield fi, loop[i], loop[(i + 1) % k]


def edge_components(s: Shape) -> list[tuple[set[str], Shape]]:
    """The shape's edges: (selector names, edge shape), in the order of the faces' outlines."""
    faces = _faces(s)
    edges: dict[tuple, dict] = {}
    order: list[tuple] = []
    for fi, p, q in _outline_segments(faces):
        if np.linalg.norm(q - p) < 1e-9:
            continue
        key = tuple(sorted((_key(p), _key(q))))
        e = edges.get(key)
        if e is None:
            e = edges[key] = {"p": p, "q": q, "faces": []}
            order.append(key)
        e["faces"].append(fi)
    centre = {fi: np.mean(np.concatenate(loops), axis=0) for fi, (_n, loops) in enumerate(faces)}
    out = []
    for key in order:
        e = edges[key]
        p, q, fs = e["p"], e["q"], e["faces"]
        normals = [faces[f][0] for f in fs]
        if len(fs) == 2 and float(normals[0] @ normals[1]) > math.cos(math.radians(1.0)):
            continue  # two coplanar faces (a triangulation seam): not an edge of the shape
        ny = np.sum(normals, axis=0)
        ex, ey, ez = _frame(q - p, ny if np.linalg.norm(ny) > 1e-9 else normals[0])
        names = _names(ey)
        names.add("border" if len(fs) == 1 else "inside")
        if len(fs) == 2:
            names |= _roof_names(q - p, normals, [centre[f] for f in fs], (p + q) / 2)
        out.append((names, _shape(s, p, ex, ey, ez, float(np.linalg.norm(q - p)))))
    return out


def face_edge_components(s: Shape) -> list[tuple[set[str], Shape]]:
    """CGA's `comp(fe)`: every edge of every face, once per face (an edge two faces share
    comes twice). The faces are comp(f)'s, in comp(f)'s order (a box: bottom, top, then the
    sides), each face's edges in its outline's order: x along the edge in the outline's
    direction, y the face's normal (the component's y-normal, classified as for comp(e)),
    z = x × y (pointing out of the face). `border`/`inside` and the roof names are those of
    the edge itself (as comp(e) names it)."""
    from .faces import faces_of

    M = np.asarray(s.ax, dtype=np.float64)  # rows: scope axes in world coordinates
    so = np.asarray(s.o, dtype=np.float64)

    def local(w: np.ndarray) -> np.ndarray:  # a world point -> the shape's scope coordinates
        return M @ (w - so)

    faces = []  # (normal, [(p, q) in scope coordinates], centre) per comp(f) face
    for _sel, f in faces_of(s):
        normal = M @ np.asarray(f.ax[2], dtype=np.float64)
        segs = []
        for ring in f.contours():
            pts = [local(np.asarray(f.world(x, y, 0.0))) for x, y in ring]
            segs.extend((pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts)))
        if segs:
            faces.append((normal, segs, np.mean([p for p, _q in segs], axis=0)))
    count: dict[tuple, list[int]] = {}
    for fi, (_n, segs, _c) in enumerate(faces):
        for p, q in segs:
            if np.linalg.norm(q - p) >= 1e-9:
                count.setdefault(tuple(sorted((_key(p), _key(q)))), []).append(fi)
    out = []
    for fi, (normal, segs, _c) in enumerate(faces):
        for p, q in segs:
            length = float(np.linalg.norm(q - p))
            if length < 1e-9:
                continue
            ex, ey, ez = _frame(q - p, normal)
            names = _names(ey)
            fs = count[tuple(sorted((_key(p), _key(q))))]
            names.add("border" if len(fs) == 1 else "inside")
            if len(fs) == 2:
                names |= _roof_names(q - p, [faces[f][0] for f in fs], [faces[f][2] for f in fs], (p + q) / 2)
            out.append((names, _shape(s, p, ex, ey, ez, length)))
    return out


def _roof_names(d: np.ndarray, normals: list[np.ndarray], centres: list[np.ndarray], mid: np.ndarray) -> set[str]:
    """eave / ridge / hip / valley of an edge between two faces (scope z up)."""
    n1, n2 = normals
    sloped = [_SLOPED[0] < abs(float(n[2])) < _SLOPED[1] for n in normals]
    horizontal_edge = abs(float(d[2])) <= 1e-6 * (np.linalg.norm(d) or 1.0)
    if horizontal_edge and sloped.count(True) == 1:
        # the lower edge of a roof plane, where it meets a wall, a fascia or the roof's bottom
        k = sloped.index(True)
        other = normals[1 - k]
        if float(normals[k][2]) > 0 and float(other[2]) <= _SLOPED[0] and float(centres[k][2]) > float(mid[2]):
            return {"eave"}
    if not all(sloped):
        return set()
    # convex where each face's centre lies behind the other face's plane
    convex = float((centres[1] - mid) @ n1) < 0 and float((centres[0] - mid) @ n2) < 0
    if not convex:
        return {"valley"}
    return {"ridge"} if horizontal_edge else {"hip"}


def vertex_components(s: Shape) -> list[tuple[set[str], Shape]]:
    """The shape's vertices (corners of its faces' outlines): (selector names, vertex shape)."""
    faces = _faces(s)
    verts: dict[tuple, dict] = {}
    order: list[tuple] = []
    for fi, p, q in _outline_segments(faces):
        key = _key(p)
        v = verts.get(key)
        if v is None:
            v = verts[key] = {"p": p, "faces": [], "first": q - p}
            order.append(key)
        if fi not in v["faces"]:
            v["faces"].append(fi)
    border = {k for k, b in _border_vertices(faces).items() if b}
    out = []
    for key in order:
        v = verts[key]
        normals = [faces[f][0] for f in v["faces"]]
        ny = np.sum(normals, axis=0)
        ex, ey, ez = _frame(_perpendicular(ny, v["first"]), ny if np.linalg.norm(ny) > 1e-9 else normals[0])
        names = _names(ey)
        names.add("border" if key in border else "inside")
        out.append((names, _shape(s, v["p"], ex, ey, ez, 0.0)))
    return out


def _perpendicular(n: np.ndarray, d: np.ndarray) -> np.ndarray:
    d = d - n * float(d @ n) / (float(n @ n) or 1.0)
    return d if np.linalg.norm(d) > 1e-9 else np.array([1.0, 0.0, 0.0])


def _border_vertices(faces: list) -> dict[tuple, bool]:
    """Whether each vertex lies on an edge that bounds only one face."""
    count: dict[tuple, int] = {}
    for _n, loops in faces:
        for loop in loops:
            k = len(loop)
            for i in range(k):
                key = tuple(sorted((_key(loop[i]), _key(loop[(i + 1) % k]))))
                count[key] = count.get(key, 0) + 1
    out: dict[tuple, bool] = {}
    for (a, b), c in count.items():
        for v in (a, b):
            out[v] = out.get(v, False) or c == 1
    return out


def _dispatch(parts: list[tuple[set[str], Shape]], block: Any) -> list:
    total = len(parts)
    out = []
    for idx, (names, c) in enumerate(parts):
        for slot in block:
            k = slot.sel
            if (k % total == idx) if type(k) is int else k in names:
                out.append((c, slot, idx, total))
                break
    return out


def op_comp_edges(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    return _dispatch(edge_components(s), block)


def op_comp_face_edges(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    return _dispatch(face_edge_components(s), block)


def op_comp_vertices(ctx: Any, s: Shape, args: Any, block: Any) -> list:
    return _dispatch(vertex_components(s), block)
