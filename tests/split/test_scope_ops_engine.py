"""CGA's scope operations in the engine: rotateScope about any axes, alignScopeToAxes(axis),
alignScopeToGeometry(edge, face), mirrorScope, mirrorGeometry (CGA's mirror). The scope turns,
the geometry stays (its world bounds and volume are unchanged); every solid stays watertight,
also when written as GLB and read back by trimesh."""
from __future__ import annotations

import math

import pytest
import trimesh

import grammarkit
from grammarkit.errors import DerivationError

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.

def derive_cga(*args, **kw):
    return grammarkit.derive(*args, surfaces="cga", **kw)


LOT = 'Lot --> footprint(rect(10, 4)) '


def one(text: str):
    m = derive_cga(text + "\n")
    assert len(m.parts) == 1
    return m, m.parts[0]


def flat(axes) -> list:
    return [v for a in axes for v in a]


def readback_watertight(m, tmp_path) -> bool:
    """The GLB read back by trimesh with default arguments, its primitives (one per tag)
    concatenated into one Trimesh with default processing (vertices merged by position)."""
    path = m.save(tmp_path / "m.glb")
    scene = trimesh.load(path)
    mesh = trimesh.util.concatenate(scene.dump())
    return trimesh.Trimesh(mesh.vertices, mesh.faces).is_watertight


def test_rotate_scope_about_x_refits_the_box_and_keeps_the_geometry(tmp_path):
    m0, _ = one(LOT + "extrude(3) A.")
    m, p = one(LOT + "extrude(3) rotateScope(90, 0, 0) A.")
    # x kept, y turned to world up, z to world -y; origin at the box corner (0, 4, 0)
    assert flat(p.axes) == pytest.approx(flat(((1, 0, 0), (0, 0, 1), (0, -1, 0))))
    assert p.size == pytest.approx((10, 3, 4)) and p.origin == pytest.approx((0, 4, 0))
    assert m.mesh.bounds == pytest.approx(m0.mesh.bounds) and m.mesh.volume == pytest.approx(m0.mesh.volume)
    assert readback_watertight(m, tmp_path)


def test_rotate_scope_by_30_degrees_makes_the_bounding_box_of_the_turned_axes(tmp_path):
    m, p = one(LOT + "extrude(3) rotateScope(30, 0, 0) A.")
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    assert p.axes[1] == pytest.approx((0, c, s)) and p.axes[2] == pytest.approx((0, -s, c))
    # the 4 x 3 cross-section in the turned axes: y extent 4c + 3s, z extent 4s + 3c
    assert p.size == pytest.approx((10, 4 * c + 3 * s, 4 * s + 3 * c))
    assert m.mesh.bounds[1] == pytest.approx((10, 4, 3), abs=2e-3)
    assert readback_watertight(m, tmp_path)
    # a split along the turned y cuts the solid on slanted planes: the volume is kept
    m2 = derive_cga(LOT + "extrude(3) rotateScope(30, 0, 0) split(y) { ~1: A. | ~1: B. }\n")
    assert {q.name for q in m2.parts} == {"A", "B"}
    assert m2.mesh.volume == pytest.approx(120, rel=2e-3) and readback_watertight(m2, tmp_path)


def test_rotate_scope_of_a_face_out_of_its_plane_and_back():
    # a face turned out of the scope's xy plane is an open surface; turned back it is a face
    # again and can be extruded
    m, p = one(LOT + "rotateScope(90, 0, 0) A.")
    assert p.size == pytest.approx((10, 0, 4)) and len(m.surface_faces) == 2
    m, p = one('Lot --> footprint(polygon(0, 0, 10, 0, 10, 4, 3, 8, 0, 4)) rotateScope(90, 0, 0) '
               "rotateScope(-90, 0, 0) extrude(2) A.")
    assert flat(p.axes) == pytest.approx(flat(((1, 0, 0), (0, 1, 0), (0, 0, 1))))
    assert m.mesh.volume == pytest.approx(2 * (40 + 0.5 * 10 * 4 - 0.5 * 4 * 3 * 0), rel=0.02)


def test_align_scope_to_axes_on_a_facade_face_and_a_flipped_top():
    # the front face of a box (normal -y): all axes to the world's, the face is vertical
    m, p = one(LOT + 'extrude(3) comp(f) { front: alignScopeToAxes() A. }')
    assert flat(p.axes) == pytest.approx(flat(((1, 0, 0), (0, 1, 0), (0, 0, 1)))) and p.size == pytest.approx((10, 0, 3))
    # "z": the scope's z to the world's, x projected: a top face turned upside down comes
    # back as a face with z up, and extrudes upwards
    m, p = one(LOT + 'extrude(3) comp(f) { top: rotateScope(180, 0, 0) alignScopeToAxes("z") extrude(1) A. }')
    assert p.axes[2] == pytest.approx((0, 0, 1)) and p.origin == pytest.approx((0, 0, 3))
    assert m.mesh.volume == pytest.approx(40, rel=0.01) and m.mesh.bounds[1][2] == pytest.approx(4, abs=2e-3)
    # "y": the scope's y to the world's y, x projected (CGA's world.z)
    m, p = one(LOT + 'extrude(3) rotateScope(0, 0, 30) rotateScope(20, 0, 0) alignScopeToAxes("y") A.')
    assert p.axes[1] == pytest.approx((0, 1, 0)) and abs(p.axes[0][1]) < 1e-9


