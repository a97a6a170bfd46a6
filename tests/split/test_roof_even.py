"""`even=true` of roofHip and roofGable (grammarkit/geometry/roofs.py `_even`): CGA's level
ridge — the ridge vertices at their average height — checked against the straight skeleton's
node heights worked out by hand, and unchanged where the ridge is level already."""
from __future__ import annotations

import math

import pytest

import grammarkit
from grammarkit.errors import DerivationError

from .test_envelope import glb_volume

T30 = math.tan(math.radians(30))
# a quad whose top edge slants: (0,0) (20,0) (20,8) (0,12); the top edge's line 4x + 20y = 240
QUAD = [(0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (0.0, 12.0)]
TOP_NORM = math.hypot(4, 20)
RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (0.0, 10.0)]


def roof(op: str, lot):
    m = grammarkit.derive(f"Lot --> {op} R.\n", lot=lot)
    return m, m.parts[0]


def test_hip_even_levels_the_ridge_at_the_skeleton_nodes_mean_height():
    # the two skeleton nodes: equidistant d from the left (x = d), bottom (y = d) and top
    # edges: (240 - 24 d) / |(4, 20)| = d; on the right x = 20 - d: (160 - 16 d) / |(4, 20)| = d
    d_left = 240 / (TOP_NORM + 24)
    d_right = 160 / (TOP_NORM + 16)
    m, planar = roof("roofHip(30)", QUAD)
    assert planar.size[2] == pytest.approx(T30 * d_left, abs=1e-6)  # the planar roof's top: the left node
    m_even, even = roof("roofHip(30, even=true)", QUAD)
    assert even.size[2] == pytest.approx(T30 * (d_left + d_right) / 2, abs=1e-5)
    assert glb_volume(m_even) < glb_volume(m)  # the left node came down more than the right went up


def test_gable_even_levels_the_ridge_between_the_eave_planes():
    # eaves: the bottom edge (y = 0) and the slanting top edge; the ridge ends on the gable
    # ends x = 0 and x = 20 where t y = t dist(top): y = c (12 - y) at x = 0, y = c (8 - y) at
    # x = 20, c = cos(atan(0.2)); even: both ends at the mean height
    c = 20 / TOP_NORM
    y0, y20 = 12 * c / (1 + c), 8 * c / (1 + c)
    m, even = roof("roofGable(30, even=true)", QUAD)
    assert even.size == pytest.approx((20.0, 12.0, T30 * (y0 + y20) / 2), abs=1e-5)
    glb_volume(m)  # watertight
    # grammarkit's own gable (even=false) stays as it was: planes from the bounding lines
    _, planar = roof("roofGable(30)", QUAD)
    assert planar.size[2] == pytest.approx(T30 * 6, abs=1e-6)


def test_even_changes_nothing_where_the_ridge_is_level():
    for op in ("roofHip(30{})", "roofGable(30{})", "roofHip(30, 1{})", "roofGable(25, 0.5{})"):
        m0, p0 = roof(op.format(""), RECT)
        m1, p1 = roof(op.format(", even=true"), RECT)
        assert p1.size == pytest.approx(p0.size, abs=1e-6)
        assert glb_volume(m1) == pytest.approx(glb_volume(m0), rel=1e-6)
    # a symmetric trapezoid: both hip nodes at the same height
    trap = [(0.0, 0.0), (20.0, 0.0), (16.0, 10.0), (4.0, 10.0)]
    (m0, p0), (m1, p1) = roof("roofHip(30)", trap), roof("roofHip(30, even=true)", trap)
    assert glb_volume(m1) == pytest.approx(glb_volume(m0), rel=1e-6)


def test_even_with_overhang_by_height_and_on_a_building_is_watertight():
    m, r = roof("roofHip(2.5, 0.6, byHeight, even=true)", QUAD)
    assert r.size[2] == pytest.approx(2.5, abs=1e-5)
    glb_volume(m)
    m = grammarkit.derive("Lot --> extrude(6) comp(f) { top: roofGable(35, 0.5, even=true) Roof. | volume: Mass. }\n",
                          lot=QUAD)
    glb_volume(m)


def test_even_must_be_a_boolean():
    with pytest.raises(DerivationError, match="even must be true or false") as e:
        roof("roofHip(30, even=2)", QUAD)
    assert e.value.span is not None and e.value.span.line == 1
