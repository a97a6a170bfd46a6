"""comp(f) consumes the shape (CGA), `volume:` keeps it; faces that are not views of an
emitted solid become the surface layer; comp(f) of faces, roofs and inserted meshes; index
and orientation selectors; recesses without a solid behind them show their reveal."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from grammarkit.geometry.convert import mesh_report
from functools import partial

from grammarkit.split import derive as _derive

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.
derive = partial(_derive, surfaces="cga")


def names(model):
    return sorted(p.name for p in model.parts)


def surface_names(model):
    return sorted({model.tags[t].name for t in model.surface_tags.tolist()})


def test_comp_consumes_the_volume_unless_volume_keeps_it(G):
    consumed = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { side: W. | top: T. }"))
    assert len(consumed.faces) == 0  # no solid: the box is gone
    assert surface_names(consumed) == ["T", "W"]  # the bottom was not selected: an open box
    assert consumed.surface_mesh.area == pytest.approx(8 * 6 + 2 * (8 + 6) * 3)
    kept = derive(G('Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { side: color("#ff0000") W. '
                    '| top: color("#00ff00") T. | volume: M. }'))
    assert len(kept.surface_faces) == 0
    rep = mesh_report(kept.mesh)
    assert rep.watertight and rep.volume == pytest.approx(144, rel=5e-3)
    labels = set(kept.face_labels())
    assert labels == {"W", "T", "M"}  # the (coloured) faces tag the kept volume; the bottom keeps M


def test_a_push_keeps_the_volume_too(G):
    # CGA's way: decompose a copy, keep the original
    m = derive(G('Lot --> footprint(rect(8, 6)) extrude(3) [ comp(f) { side: color("#f00") W. } ] M.'))
    assert len(m.surface_faces) == 0 and "W" in set(m.face_labels())


def test_faces_of_a_moved_volume_are_surfaces(G):
    # the kept volume was moved after the comp: its faces no longer lie on it
    m = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) [ comp(f) { side: W. } ] t(0, 0, 5) M."))
    assert surface_names(m) == ["W"] and mesh_report(m.mesh).watertight


def test_recess_without_a_solid_shows_its_reveal(G):
    m = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { front: Facade }\n"
                 "Facade --> split(x) { ~1: Wall. | 2: split(y) { 1: Wall. | 1.5: recess(0.25) Glass. "
                 "| ~1: Wall. } | ~1: Wall. }"))
    assert len(m.faces) == 0
    glass = [k for k, t in enumerate(m.surface_tags.tolist()) if m.tags[t].name == "Glass"]
    assert len(glass) == 2 + 8  # the pane at the bottom of the recess, and four reveal walls
    V = m.surface_vertices[m.surface_faces[glass]].reshape(-1, 3)
    assert V[:, 1].max() == pytest.approx(0.25)  # 0.25 into the (absent) wall
    # the reveal walls face into the opening
    mesh = trimesh.Trimesh(m.surface_vertices, m.surface_faces[glass], process=False)
    centre = np.array([4.0, 0.125, 1.75])
    walls = np.abs(mesh.face_normals[:, 1]) < 0.5
    to_centre = centre - mesh.triangles_center[walls]
    assert (np.einsum("ij,ij->i", mesh.face_normals[walls], to_centre) > 0).all()
    # with the volume kept, the same recess is a cut: no surfaces at all
    kept = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { front: Facade | volume: M. }\n"
                    "Facade --> split(x) { ~1: Wall. | 2: split(y) { 1: Wall. | 1.5: recess(0.25) "
                    "Glass. | ~1: Wall. } | ~1: Wall. }"))
    assert len(kept.surface_faces) == 0
    assert mesh_report(kept.mesh).volume == pytest.approx(144 - 2 * 1.5 * 0.25, rel=5e-3)


def test_a_model_of_faces_only(G):
    m = derive(G("Lot --> Lot."))
    assert m.triangle_count == 2 and len(m.faces) == 0
    assert m.surface_mesh.area == pytest.approx(100.0)
    assert [p.kind for p in m.parts] == ["face"]


def test_index_selectors_and_comp_index(G):
    m = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { 0: A(comp.index, comp.total) "
                 "| 4: B(comp.index, comp.total) | side: C(comp.index, comp.total) }\n"
                 "A(i, n) --> extrude(1 + i) A.\nB(i, n) --> extrude(1 + n) B.\nC(i, n) --> extrude(1 + i) C."))
    by = {p.name: [] for p in m.parts}
    for p in m.parts:
        by[p.name].append(p.size[2])
    # CGA's order: bottom 0, top 1, sides 2.. (in the footprint's edge order)
    assert by["A"] == [1] and by["B"] == [1 + 6]  # comp.total counts every face of the comp
    assert sorted(by["C"]) == [3, 4, 6]  # sides 2, 3, 5 (side 4 went to B)
    bottom = next(p for p in m.parts if p.name == "A")
    assert bottom.axes[2] == pytest.approx((0, 0, -1))


def test_orientation_selectors(G):
    m = derive(G("Lot --> footprint(rect(8, 6)) extrude(3) comp(f) { horizontal: H. | vertical: V. }"))
    assert names(m) == ["H", "H", "V", "V", "V", "V"]


def test_comp_of_a_face_is_the_face(G):
    m = derive(G("Lot --> footprint(rect(8, 6)) comp(f) { top: extrude(2) T. }"))
    assert names(m) == ["T"] and mesh_report(m.mesh).volume == pytest.approx(96, rel=5e-3)


def test_comp_of_a_roof_gives_its_planes(G):
    m = derive(G("Lot --> footprint(rect(10, 6)) extrude(3) comp(f) { top: roofHip(30) Roof | volume: M. }\n"
                 "Roof --> comp(f) { top: Plane(scope.sx, scope.sy) | side: Side. | bottom: NIL }\n"
                 "Plane(w, h) --> Plane."))
    planes = [p for p in m.parts if p.name == "Plane"]
    assert len(planes) == 4
    # the sides are the roof's 2 cm fascia (grammarkit.geometry.roofs.FASCIA)
    assert all(p.size[1] < 0.03 for p in m.parts if p.name == "Side")
    # the long planes: x along the 10 m eave (the lowest edge), z the outward normal tilted 30 degrees
    long = [p for p in planes if p.size[0] == pytest.approx(10, abs=0.05)]
    assert len(long) == 2
    for p in long:
        ex, ey, ez = (np.array(a) for a in p.axes)
        assert abs(ex[2]) < 1e-9 and ez[2] == pytest.approx(np.cos(np.radians(30)), abs=5e-3)
        assert ey[2] > 0  # y runs up the slope
    # the roof was consumed: its planes are surfaces, the kept mass is the solid
    assert surface_names(m) == ["Plane", "Side"] and mesh_report(m.mesh).watertight


def test_comp_of_a_taper_and_its_faces_on_a_kept_solid(G):
    m = derive(G('Lot --> footprint(rect(6, 6)) taper(4, 0.5) comp(f) { side: color("#f00") S. '
                 '| top: color("#0f0") T. | volume: V. }'))
    assert names(m).count("S") == 4 and names(m).count("T") == 1
    assert len(m.surface_faces) == 0 and {"S", "T"} <= set(m.face_labels())
