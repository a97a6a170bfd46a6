"""Stitching the labelled copies into one mesh (Wu et al., section III-B, last step).

Closed input: each used label's copy of the input solid (translated by l in lattice units)
is clipped to that label's region (its voxels, merged into few boxes) and the pieces are
united with manifold3d, whose booleans always return a closed manifold. All of it happens in
the lattice's canonical space in double precision, with vertex coordinates snapped so that
repeated vertices are whole lattice units apart (`snap_periodic`): pieces of identical
geometry then meet on exactly coincident faces and unite without slivers.

Open input (`stitch_surface`): the same clipping on the triangles alone (a surface has no
inside for booleans): each copy's triangles are cut by the planes of its boxes and kept
inside; the pieces are concatenated and welded. The output is open wherever the input was.

Face colours survive: the input's triangles carry a manifold3d face id per (plane, colour),
which the output triangles keep.
"""
from __future__ import annotations

from dataclasses import dataclass

import manifold3d as m3
import numpy as np
import trimesh

from .labelling import Lattice

__all__ = ["StitchResult", "merge_boxes", "part_face_sets", "snap_periodic", "stitch_solid", "stitch_surface"]


def merge_boxes(mask: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Cover the True voxels of a 3D mask by disjoint boxes [lo, hi) (greedy: grow along the
    last axis, then the middle one, then the first, while every voxel is still uncovered)."""
    mask = np.asarray(mask, dtype=bool).copy()
    boxes = []
    dims = mask.shape
    for idx in zip(*np.nonzero(mask)):
        if not mask[idx]:
            continue
        i, j, k = idx
        k1 = k
        while k1 + 1 < dims[2] and mask[i, j, k1 + 1]:
            k1 += 1
        j1 = j
        while j1 + 1 < dims[1] and mask[i, j1 + 1, k:k1 + 1].all():
            j1 += 1
        i1 = i
        while i1 + 1 < dims[0] and mask[i1 + 1, j:j1 + 1, k:k1 + 1].all():
            i1 += 1
        mask[i:i1 + 1, j:j1 + 1, k:k1 + 1] = False
        boxes.append((np.array([i, j, k]), np.array([i1 + 1, j1 + 1, k1 + 1])))
    return boxes


def snap_periodic(c: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Lattice coordinates with the fractional parts of each axis snapped to clusters (values
    within `tol` of each other become one), so that vertices that repeat along a generator are
    exactly a whole number of lattice units apart. Input coordinates carry rounding noise
    (float32 files, the generator found to ~1e-9); without this, two copies meeting at a seam
    differ by ~1e-7 and the union leaves zero-area slivers there."""
    c = np.asarray(c, dtype=np.float64).copy()
    for axis in range(3):
        frac = np.mod(c[:, axis], 1.0)
        order = np.argsort(frac, kind="stable")
        f = frac[order]
        new_group = np.concatenate([[True], np.diff(f) > tol])
        group = np.cumsum(new_group) - 1
        first = f[new_group]
        rep = first[group]
        # a cluster straddling 0 / 1 joins the first one
        if len(first) > 1 and (f[-1] - 1.0 >= first[0] - tol) and group[-1] != 0:
            rep = np.where(group == group[-1], first[0] + 1.0, rep)
        snapped = np.empty_like(frac)
        snapped[order] = rep
        c[:, axis] = np.round(c[:, axis] - snapped) + snapped
    return c


def part_face_sets(faces: np.ndarray, n_vertices: int) -> list[np.ndarray]:
    """The faces of each part: the connected components of the faces by shared vertex index
    (not position), in order of their first face."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return []
    rows = np.repeat(faces[:, 0], 2)
    cols = faces[:, 1:].ravel()
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
    _, label = connected_components(graph, directed=False)
    face_label = label[faces[:, 0]]
    _, first, inverse = np.unique(face_label, return_index=True, return_inverse=True)
    order = np.argsort(first)
    return [np.flatnonzero(inverse == k) for k in order]


def _box(lo: np.ndarray, hi: np.ndarray) -> m3.Manifold:
    return m3.Manifold.cube(tuple(float(x) for x in hi - lo)).translate(tuple(float(x) for x in lo))


@dataclass
class StitchResult:
    mesh: trimesh.Trimesh  # normalised units
    pieces: int
    boxes: int


def stitch_solid(mesh_n: trimesh.Trimesh, lattice: Lattice, label_grid: np.ndarray,
                 label_vectors: np.ndarray, colors: np.ndarray | None) -> StitchResult:
    """Clip and unite, in the lattice's canonical space (generators = unit vectors) in double
    precision, where every copy is the input moved by a whole lattice vector (exact) and every
    region a union of unit boxes with integer corners (exact): pieces of identical geometry
    then meet on exactly coincident faces, which manifold3d's union removes cleanly.
    `label_grid` (output dims) holds label indices into `label_vectors`."""
    c = snap_periodic(lattice.to_lattice(mesh_n.vertices))
    start = np.round(lattice.start * 2 ** 20) / 2 ** 20  # a dyadic corner: exact in float64
    tris = np.ascontiguousarray(mesh_n.faces, dtype=np.uint64)
    face_groups = _face_groups(mesh_n, colors)
    # one solid per part (connected by vertex index, as the file gave them): welding by
    # position across parts would join parts that share an edge into a non-manifold mesh
    parts = []
    for part_faces in part_face_sets(mesh_n.faces, len(c)):
        used, local = np.unique(tris[part_faces], return_inverse=True)
        src = m3.Mesh64(vert_properties=np.ascontiguousarray(c[used.astype(np.int64)]),
                        tri_verts=np.ascontiguousarray(local.reshape(-1, 3), dtype=np.uint64),
                        face_id=face_groups[part_faces].astype(np.uint64))
        src.merge()  # welds a part's own triangle soup (STL-style duplicated vertices)
        part = m3.Manifold(src)  # not as_original(): that would renumber the face ids
        if part.status() != m3.Error.NoError:
            raise ValueError(f"the mesh is not a closed manifold solid ({part.status().name})")
        parts.extend(part.decompose())
    # touching or overlapping parts would make the copies self-intersect: unite them first
    solid = parts[0]
    if len(parts) > 1:
        solid = m3.Manifold.batch_boolean(parts, m3.OpType.Add)
    source_ids = set(int(i) for i in np.asarray(solid.to_mesh64().run_original_id))
    pieces, n_boxes = [], 0
    for label in np.unique(label_grid):
        boxes = merge_boxes(label_grid == label)
        n_boxes += len(boxes)
        copy = solid.translate(tuple(float(x) for x in label_vectors[label]))
        regions = [_box(start + lo, start + hi) for lo, hi in boxes]
        region = regions[0] if len(regions) == 1 else m3.Manifold.batch_boolean(regions, m3.OpType.Add)
        piece = copy ^ region
        if not piece.is_empty():
            pieces.append(piece)
    if not pieces:
        raise ValueError("stitching produced an empty mesh")
    union = pieces[0] if len(pieces) == 1 else m3.Manifold.batch_boolean(pieces, m3.OpType.Add)
    out = union.to_mesh64()
    v = lattice.to_normalised(np.asarray(out.vert_properties, dtype=np.float64)[:, :3])
    f = np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3)
    result = trimesh.Trimesh(v, f, process=False)
    if colors is not None and len(f):
        group_color = np.zeros((int(face_groups.max()) + 1, colors.shape[1]), dtype=np.uint8)
        group_color[face_groups] = colors
        face_src = np.full(len(f), -1, dtype=np.int64)
        run_index = np.asarray(out.run_index, dtype=np.int64)
        face_id = np.asarray(out.face_id, dtype=np.int64)
        for r, oid in enumerate(np.asarray(out.run_original_id)):
            if int(oid) in source_ids:
                sl = slice(run_index[r] // 3, run_index[r + 1] // 3)
                face_src[sl] = face_id[sl]
        fallback = _most_common(colors)
        fc = np.where((face_src >= 0)[:, None], group_color[np.clip(face_src, 0, None)], fallback)
        result.visual.face_colors = fc.astype(np.uint8)
    return StitchResult(result, len(pieces), n_boxes)


def _face_groups(mesh_n: trimesh.Trimesh, colors: np.ndarray | None) -> np.ndarray:
    """One id per (plane, colour) of the input's triangles: manifold3d keeps the output faces
    of different ids apart (so colours survive), and one id per *triangle* instead would keep
    every input triangle's edges, leaving zero-area slivers where copies meet at a seam."""
    n = np.asarray(mesh_n.face_normals, dtype=np.float64)
    d = np.einsum("ij,ij->i", n, np.asarray(mesh_n.triangles)[:, 0])
    key = [np.round(n * 1e6).astype(np.int64), np.round(d * 1e6).astype(np.int64)[:, None]]
    if colors is not None:
        _, color_id = np.unique(colors, axis=0, return_inverse=True)
        key.append(color_id.reshape(-1, 1))
    _, group = np.unique(np.concatenate(key, axis=1), axis=0, return_inverse=True)
    return group.reshape(-1)


def _most_common(colors: np.ndarray) -> np.ndarray:
    uniq, counts = np.unique(colors, axis=0, return_counts=True)
    return uniq[int(np.argmax(counts))]


def _clip_to_box(vertices: np.ndarray, faces: np.ndarray, lattice: Lattice, lo, hi):
    """The triangles (normalised units) inside the lattice box [lo, hi), cut at its planes
    (numpy only: `trimesh.intersections.slice_faces_plane`)."""
    inv = lattice.inverse
    for axis in range(3):
        n = inv[axis]  # the plane c_axis = value has this normal in normalised space
        for value, sign in ((lattice.start[axis] + lo[axis], 1.0),
                            (lattice.start[axis] + hi[axis], -1.0)):
            if len(faces) == 0:
                return vertices, faces
            origin = lattice.to_normalised(np.eye(3)[axis] * value)
            vertices, faces, *_ = trimesh.intersections.slice_faces_plane(
                vertices, faces, sign * n, origin)
    return vertices, faces


def stitch_surface(mesh_n: trimesh.Trimesh, lattice: Lattice, label_grid: np.ndarray,
                   label_vectors: np.ndarray, colors: np.ndarray | None) -> StitchResult:
    """An open mesh: each copy's triangles clipped to its label's boxes, concatenated and
    welded (by position); one pass per face colour so that colours survive the clipping."""
    from grammarkit.geometry.meshio import weld

    verts = np.asarray(mesh_n.vertices, dtype=np.float64)
    faces = np.asarray(mesh_n.faces, dtype=np.int64)
    if colors is None:
        groups = [(None, faces)]
    else:
        uniq, inv = np.unique(colors, axis=0, return_inverse=True)
        groups = [(uniq[i], faces[inv.reshape(-1) == i]) for i in range(len(uniq))]
    parts_v, parts_f, parts_c = [], [], []
    n_boxes, offset = 0, 0
    for label in np.unique(label_grid):
        shift = lattice.to_normalised(label_vectors[label].astype(np.float64))
        for lo, hi in merge_boxes(label_grid == label):
            n_boxes += 1
            for color, gf in groups:
                v, f = _clip_to_box(verts + shift, gf, lattice, lo, hi)
                if len(f) == 0:
                    continue
                parts_v.append(v)
                parts_f.append(f + offset)
                offset += len(v)
                if color is not None:
                    parts_c.append(np.tile(color, (len(f), 1)))
    if not parts_f:
        raise ValueError("stitching produced an empty mesh")
    merged = trimesh.Trimesh(np.concatenate(parts_v), np.concatenate(parts_f), process=False)
    if parts_c:
        merged.visual.face_colors = np.concatenate(parts_c).astype(np.uint8)
    merged = weld(merged)
    keep = merged.nondegenerate_faces()
    merged.update_faces(keep)
    merged.remove_unreferenced_vertices()
    return StitchResult(merged, len(parts_f), n_boxes)
