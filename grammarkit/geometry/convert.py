"""Conversions between trimesh (I/O, export) and manifold3d (booleans), and mesh health checks.

Why a module for four small functions: manifold3d wants float32 vertices and uint32 indices
(float64 raises), a triangle soup must be merged first or the Manifold comes out silently
empty, and trimesh's own vertex processing can break manifold3d's output. Getting these right
once keeps every engine's output watertight.
"""
from __future__ import annotations

from dataclasses import dataclass

import manifold3d
import numpy as np
import trimesh

from ..errors import ShapeError

__all__ = ["MeshReport", "assert_manifold", "mesh_report", "to_manifold", "to_trimesh"]


def _label(what: str) -> str:
    return f"{what}: " if what else ""


def _build(mesh: trimesh.Trimesh, what: str) -> manifold3d.Manifold:
    """The Manifold of `mesh` (status unchecked); ShapeError for non-meshes and bad numbers."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise ShapeError(f"{_label(what)}expected a triangle mesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0:
        raise ShapeError(f"{_label(what)}the mesh is empty (no triangles)")
    verts = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    if not np.isfinite(verts).all():
        raise ShapeError(f"{_label(what)}the mesh has NaN or infinite vertex coordinates")
    tris = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    m = manifold3d.Mesh(vert_properties=verts, tri_verts=tris)
    m.merge()  # weld coincident vertices of a triangle soup (STL/OBJ) into a shared topology
    return manifold3d.Manifold(m)


def to_manifold(mesh: trimesh.Trimesh, what: str = "") -> manifold3d.Manifold:
    """A manifold3d solid from a closed trimesh; `ShapeError` (naming `what`) if it is not one.

    Triangle soups are welded first, so an STL-style mesh with duplicated vertices works."""
    solid = _build(mesh, what)
    status = solid.status()
    if status != manifold3d.Error.NoError:
        raise ShapeError(
            f"{_label(what)}the mesh is not a closed manifold solid (manifold3d: {status.name}); "
            f"{len(mesh.faces)} triangles, watertight={mesh.is_watertight}",
            hint="every edge must be shared by exactly two consistently oriented triangles")
    return solid


def to_trimesh(m: manifold3d.Manifold, **kw) -> trimesh.Trimesh:
    """A trimesh of a Manifold's surface, without trimesh's vertex processing (which can
    merge vertices manifold3d keeps apart and so break manifoldness). Extra keyword
    arguments go to `trimesh.Trimesh` (e.g. `face_colors=`, `metadata=`)."""
    mesh = m.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64).reshape(-1, 3)
    kw.setdefault("process", False)
    return trimesh.Trimesh(vertices=verts, faces=faces, **kw)


@dataclass(frozen=True)
class MeshReport:
    """Health of a mesh as the tests and the CLI check it."""

    watertight: bool  # trimesh: every edge shared by exactly two faces, by vertex index (so an
    #                   unwelded triangle soup is not watertight even if manifold3d can weld it)
    manifold: bool  # manifold3d accepts it as a solid (status NoError)
    status: str  # manifold3d status name, or why it could not be built
    volume: float  # signed volume per trimesh (positive for outward-facing closed meshes)
    triangles: int
    euler_number: int  # V - E + F; 2 per closed genus-0 component

    @property
    def ok(self) -> bool:
        return self.watertight and self.manifold and self.triangles > 0

    def __str__(self) -> str:
        return (f"{'ok' if self.ok else 'NOT OK'}: watertight={self.watertight} "
                f"manifold={self.manifold} ({self.status}) volume={self.volume:.6g} "
                f"triangles={self.triangles} euler={self.euler_number}")


def mesh_report(mesh: trimesh.Trimesh | trimesh.Scene) -> MeshReport:
    """Watertightness, manifold3d status, volume, triangle count and Euler number.

    A Scene is reported as the concatenation of its geometry in world coordinates."""
    if isinstance(mesh, trimesh.Scene):
        mesh = mesh.to_mesh() if mesh.geometry else trimesh.Trimesh()
    n = int(len(mesh.faces))
    if n == 0:
        return MeshReport(False, False, "Empty", 0.0, 0, 0)
    try:
        status = _build(mesh, "").status().name
    except ShapeError as exc:  # NaN vertices and the like
        status = str(exc)
    manifold = status == "NoError"
    # Counted directly rather than via trimesh's cached `euler_number`, which merges vertices first.
    edges = np.sort(mesh.edges, axis=1)
    n_edges = len(np.unique(edges, axis=0))
    n_verts = len(np.unique(mesh.faces))
    return MeshReport(
        watertight=bool(mesh.is_watertight),
        manifold=manifold,
        status=status,
        volume=float(mesh.volume),
        triangles=n,
        euler_number=int(n_verts - n_edges + n),
    )


def assert_manifold(mesh: trimesh.Trimesh | trimesh.Scene, what: str = "") -> MeshReport:
    """Raise `ShapeError` naming `what` unless `mesh` is a watertight manifold solid."""
    report = mesh_report(mesh)
    if not report.ok:
        raise ShapeError(f"{_label(what)}mesh is not a watertight manifold: {report}")
    return report
