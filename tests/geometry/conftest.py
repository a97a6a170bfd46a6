"""Fixtures of the geometry tests: small watertight models with face colours."""
from __future__ import annotations

import manifold3d as mf
import numpy as np
import pytest
import trimesh

from grammarkit.geometry.convert import to_trimesh


def make_building(nx: int = 4, ny: int = 3, floors: int = 3) -> trimesh.Trimesh:
    """A box with window recesses on all four sides and a hip roof, united by manifold3d;
    faces coloured by origin (wall, window recess, roof) through manifold3d's original ids."""
    sx, sy, fh = 2.0, 2.0, 3.0
    W, D, H = nx * sx, ny * sy, floors * fh
    body = mf.Manifold.cube((W, D, H)).as_original()
    cuts = []
    for f in range(floors):
        z = f * fh + 0.9
        for i in range(nx):
            x = i * sx + 0.5
            cuts.append(mf.Manifold.cube((1.0, 0.6, 1.5)).translate((x, -0.3, z)))
            cuts.append(mf.Manifold.cube((1.0, 0.6, 1.5)).translate((x, D - 0.3, z)))
        for j in range(ny):
            y = j * sy + 0.5
            cuts.append(mf.Manifold.cube((0.6, 1.0, 1.5)).translate((-0.3, y, z)))
            cuts.append(mf.Manifold.cube((0.6, 1.0, 1.5)).translate((W - 0.3, y, z)))
    cutters = mf.Manifold.batch_boolean(cuts, mf.OpType.Add).as_original()
    roof = mf.Manifold.batch_hull([
        mf.Manifold.cube((W + 1, D + 1, 0.01)).translate((-0.5, -0.5, H)),
        mf.Manifold.cube((W * 0.2, 0.01, 0.01)).translate((W * 0.4, D / 2, H + 4))]).as_original()
    solid = (body - cutters) + roof
    mesh = solid.to_mesh()
    out = to_trimesh(solid)
    ids = np.zeros(len(out.faces), dtype=np.int64)
    for k in range(len(mesh.run_original_id)):
        ids[mesh.run_index[k] // 3: mesh.run_index[k + 1] // 3] = mesh.run_original_id[k]
    colors = np.tile(np.array([225, 215, 190, 255], np.uint8), (len(ids), 1))
    colors[ids == cutters.original_id()] = [110, 140, 170, 255]
    colors[ids == roof.original_id()] = [150, 70, 55, 255]
    out.visual.face_colors = colors
    return out


@pytest.fixture(scope="session")
def building() -> trimesh.Trimesh:
    return make_building()


@pytest.fixture
def box() -> trimesh.Trimesh:
    return trimesh.creation.box((1.0, 1.0, 1.0))
