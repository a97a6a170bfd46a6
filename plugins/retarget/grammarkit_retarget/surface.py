"""Distances from points to a mesh surface (`SurfaceDistance`): the seam cost's measure of
whether two translated copies agree, and the offset check's measure of whether a translation
maps the model onto itself."""
from __future__ import annotations

import numpy as np
import trimesh

from .features import FeatureCloud

__all__ = ["SurfaceDistance"]


def _vertex_faces(faces: np.ndarray, n_vertices: int, cap: int = 16) -> np.ndarray:
    """(V, cap) faces around each vertex, -1 padded; a vertex with more faces (the hub of a
    fan) keeps `cap` of them. (trimesh's `vertex_faces` pads to the largest degree, which on a
    finely tessellated model with fan hubs is thousands of columns.)"""
    flat = faces.ravel()
    order = np.argsort(flat, kind="stable")
    vert = flat[order]
    face = order // 3
    starts = np.searchsorted(vert, np.arange(n_vertices))
    rank = np.arange(len(vert)) - starts[vert]
    keep = rank < cap
    out = np.full((n_vertices, cap), -1, dtype=np.int64)
    out[vert[keep], rank[keep]] = face[keep]
    return out


class SurfaceDistance:
    """Distance from points to a mesh surface, exact where it matters and cheap where it can be.

    Cheap test first: a point lies on the surface when a nearby dense sample on a face with an
    agreeing normal has the point in its plane (within 1e-6), or when it sits on a mesh vertex.
    The remaining points within `cap` of the surface get the exact distance to the nearest of
    a few candidate triangles: the faces of the nearest dense samples and of the nearest
    vertices (a k-d tree of points cannot see a small face without samples; its vertices can).
    Points farther than `cap` from every sample and vertex get `cap`.

    oriented=True measures the distance to the faces whose normal agrees with the point's
    (n . n_face > 0.5) only, the vertex shortcut included: a translation that puts a face
    onto a face turned the other way (the left jamb of a window onto its right jamb, when
    the window is half a bay wide) does not map the model onto itself. The offset checks use
    it; the seam cost compares copies of the same geometry and keeps the plain distance."""

    def __init__(self, cloud: FeatureCloud, mesh_n: trimesh.Trimesh, cap: float,
                 k_samples: int = 6, k_vertices: int = 3, oriented: bool = False):
        from scipy.spatial import cKDTree

        self.cloud, self.cap = cloud, cap
        self.k_samples, self.k_vertices = k_samples, k_vertices
        self.samples = cKDTree(cloud.dense)
        self.vertices = np.asarray(mesh_n.vertices, dtype=np.float64)
        self.vertex_tree = cKDTree(self.vertices)
        self.triangles = np.asarray(mesh_n.triangles, dtype=np.float64)
        self.vertex_faces = _vertex_faces(np.asarray(mesh_n.faces), len(self.vertices))
        self.face_normals = np.asarray(mesh_n.face_normals, dtype=np.float64) if oriented else None

    def __call__(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        cloud, cap = self.cloud, self.cap
        dist, j = self.samples.query(points, k=self.k_samples, distance_upper_bound=cap)
        found = np.isfinite(dist)
        jj = np.where(found, j, 0)
        off = points[:, None, :] - cloud.dense[jj]
        n = cloud.dense_normals[jj]
        along = np.abs(np.einsum("ikj,ikj->ik", off, n))
        tangential = np.sqrt(np.maximum(np.where(found, dist, 0.0) ** 2 - along ** 2, 0.0))
        agree = np.einsum("ij,ikj->ik", normals, n) > 0.5
        on_plane = found & agree & (tangential <= 1.5 * cloud.params.dense) & (along <= 1e-6)
        value = np.where(on_plane.any(axis=1), 0.0, cap)
        vd, vj = self.vertex_tree.query(points, k=self.k_vertices, distance_upper_bound=cap)
        if self.face_normals is None:
            value[vd[:, 0] <= 1e-6] = 0.0
        near = (value > 0) & (found.any(axis=1) | np.isfinite(vd[:, 0]))
        if near.any():
            idx = np.flatnonzero(near)
            cand = [np.where(found[idx], cloud.dense_faces[jj[idx]], -1)]
            vfin = np.isfinite(vd[idx])
            vf = self.vertex_faces[np.where(vfin, vj[idx], 0)]  # (n, k, deg)
            vf = np.where(vfin[:, :, None], vf, -1)
            cand.append(vf.reshape(len(idx), -1))
            cand = np.concatenate(cand, axis=1)
            rows = np.repeat(np.arange(len(idx)), cand.shape[1])
            faces = cand.ravel()
            ok = faces >= 0
            if self.face_normals is not None:
                ok &= np.einsum("ij,ij->i", self.face_normals[np.maximum(faces, 0)],
                                normals[idx][rows]) > 0.5
            rows, faces = rows[ok], faces[ok]
            closest = trimesh.triangles.closest_point(self.triangles[faces], points[idx][rows])
            d = np.linalg.norm(closest - points[idx][rows], axis=1)
            best = np.full(len(idx), cap)
            np.minimum.at(best, rows, d)
            value[idx] = np.minimum(best, cap)
        return value
