"""CGA's roof options (grammarkit/split/ops/, grammarkit/geometry/roofs.py): the gable's
ridge along an edge index and its two overhangs, the shed's low edge by index, and byHeight
for the gable, hip and shed roofs."""
from __future__ import annotations

import io
import math

import numpy as np
import pytest

import grammarkit
from grammarkit.errors import DerivationError, GrammarError

RECT = [(0.0, 0.0), (10.0, 0.0), (10.0, 6.0), (0.0, 6.0)]
TRAPEZOID = [(0.0, 0.0), (12.0, 0.0), (9.0, 6.0), (3.0, 6.0)]


def roof(text: str, lot=RECT):
    m = grammarkit.derive(f"Lot --> {text} R.\n", lot=lot)
    return m, next(p for p in m.parts if p.name == "R")


def glb_watertight(model) -> bool:
    """The model's GLB read back by trimesh with default processing is one closed mesh."""
    import trimesh

    from grammarkit.geometry.exporters import encode_glb

    loaded = trimesh.load(io.BytesIO(encode_glb(model)), file_type="glb")
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.to_mesh()
    mesh = trimesh.Trimesh(loaded.vertices, loaded.faces)
    return bool(mesh.is_watertight and mesh.is_winding_consistent)


def top_vertices(model, frac: float = 0.999) -> np.ndarray:
    """(x, y) of the vertices at the roof's top (within 0.1 % of its height)."""
    V = np.asarray(model.manifold.to_mesh().vert_properties)[:, :3]
    z1 = V[:, 2].max()
    return V[V[:, 2] >= z1 * frac][:, :2]


def test_gable_ridge_follows_the_edge_index():
    # edge 0 runs along x: ridge along x over the middle of the 6 m depth, 3 m high at 45 degrees
    m, r = roof("roofGable(45, index=0)")
    assert r.size[2] == pytest.approx(3.0, abs=1e-6)
    assert np.allclose(top_vertices(m)[:, 1], 3.0, atol=1e-3)
    # edge 1 runs along y: the ridge turns, over the middle of the 10 m width, 5 m high
    m, r = roof("roofGable(45, index=1)")
    assert r.size[2] == pytest.approx(5.0, abs=1e-6)
    assert np.allclose(top_vertices(m)[:, 0], 5.0, atol=1e-3)
    # the index is taken modulo the number of edges (CGA's float index floored): 5 is edge 1
    assert roof("roofGable(45, index=5.7)")[1].size[2] == pytest.approx(5.0, abs=1e-6)
    assert glb_watertight(m)


def test_gable_overhangs_across_and_along_the_ridge():
    m, r = roof("roofGable(45, overhang=1, overhang_y=2)")
    # across the ridge (eaves) by 1, along it (gable ends) by 2
    assert r.size[:2] == pytest.approx((14.0, 8.0), abs=1e-6)
    assert r.size[2] == pytest.approx(4.0, abs=1e-6)  # half of the 8 m span at 45 degrees
    # a negative overhang_y pulls the gable ends in (a real rule does this for a temple front)
    m2, r2 = roof("roofGable(45, overhang=0, overhang_y=-1.5)")
    assert r2.size[:2] == pytest.approx((7.0, 6.0), abs=1e-6)
    assert m2.manifold.volume() == pytest.approx(7.0 * 6.0 * 3.0 / 2, rel=0.02)
    assert glb_watertight(m) and glb_watertight(m2)
    # with the index, the overhangs follow the edge's frame: ridge along y, eaves grow along x
    _, r3 = roof("roofGable(45, overhang=1, overhang_y=2, index=1)")
    assert r3.size[:2] == pytest.approx((12.0, 10.0), abs=1e-6)


def test_shed_rises_from_the_indexed_edge():
    for index, (axis, low) in {0: (1, 0.0), 1: (0, 10.0), 2: (1, 6.0), 3: (0, 0.0)}.items():
        m, r = roof(f"roofShed(30, index={index})")
        run = 6.0 if axis == 1 else 10.0
        assert r.size[2] == pytest.approx(run * math.tan(math.radians(30)), abs=1e-6)
        top = top_vertices(m)[:, axis]
        # the top is the edge opposite the low one
        assert np.allclose(top, run - low if low else run, atol=1e-3), (index, top)
        assert glb_watertight(m)
    # without an index: grammarkit's ridge axis (x: rising towards +y), the same as index 0
    assert roof("roofShed(30)")[1].size == pytest.approx(roof("roofShed(30, index=0)")[1].size)


@pytest.mark.parametrize("op, height", [("roofGable", 2.5), ("roofHip", 1.75), ("roofShed", 4.0)])
def test_by_height_gives_that_height(op, height):
    for lot in (RECT, TRAPEZOID):
        m, r = roof(f"{op}({height}, value_type=byHeight)", lot)
        assert r.size[2] == pytest.approx(height, abs=1e-6)
        assert glb_watertight(m)
    # the gable's planes over a 6 m span reaching 2.5 m: the volume is the prism's half
    m, _ = roof("roofGable(2.5, value_type=byHeight)")
    if op == "roofGable":
        assert m.manifold.volume() == pytest.approx(10 * 6 * 2.5 / 2, rel=0.02)


def test_by_height_and_by_angle_agree():
    _, a = roof("roofHip(30)")
    _, h = roof(f"roofHip({3 * math.tan(math.radians(30))}, value_type=byHeight)")
    assert a.size == pytest.approx(h.size, abs=1e-6)


def test_bad_roof_options_are_located_errors():
    with pytest.raises(DerivationError, match="height must be > 0") as e:
        roof("roofGable(-2, value_type=byHeight)")
    assert e.value.span is not None and e.value.span.line == 1
    with pytest.raises(DerivationError, match="steeper than 89"):
        roof("roofShed(1000, value_type=byHeight)")
    with pytest.raises(GrammarError, match="value_type"):
        grammarkit.derive("Lot --> roofGable(2, value_type=byWidth) R.\n", lot=RECT)
    with pytest.raises(DerivationError, match="leave no roof"):
        roof("roofGable(45, overhang=0, overhang_y=-6)")


def test_gable_ridge_auto_runs_along_the_longest_edge():
    # a 10 x 24 rectangle turned by 30 degrees: the ridge along the 24 m sides, so the roof
    # rises over the 10 m span (5 m at 45 degrees), whatever the scope's axes are
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    lot = [(x * c - y * s, x * s + y * c) for x, y in ((0, 0), (10, 0), (10, 24), (0, 24))]
    m = grammarkit.derive("Lot --> roofGable(45, ridge=auto) R.\n", lot=lot)
    assert m.parts[0].size[2] == pytest.approx(5.0, abs=1e-6)
    m = grammarkit.derive("Lot --> roofGable(45, ridge=auto) R.\n", lot=[(0, 0), (24, 0), (24, 10), (0, 10)])
    assert m.parts[0].size[2] == pytest.approx(5.0, abs=1e-6)
