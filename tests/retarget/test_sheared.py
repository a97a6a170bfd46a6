"""Non-orthogonal generators (Wu et al., section V, Fig. 7): a sheared window grid is mapped to
the canonical space of its generators, retargeted there and mapped back."""
from __future__ import annotations

import numpy as np
import pytest

from grammarkit.geometry.convert import mesh_report
from grammarkit_retarget import principal_offsets, retarget_report, testmodels

SHEAR = 0.4  # x += 0.4 z


def _shear(mesh, s):
    out = mesh.copy()
    v = np.asarray(out.vertices).copy()
    v[:, 0] += s * v[:, 2]
    out.vertices = v
    return out


@pytest.fixture(scope="module")
def sheared():
    model = testmodels.build("facade_panel")
    return model, _shear(model.mesh, SHEAR)


def test_sheared_generators_are_found(sheared):
    _, mesh = sheared
    found = principal_offsets(mesh)
    want = [np.array([1.2, 0, 0]), np.array([1.5 * SHEAR, 0, 1.5])]
    assert len(found) == 2
    for g in want:
        assert min(min(np.linalg.norm(p - g), np.linalg.norm(p + g)) for p in found.principal) < 1e-5
    u, v = (g / np.linalg.norm(g) for g in found.principal)
    assert 0.1 < abs(u @ v) <= 0.5  # not orthogonal, but at least 60 degrees apart


@pytest.mark.parametrize("f", [0.5, 2.0])
def test_retargeting_along_the_sheared_generator(sheared, f):
    model, mesh = sheared
    found = principal_offsets(mesh)
    # growing along (0.6, 0, 1.5) by k steps grows the box by k * 0.6 in x and k * 1.5 in z
    k = round((f - 1) * 5.0 / 1.5)
    size = np.asarray(mesh.extents, dtype=np.float64) + np.array([abs(k) * 0.6 * np.sign(k), 0, k * 1.5])
    report = retarget_report(mesh, size, offsets=found)
    assert report.method == "retarget" and mesh_report(report.mesh).ok
    assert np.allclose(report.size, size, atol=1e-5)
    # unshear and measure like the upright facade: whole storeys added or removed
    upright = _shear(report.mesh, -SHEAR)
    storeys = testmodels.measure(upright, model.probes[2])
    bays = testmodels.measure(upright, model.probes[0])
    assert storeys["count"] == 3 + k
    assert np.allclose(storeys["sizes"], 0.9, rtol=0.01) and np.allclose(bays["sizes"], 0.7, rtol=0.01)
    assert bays["count"] == 5
