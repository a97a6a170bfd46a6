"""Real CGA buildings as one watertight solid (issue 27): every corpus rule package
(grammars/cga/packages/*.rpk), imported as it comes and derived on the 20 x 12 lot and the L
lot, is by default one closed, consistently wound manifold per connected mass, with no open
surface triangles, by `Model.mesh` and by its GLB read back with `trimesh.load(p,
force="mesh")`; `surfaces="cga"` keeps CityEngine's open faces. Also the pieces: faces of a
consumed volume are views of it, dropped faces close it (tagged "closing"), faces moved off
their volume and open inserted meshes become closed parts of a documented thickness."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import grammarkit
from grammarkit.functions import lshape
from grammarkit.geometry.closing import THICKNESS, close_mesh, fill_holes
from grammarkit.split import derive

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted((ROOT / "grammars" / "cga" / "packages").glob("*.rpk"))
LOTS = {"rect": [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)],
        "lshape": [tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]}


@pytest.fixture
def imported(cga_packages):
    return cga_packages


def _closed(mesh, bodies: bool = True) -> None:
    assert len(mesh.faces) > 0
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    if bodies:  # (not on a textured mesh read back: trimesh copies the texture per body)
        for body in mesh.split(only_watertight=False):
            assert body.is_watertight  # every mass closed (a pocket inside one is a shell of its own)


@pytest.mark.parametrize("lot", sorted(LOTS))
@pytest.mark.parametrize("package", [p.stem for p in PACKAGES])
def test_corpus_building_is_one_watertight_solid_per_mass(imported, package, lot, tmp_path):
    model = derive(imported[package], lot=LOTS[lot])
    assert model.surface_triangle_count == 0  # no open surface triangles in the default mode
    _closed(model.mesh)
    assert model.triangle_count == len(model.mesh.faces)
    path = model.save(tmp_path / f"{package}.glb")
    back = trimesh.load(path, force="mesh")
    # textured or not, the GLB's solid is one seamless primitive, watertight as it is read
    _closed(back)
    assert back.body_count == model.mesh.body_count


def test_cga_mode_keeps_cityengines_open_faces(imported):
    open_faces = derive(imported["candler"], lot=LOTS["rect"], surfaces="cga")
    solid = derive(imported["candler"], lot=LOTS["rect"])
    assert open_faces.surface_triangle_count > 1000 and solid.surface_triangle_count == 0
    # the same building: bounding boxes agree to the closing thickness
    both = np.vstack([open_faces.mesh.vertices, open_faces.surface_vertices])
    assert np.allclose(solid.mesh.bounds, [both.min(0), both.max(0)], atol=0.05)


def test_comp_faces_are_views_and_dropped_faces_close_the_solid():
    g = grammarkit.parse("Lot --> extrude(4) comp(f) { side: Wall. | top: NIL }\n")
    m = derive(g)
    _closed(m.mesh)
    assert m.mesh.volume == pytest.approx(400, rel=0.01)
    labels = m.face_labels()
    by_tag = {t.name: t.role for t in m.tags}
    assert set(labels) == {"Wall", "Lot"} and by_tag["Lot"] == "closing"  # top and bottom: hidden
    top = [i for i, n in enumerate(m.mesh.face_normals[:, 2]) if n > 0.99]
    assert {labels[i] for i in top} == {"Lot"}
    cga = derive(g, surfaces="cga")
    assert len(cga.mesh.faces) == 0 and cga.surface_triangle_count == 8  # the four open walls


def test_a_face_moved_off_its_volume_is_a_closed_part_of_its_own():
    g = grammarkit.parse("Lot --> extrude(4) comp(f) { front: t(0, 0, 2) Sign. | side: Wall. }\n")
    m = derive(g)
    _closed(m.mesh)
    assert m.mesh.body_count == 2  # the building and the sign in front of it, apart
    sign = [b for b in m.mesh.split() if b.bounds[0][1] < -1]
    assert len(sign) == 1 and sign[0].extents[1] == pytest.approx(THICKNESS, abs=0.004)
    # united where it touches: moved by less than its thickness, it is part of the mass
    touching = derive(grammarkit.parse("Lot --> extrude(4) comp(f) { front: t(0, 0, 0.005) Sign. | side: Wall. }\n"))
    _closed(touching.mesh)
    assert touching.mesh.body_count == 1


def test_open_meshes_are_closed_by_caps_or_thickness():
    # a tube open at both ends: closed by caps (its volume is the cylinder's)
    tube = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=24)
    keep = np.abs(tube.face_normals[:, 2]) < 0.5
    V, F = tube.vertices, tube.faces[keep]
    assert fill_holes(V, F) is not None
    solid = close_mesh(V, F)
    assert solid.volume() == pytest.approx(tube.volume, rel=1e-6)
    # a single quad: a slab THICKNESS thick behind its front
    quad = close_mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    assert quad.volume() == pytest.approx(THICKNESS)
    assert quad.bounding_box()[2] == pytest.approx(-THICKNESS)
    # the same triangles give the very same (cached) solid
    assert close_mesh(V, F) is solid


def test_bad_surfaces_mode_is_a_clear_error():
    from grammarkit.errors import DerivationError

    with pytest.raises(DerivationError, match="surfaces= must be one of 'solid', 'cga'"):
        derive(grammarkit.parse("Lot --> extrude(1) X.\n"), surfaces="open")
