"""Shared builders for the tiling tests (imported by path: pytest runs with --import-mode=importlib)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from grammarkit.tiling import Assembly, Part

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "grammars" / "tiling"


def box_part(pid: str, ptype: str, center, extents=(1, 1, 1), rot_z: float = 0.0) -> Part:  # noqa: ANN001
    mesh = trimesh.creation.box(extents=extents)
    T = trimesh.transformations.rotation_matrix(np.radians(rot_z), (0, 0, 1))
    T[:3, 3] = center
    mesh.apply_transform(T)
    return Part(pid, ptype, mesh, T)


def lattice(nx: int, ny: int, nz: int, spacing: float = 2.0) -> Assembly:
    """Cubes ("Node") at grid points joined by thin boxes ("Beam") touching face to face."""
    parts = []
    cube = trimesh.creation.box(extents=(1, 1, 1))
    L = spacing - 1.0
    beams = [trimesh.creation.box(extents=e) for e in ((L, .4, .4), (.4, L, .4), (.4, .4, L))]
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                c = np.array([i, j, k], float) * spacing
                T = np.eye(4)
                T[:3, 3] = c
                # built directly (not copy + apply_transform): 10,000 parts in a fraction of a second
                m = trimesh.Trimesh(cube.vertices + c, cube.faces, process=False)
                parts.append(Part(f"Node.{len(parts)}", "Node", m, T))
                for ax, lim in enumerate((nx, ny, nz)):
                    if (i, j, k)[ax] < lim - 1:
                        T = np.eye(4)
                        T[:3, 3] = c + np.eye(3)[ax] * spacing / 2
                        m = trimesh.Trimesh(beams[ax].vertices + T[:3, 3], beams[ax].faces, process=False)
                        parts.append(Part(f"Beam.{len(parts)}", "Beam", m, T))
    return Assembly(parts, name=f"lattice{nx}x{ny}x{nz}")


def load_make_examples():
    """The example generator script as a module (its builders make fresh assemblies)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("grammarkit_tiling_make_examples", EXAMPLES / "make_examples.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
