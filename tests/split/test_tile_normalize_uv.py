"""CGA's tileUV and normalizeUV (grammarkit/split/ops/texturing.py) on baked texture coordinates."""
from __future__ import annotations

import numpy as np
import pytest

import grammarkit
from grammarkit.cga import translate_cga

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.

def derive_cga(*args, **kw):
    return grammarkit.derive(*args, surfaces="cga", **kw)


LOT = [(0.0, 0.0), (12.0, 0.0), (12.0, 9.0), (0.0, 9.0)]


def uv_range(text: str) -> np.ndarray:
    m = derive_cga(text, lot=LOT)
    uv = np.concatenate([u.reshape(-1, 2) for u in (m.triangle_uvs, m.surface_uvs) if u is not None])
    uv = uv[~np.isnan(uv).any(axis=1)]
    return np.array([uv.min(axis=0), uv.max(axis=0)]).ravel()


def test_tile_uv_makes_tiles_of_the_given_world_size():
    base = "Lot --> setupProjection(0, scope.xy, 2, 3) projectUV(0) "
    assert uv_range(base + "F.\n") == pytest.approx([0, 0, 6, 3])
    # 4 x 3 m tiles on a 12 x 9 m lot: 3 x 3 tiles, whatever the projection's tile was
    assert uv_range(base + "tileUV(0, 4, 3) F.\n") == pytest.approx([0, 0, 3, 3])
    assert uv_range(base + "tileUV(0, 0, 1) F.\n") == pytest.approx([0, 0, 6, 9])  # 0: u kept
    assert uv_range(base + "tileUV(0, -4, 3) F.\n") == pytest.approx([-3, 0, 0, 3])  # mirrored


def test_normalize_uv_spans_zero_to_one():
    base = "Lot --> setupProjection(0, scope.xy, 2, 3, 1, 1) projectUV(0) "
    assert uv_range(base + "normalizeUV(0, uv, separatePerFace) F.\n") == pytest.approx([0, 0, 1, 1])
    lo, hi = uv_range(base + "normalizeUV(0, u, collectiveAllFaces) F.\n").reshape(2, 2)
    assert (lo[0], hi[0]) == pytest.approx((0, 1)) and hi[1] - lo[1] == pytest.approx(3.0)
    # on a volume: over all its faces together
    r = uv_range("Lot --> extrude(6) setupProjection(0, world.xy, 1, 1) projectUV(0) "
                 "normalizeUV(0, uv, collectiveAllFaces) M.\n")
    assert r == pytest.approx([0, 0, 1, 1], abs=1e-3)  # the solid is grown by the 1 mm weld


def test_without_texture_coordinates_tile_and_normalize_uv_warn_and_change_nothing():
    m = derive_cga("Lot --> tileUV(0, 2, 2) F.\n", lot=LOT)  # CityEngine's behaviour
    assert any("tileUV(): the shape has no texture coordinates in uv set 0" in w for w in m.warnings)
    # normalizeUV() too: the public swiss rule set calls it on shapes without UVs
    m = derive_cga("Lot --> normalizeUV(0, uv, separatePerFace) F.\n", lot=LOT)
    assert any("normalizeUV(): the shape has no texture coordinates in uv set 0" in w for w in m.warnings)


def test_cga_tile_and_normalize_are_translated():
    r = translate_cga("Lot --> setupProjection(0, scope.xz, 1, 1) projectUV(0) tileUV(0, 4, 3) "
                      "normalizeUV(0, u, separatePerFace) X.\n", filename="t.cga")
    assert r.ok
    assert "tileUV(0, 4, 3)" in r.text and "normalizeUV(0, u, separatePerFace)" in r.text
    derive_cga(r.grammar, lot=LOT)