def test_align_scope_to_axes_on_a_box_extruded_downwards_keeps_a_box():
    # a volume extruded below a top face (z down): aligned, it is the same box with z up
    m, p = one(LOT + 'extrude(3) comp(f) { top: extrude(-1) alignScopeToAxes("z") A. }')
    assert p.axes[2] == pytest.approx((0, 0, 1)) and p.size == pytest.approx((10, 4, 1))
    assert p.origin == pytest.approx((0, 0, 2))
    assert m.mesh.volume == pytest.approx(40, rel=0.01)


def test_align_scope_to_geometry_picks_a_face_of_a_volume():
    # face 2 in comp(f) order (bottom, top, then the sides) is the front: z its normal (-y)
    m, p = one(LOT + 'extrude(3) alignScopeToGeometry("longest", 2) A.')
    assert flat(p.axes) == pytest.approx(flat(((1, 0, 0), (0, 0, 1), (0, -1, 0)))) and p.size == pytest.approx((10, 3, 4))
    # "largest": the bottom (40 m2, first of the two largest), looking down
    m, p = one(LOT + 'extrude(3) alignScopeToGeometry(0, "largest") A.')
    assert p.axes[2] == pytest.approx((0, 0, -1)) and p.size == pytest.approx((10, 4, 3))
    # "any" with "longest": the longest edge of any face
    m, p = one('Lot --> footprint(rect(4, 10)) extrude(3) alignScopeToGeometry("longest", "any") A.')
    assert abs(p.axes[0][1]) == pytest.approx(1)


def test_mirror_scope_turns_two_axes_and_refuses_one():
    m, p = one(LOT + "extrude(3) mirrorScope(true, true, false) A.")
    assert flat(p.axes) == pytest.approx(flat(((-1, 0, 0), (0, -1, 0), (0, 0, 1)))) and p.origin == pytest.approx((10, 4, 0))
    assert p.size == pytest.approx((10, 4, 3))
    with pytest.raises(DerivationError) as e:
        derive_cga(LOT + "extrude(3) mirrorScope(false, false, true) A.\n")
    assert "left-handed" in str(e.value) and e.value.span.column > 1
    with pytest.raises(DerivationError) as e:
        derive_cga(LOT + 'mirrorScope(1, 0, 0) A.\n')
    assert "true or false" in str(e.value)


def test_mirror_geometry_reflects_inside_the_scope(tmp_path):
    # an asymmetric footprint (a gable point at x = 3) mirrored along x: the point at x = 7
    src = 'Lot --> footprint(polygon(0, 0, 10, 0, 10, 4, 3, 8, 0, 4)) extrude(3) '
    m0 = derive_cga(src + "A.\n")
    m, p = one(src + "mirrorGeometry(true, false, false) A.")
    assert p.size == pytest.approx((10, 8, 3)) and p.axes[0] == pytest.approx((1, 0, 0))
    top = m.mesh.vertices[m.mesh.vertices[:, 1] > 7.9]
    assert top[:, 0] == pytest.approx(7, abs=0.01)
    assert m.mesh.volume == pytest.approx(m0.mesh.volume) and readback_watertight(m, tmp_path)
    # a roof mirrored along z hangs upside down inside its scope, still a closed solid
    m, p = one(LOT + "roofGable(30) mirrorGeometry(false, false, true) A.")
    low = m.mesh.vertices[m.mesh.vertices[:, 2] < 0.01]
    assert low[:, 1] == pytest.approx(2, abs=0.01)  # the ridge is at the bottom now
    assert m.mesh.is_watertight and readback_watertight(m, tmp_path)


def test_bad_arguments_are_located_errors():
    for op in ('alignScopeToAxes("w")', 'alignScopeToGeometry(0, "big")',
               'alignScopeToGeometry(0, "any")', "alignScopeToGeometry(0.5)"):
        with pytest.raises(DerivationError) as e:
            derive_cga(LOT + "extrude(3) " + op + " A.\n")
        assert e.value.span is not None and e.value.span.line == 1, op


def test_scope_operations_are_deterministic():
    text = LOT + "extrude(3) rotateScope(17, 23, 41) split(x) { ~1: A. | ~1: B. }\n"
    a, b = derive_cga(text), derive_cga(text)
    assert [(q.origin, q.axes, q.size) for q in a.parts] == [(q.origin, q.axes, q.size) for q in b.parts]
