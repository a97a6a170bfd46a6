"""Retargeting the five structured test models to 0.5x, 1.5x and 3x along each of their
repetition axes: element counts change in proportion, element sizes and spacing stay those of
the input (within 5%), the bounding box is the requested one within one voxel, and the output
is a watertight manifold, in memory and read back from a file. Plain scaling, measured the
same way, distorts the element sizes by the scale factor."""
from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

from grammarkit.errors import ShapeError
from grammarkit.geometry.convert import mesh_report
from grammarkit.geometry.exporters import exporter_for
from grammarkit.geometry.meshio import load_mesh
from grammarkit_retarget import retarget, retarget_report, scale_to, testmodels

FACTORS = (0.5, 1.5, 3.0)
CASES = [(name, axis, f) for name, build in testmodels.MODELS.items()
         for axis in sorted(build().probes) for f in FACTORS]


def _target(model, axis, f):
    size = np.asarray(model.mesh.extents, dtype=np.float64).copy()
    size[axis] *= f
    return size


@pytest.fixture(scope="module")
def results(models, offsets):
    out = {}
    for name, axis, f in CASES:
        model = models[name]
        out[(name, axis, f)] = retarget_report(model.mesh, _target(model, axis, f),
                                               offsets=offsets[name], name=name)
    return out


@pytest.mark.parametrize("name,axis,f", CASES)
def test_elements_are_added_or_removed_not_stretched(models, results, name, axis, f):
    model, report = models[name], results[(name, axis, f)]
    probe = model.probes[axis]
    before = testmodels.measure(model.mesh, probe)
    after = testmodels.measure(report.mesh, probe)
    element = float(np.median(before["sizes"]))
    # element sizes and their spacing stay the input's
    assert after["count"] >= 1
    assert np.allclose(after["sizes"], element, rtol=0.05), (after["sizes"], element)
    if after["count"] > 1:
        assert after["pitch"] == pytest.approx(before["pitch"], rel=0.05)
    # the count changes in proportion to the size: whole elements per generator step
    step = float(np.linalg.norm(model.generators[[i for i, g in enumerate(model.generators)
                                                  if abs(g[axis]) > 0][0]]))
    gained = (report.size[axis] - report.input_size[axis]) / step
    assert gained == pytest.approx(round(gained), abs=1e-5)  # the models are float32
    assert after["count"] == before["count"] + round(gained)
    # ... and that is the size change in elements, rounded: (f - 1) * size / spacing
    wanted = (f - 1) * report.input_size[axis] / before["pitch"]
    assert abs(after["count"] - before["count"] - wanted) <= 0.5 + 1e-9
    # plain scaling, measured the same way, stretches every element by the factor
    scaled = testmodels.measure(scale_to(model.mesh, report.requested), probe)
    assert scaled["count"] == before["count"]
    assert np.allclose(scaled["sizes"], element * f, rtol=0.01)
    assert abs(np.median(scaled["sizes"]) / element - 1) > 0.05


@pytest.mark.parametrize("name,axis,f", CASES)
def test_bounding_box_is_the_requested_one_within_one_voxel(results, name, axis, f):
    report = results[(name, axis, f)]
    voxel = report.voxel_size
    assert report.method == "retarget"
    assert np.all(np.abs(report.size - report.requested) <= voxel / 2 + 1e-9), (report.size, report.requested)
    others = [a for a in range(3) if a != axis]
    assert np.allclose(report.size[others], report.input_size[others], rtol=1e-6)


@pytest.mark.parametrize("name,axis,f", CASES)
def test_output_is_a_watertight_manifold_in_memory_and_read_back(tmp_path, results, name, axis, f):
    mesh = results[(name, axis, f)].mesh
    assert mesh_report(mesh).ok, mesh_report(mesh)
    # read back by trimesh with default arguments (vertices merged by position)
    plain = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    data = exporter_for("x.glb").encode(plain)
    back = trimesh.load(io.BytesIO(data), file_type="glb", force="mesh")
    assert back.is_watertight and back.is_winding_consistent
    # coloured: written with colour seams split, read back by grammarkit's loader
    path = tmp_path / "out.glb"
    path.write_bytes(exporter_for(path).encode(mesh))
    assert mesh_report(load_mesh(path, single=True)).ok


def test_colours_survive(results, models):
    report = results[("facade_panel", 0, 1.5)]
    before = {tuple(c) for c in np.asarray(models["facade_panel"].mesh.visual.face_colors)}
    after = {tuple(c) for c in np.asarray(report.mesh.visual.face_colors)}
    assert after == before


def test_graph_size_and_labels_follow_the_offset_space(results):
    report = results[("picket_fence", 0, 3.0)]
    k = int(report.steps[0])
    assert report.stats["labels"] == abs(k) + 1
    assert report.stats["nodes"] == int(np.prod(report.labelling.dims))
    assert report.solution.energy <= report.solution.initial_energy


def test_same_seed_same_output_and_another_seed_still_correct(models):
    model = models["picket_fence"]
    size = _target(model, 0, 1.5)
    a = retarget(model.mesh, size, seed=3)
    b = retarget(model.mesh, size, seed=3)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    c = retarget(model.mesh, size, seed=4)
    assert testmodels.measure(c, model.probes[0])["count"] == testmodels.measure(a, model.probes[0])["count"]


def test_exact_scales_the_remainder(models, offsets):
    model = models["bookshelf"]
    size = _target(model, 0, 1.7)
    report = retarget_report(model.mesh, size, offsets=offsets["bookshelf"], exact=True)
    assert np.allclose(report.size, size, rtol=1e-9)
    assert abs(report.scale[0] - 1) < 0.5 * 0.42 / size[0] + 1e-9  # under half a step


def test_an_axis_without_principal_offset_is_refused_or_scaled(models, offsets):
    model = models["picket_fence"]  # pickets along x; nothing repeats in height
    size = _target(model, 2, 1.5)
    with pytest.raises(ShapeError, match=r"picket_fence: no principal offset runs along z.*--allow-scale"):
        retarget_report(model.mesh, size, offsets=offsets["picket_fence"], name="picket_fence")
    report = retarget_report(model.mesh, size, offsets=offsets["picket_fence"], allow_scale=True)
    assert report.method == "unchanged" and report.scale[2] == pytest.approx(1.5)
    assert np.allclose(report.size, size)
    # both: more pickets along x, scaled in height
    size2 = _target(model, 0, 2.0)
    size2[2] *= 1.5
    both = retarget_report(model.mesh, size2, offsets=offsets["picket_fence"], allow_scale=True)
    assert both.method == "retarget" and both.scale[2] == pytest.approx(1.5)
    picket = testmodels.measure(both.mesh, testmodels.Probe(0, (0.0, 0.05, 0.55 * 1.5)))
    assert np.allclose(picket["sizes"], 0.08, rtol=0.05) and picket["count"] > 12


def test_shrinking_below_the_smallest_arrangement_is_a_clear_error(models, offsets):
    model = models["picket_fence"]
    with pytest.raises(ShapeError, match="picket_fence: cannot retarget to"):
        retarget_report(model.mesh, _target(model, 0, 0.02), offsets=offsets["picket_fence"],
                        name="picket_fence")


def test_the_papers_seam_cost_is_available(models, offsets):
    model = models["tiled_floor"]
    report = retarget_report(model.mesh, _target(model, 0, 1.5), offsets=offsets["tiled_floor"],
                             seam="descriptor")
    m = testmodels.measure(report.mesh, model.probes[0])
    assert m["count"] == 15 and mesh_report(report.mesh).ok
