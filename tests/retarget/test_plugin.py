"""The plugin's registration: the command and the fit, a light entry-point module, and
`fit=retarget` as the split engine calls it."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import trimesh

from grammarkit.plugins import get_plugin_manager
from grammarkit_retarget import testmodels


def test_registered_through_the_entry_point():
    pm = get_plugin_manager()
    assert "retarget" in pm.cli_commands()
    fit = pm.registries().fits["retarget"]
    assert fit.plugin == "retarget" and callable(fit.fit)


def test_importing_the_plugin_stays_light():
    code = ("import sys, grammarkit_retarget.plugin, grammarkit_retarget; "
            "print(sorted(m for m in ('trimesh', 'scipy', 'manifold3d', 'numpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def _at_origin(mesh):
    m = mesh.copy()
    m.apply_translation(-m.bounds[0])
    return m


def test_fit_retargets_to_the_scope_exactly(models):
    fit = get_plugin_manager().registries().fits["retarget"].fit
    fence = _at_origin(models["picket_fence"].mesh)
    out = fit(fence, (7.0, 0.2, 1.5))
    assert np.allclose(out.bounds[0], 0, atol=1e-9)
    assert np.allclose(out.extents, (7.0, 0.2, 1.5), rtol=1e-9)
    # more pickets, each only stretched by the remainder (under half a picket spacing)
    m = testmodels.measure(out, testmodels.Probe(0, (0.0, 0.2 * 0.5, 0.55 * 1.25)))
    assert m["count"] == 12 + round((7.0 - 3.2) / 0.25)
    stretch = 7.0 / (3.2 + 15 * 0.25)
    assert np.allclose(m["sizes"], 0.08 * stretch, rtol=1e-3) and abs(stretch - 1) < 0.02
    assert trimesh.Trimesh(out.vertices, out.faces).is_watertight


def test_fit_keeps_the_assets_own_size_on_a_zero_scope_axis_and_scales_plain_assets(models):
    fit = get_plugin_manager().registries().fits["retarget"].fit
    fence = _at_origin(models["picket_fence"].mesh)
    out = fit(fence, (4.7, 0.0, 1.2))
    assert np.allclose(out.extents, (4.7, fence.extents[1], 1.2), rtol=1e-6)
    ball = _at_origin(trimesh.creation.icosphere(subdivisions=2))
    scaled = fit(ball, (4.0, 2.0, 2.0))
    assert np.allclose(scaled.extents, (4.0, 2.0, 2.0))


def test_fit_in_a_split_grammar(tmp_path, models):
    """`i("fence.glb", fit=retarget)` inside a split grammar."""
    from grammarkit.geometry.exporters import exporter_for
    from grammarkit.split import derive

    path = tmp_path / "fence.glb"
    path.write_bytes(exporter_for(path).encode(models["picket_fence"].mesh))
    lot = 'Lot --> footprint(rect(8, 0.2)) extrude(1.2) i("{}"{}) Fence.\n'
    fitted = derive(lot.format(path.as_posix(), ", fit=retarget"))
    scaled = derive(lot.format(path.as_posix(), ""))
    probe = testmodels.Probe(0, (0.0, 0.09, 0.55))
    for model, count, size in ((fitted, 12 + 19, 0.08 * 8 / 7.95), (scaled, 12, 0.08 * 8 / 3.2)):
        mesh = trimesh.Trimesh(model.vertices, model.faces, process=False)
        assert mesh.is_watertight and np.allclose(mesh.extents, (8, 0.2, 1.2), atol=5e-3)
        m = testmodels.measure(mesh, probe)
        assert m["count"] == count and np.allclose(m["sizes"], size, rtol=1e-3), (count, m)
