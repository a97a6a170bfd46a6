"""Emitted meshes stay watertight and manifold *as files*: readers weld vertices by position
(trimesh, Blender, grammarkit's own load_mesh), so coincident vertices that the in-memory mesh
kept apart (pinched edges, zero-area slivers) turn into non-manifold edges on reading back."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

import grammarkit
from grammarkit.geometry import roofs
from grammarkit.geometry.convert import mesh_report, to_trimesh
from grammarkit.geometry.exporters import export
from grammarkit.geometry.meshio import load_mesh

from conftest import GRAMMARS  # noqa: E402  (tests/qa/conftest.py; see its sys.path note)

RECT = ((0.0, 0.0), (16.0, 0.0), (16.0, 11.0), (0.0, 11.0))
ELL = ((0.0, 0.0), (10.0, 0.0), (10.0, 4.0), (4.0, 4.0), (4.0, 10.0), (0.0, 10.0))


def _coincident(vertices) -> int:
    return len(cKDTree(np.asarray(vertices)).query_pairs(1e-7))


@pytest.mark.parametrize("poly", [RECT, ELL], ids=["rect", "ell"])
@pytest.mark.parametrize("make", [
    lambda p: roofs.hip(p, 30, overhang=0.4),
    lambda p: roofs.gable(p, 30, overhang=0.4),
    lambda p: roofs.shed(p, 30, overhang=0.4),
    lambda p: roofs.pyramid(p, 30, overhang=0.4),
    lambda p: roofs.mansard(p, 70, 3, 18, overhang=0.15),
], ids=["hip", "gable", "shed", "pyramid", "mansard"])
def test_roof_solids_have_no_pinched_vertices(make, poly):
    solid = make(poly)
    mesh = to_trimesh(solid)
    assert _coincident(mesh.vertices) == 0
    welded = mesh.copy()
    welded.merge_vertices()
    assert welded.is_watertight and welded.is_winding_consistent


def test_neighbouring_recesses_leave_no_sliver_walls():
    text = ("Lot --> footprint(rect(12, 8)) extrude(6) comp(f) { side: F | top: T. | bottom: NIL | volume: M. }\n"
            "F --> split(y) { 1: W. | ~1: split(x) { { ~1.5: recess(0.3) G. }* } | 1: W. }\n")
    m = grammarkit.derive(text)
    assert _coincident(m.mesh.vertices) == 0
    assert len(m.manifold.decompose()) == 1


@pytest.mark.parametrize("name", ["paris", "lshape"])
@pytest.mark.parametrize("fmt", ["glb", "gltf", "obj", "stl", "ply"])
def test_example_files_read_back_watertight(tmp_path, name, fmt):
    m = grammarkit.derive(GRAMMARS / f"{name}.grammar", seed=0)
    path = m.save(tmp_path / f"{name}.{fmt}")
    rep = mesh_report(load_mesh(path))
    assert rep.ok, f"{name}.{fmt}: {rep}"
    assert math.isclose(rep.volume, m.manifold.volume(), rel_tol=1e-4)


@pytest.mark.parametrize("name", ["paris", "lshape"])
def test_variations_have_no_pinched_vertices(name):
    from grammarkit.split import variations

    for var, m in variations(GRAMMARS / f"{name}.grammar", 3, seed=9):
        assert _coincident(m.mesh.vertices) == 0, f"{name} variation {var.index}: {var.attrs} {var.bindings}"
        assert len(m.manifold.decompose()) == 1


def test_hip_roof_on_a_wall_top_and_ledge_under_an_overhang():
    # the wall's corner edges run into the hip lines, and the ledge is exactly as deep as the
    # overhang: both used to leave pinched vertices in the union
    text = ("Lot --> footprint(rect(8, 6)) extrude(9) comp(f) { top: T | side: F | bottom: NIL }\n"
            "T --> roofHip(30) R.\n"
            "F --> split(y) { ~1: W. | 0.5: extrude(0.4) L. }\n")
    for t in (text, text.replace("roofHip(30)", "roofHip(30, overhang=0.4)")):
        m = grammarkit.derive(t)
        assert _coincident(m.mesh.vertices) == 0
        assert mesh_report(m.mesh).ok and len(m.manifold.decompose()) == 1


# -- issue 32 item 2: the GLB as most people load it ---------------------------------------
# every shipped split grammar (library.grammar only holds snippets for the others to use)
SHIPPED_SPLIT = sorted([p for p in GRAMMARS.glob("*.grammar") if grammarkit.parse(p).rules]
                       + [GRAMMARS / "lots" / "block.grammar"])


@pytest.mark.parametrize("seed", [0, 3])
@pytest.mark.parametrize("path", SHIPPED_SPLIT, ids=lambda p: p.stem)
def test_shipped_glb_is_watertight_as_trimesh_loads_it(tmp_path, path, seed):
    """`trimesh.load(p, force="mesh")` with nothing else (no merge, no processing) reads the
    closed solid: one primitive per solid over one vertex set, per-terminal data in extras."""
    import trimesh

    from grammarkit.geometry.meshio import face_labels

    m = grammarkit.derive(path, seed=seed)
    glb = m.save(tmp_path / f"{path.stem}.glb")
    mesh = trimesh.load(glb, force="mesh")
    assert mesh.is_watertight and mesh.is_winding_consistent, path.stem
    assert mesh.body_count == len(m.manifold.decompose()), path.stem  # one body per mass
    assert len(mesh.faces) == len(m.faces)
    assert math.isclose(abs(mesh.volume), m.manifold.volume(), rel_tol=1e-4)
    # the terminals are still selectable: every face keeps its terminal
    assert sorted(face_labels(glb)) == sorted(m.face_labels())
