"""Issue 27's second step: the default solid mode with fewer parts and triangles, the same look.

- An open piece that is a convex patch (every face on its convex hull: a bar modelled as its
  visible sides) closes as that hull, its faces where they were; a flat pane is still a slab.
- The reversed walls of a CGA opening (`extrude(-d) comp(f) { side: reverseNormals() Reveal }`
  into a closing solid) are views of the solid's reveal (they paint it), not slabs inside the wall;
  moved off it or facing into the wall they stay slabs.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import grammarkit
from grammarkit.geometry import closing
from grammarkit.geometry.closing import THICKNESS, close_mesh, thicken
from grammarkit.split import derive, engine


def _l_profile():
    """Two quads meeting at a right angle along x (a bar's top and front, open elsewhere)."""
    V = np.array([[0, 0, 0], [2, 0, 0], [2, 0.1, 0], [0, 0.1, 0],  # top, z = 0
                  [0, 0, -0.1], [2, 0, -0.1]], float)  # the front drops from the y = 0 edge
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 5], [0, 5, 1]])
    return V, F


def test_a_convex_patch_closes_as_its_hull_with_its_faces_kept():
    V, F = _l_profile()
    solid = close_mesh(V, F)
    Vt, Ft = thicken(V, F, THICKNESS)
    assert solid.num_tri() < len(Ft)  # 8 triangles against thickening's 20
    m = solid.to_mesh()
    closed = trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts), process=True)
    assert closed.is_watertight and closed.is_winding_consistent
    # the visible faces stay where they were: every vertex of the piece is on the solid
    assert np.abs(closed.nearest.signed_distance(V)).max() < 1e-5
    assert solid.volume() == pytest.approx(0.5 * 0.1 * 0.1 * 2, rel=1e-4)  # the prism under them


def test_a_flat_pane_is_still_a_slab_and_the_old_closing_stays_measurable():
    quad = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    assert close_mesh(*quad).volume() == pytest.approx(THICKNESS)
    V, F = _l_profile()
    lean = close_mesh(V, F)
    closing.CONVEX_PATCHES = False
    try:
        old = close_mesh(V, F)  # a separate cache entry: the flag is part of the key
    finally:
        closing.CONVEX_PATCHES = True
    assert old is not lean and old.num_tri() > lean.num_tri()


OPENING = ("Lot --> extrude(6) comp(f) { front: Facade | side: Wall. }\n"
           "Facade --> split(x) { 2: Wall. | 2: Win | ~1: Wall. }\n"
           "Win --> split(y) { 1: Wall. | 2: Hole | ~1: Wall. }\n"
           "Hole --> extrude(-0.4) comp(f) { side: {side} Reveal. }\n")


def _reveal_run(side: str, views: bool = True):
    g = grammarkit.parse(OPENING.replace("{side}", side))
    engine.REVEAL_VIEWS = views
    try:
        return derive(g, lot=[(0, 0), (8, 0), (8, 6), (0, 6)])
    finally:
        engine.REVEAL_VIEWS = True


@pytest.mark.parametrize("views", [True, False])
def test_the_walls_of_an_opening_paint_its_reveal(views):
    m = _reveal_run("reverseNormals()", views)
    assert m.mesh.is_watertight and m.mesh.is_winding_consistent and m.mesh.body_count == 1
    labels = np.array(m.face_labels())
    reveal = labels == "Reveal"
    normals = m.mesh.face_normals[reveal]
    assert reveal.any()
    if views:  # the solid's own reveal triangles carry the tag: no slab, nothing extra
        ctx = m._ctx
        assert len(ctx.reveal_tags) == 4
        assert not any(ctx.tags[t][0] == "Reveal" for t in ctx.id_tag.values())  # no Reveal solid
        # they face into the hole (the reveal's visible side), not into the wall
        centre = np.array([3.0, 0.0, 2.0])
        tri_c = m.mesh.triangles_center[reveal]
        inward = np.einsum("ij,ij->i", normals, centre - tri_c)
        assert (inward[np.abs(normals[:, 1]) < 0.5] > 0).all()
    lean, slabs = _reveal_run("reverseNormals()", True), _reveal_run("reverseNormals()", False)
    assert lean.triangle_count < slabs.triangle_count
    assert lean.mesh.volume == pytest.approx(slabs.mesh.volume, abs=0.02)  # slabs were inside the wall


def test_walls_of_an_opening_that_face_the_wall_or_move_stay_slabs():
    unreversed = _reveal_run("")
    assert not unreversed._ctx.reveal_tags  # facing into the wall: a slab (the previous way)
    moved = _reveal_run("reverseNormals() t(0, 0, 0.2)")
    assert not moved._ctx.reveal_tags  # moved off the reveal: a closed part of its own
    for m in (unreversed, moved):
        assert m.mesh.is_watertight and m.mesh.is_winding_consistent
