"""`envelope(direction, max_height, front_base, front_angle, ...)` (grammarkit/split/ops/envelope.py):
the zoning envelope of a lot, a watertight solid whose volume matches the closed form."""
from __future__ import annotations

import io

import pytest

import grammarkit
from grammarkit.errors import DerivationError, GrammarError

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]
REL = 2e-3  # solids are welded by 1 mm (grammarkit.split.engine), a few 1e-4 of these volumes


def envelope(args: str, lot=LOT):
    m = grammarkit.derive(f"Lot --> envelope({args}) E.\n", lot=lot)
    return m, next(p for p in m.parts if p.name == "E")


def glb_volume(model) -> float:
    import trimesh

    from grammarkit.geometry.exporters import encode_glb

    loaded = trimesh.load(io.BytesIO(encode_glb(model)), file_type="glb")
    mesh = loaded.to_mesh() if isinstance(loaded, trimesh.Scene) else loaded
    mesh = trimesh.Trimesh(mesh.vertices, mesh.faces)
    assert mesh.is_watertight and mesh.is_winding_consistent
    return float(mesh.volume)


def test_front_setback_plane_volume_is_the_closed_form():
    # W x D lot, H high, the front side vertical to b then leaning in at 45 degrees:
    # V = W D H - W (H - b)^2 / 2 (the plane stays inside the lot: D >= H - b)
    m, e = envelope("normal, 15, 5, 45")
    assert e.size == pytest.approx((20.0, 16.0, 15.0))
    assert glb_volume(m) == pytest.approx(20 * 16 * 15 - 20 * 10 ** 2 / 2, rel=REL)
    # at 30 degrees the plane runs (H - b) / tan(30) deep: V = W D H - W (H - b)^2 / (2 tan 30)
    m, _ = envelope("normal, 12, 4, 30")
    t = 3 ** -0.5
    assert glb_volume(m) == pytest.approx(20 * 16 * 12 - 20 * 8 ** 2 / t / 2, rel=REL)


def test_all_four_sides_make_a_hipped_top_and_max_height_seals_it():
    # every side leans in from 5 m at 45 degrees: a hip over 20 x 16 (ridge 8 m above the
    # base, below the 15 m cap): V = W D b + integral_0^8 (W - 2z)(D - 2z) dz
    m, e = envelope("normal, 15, 5, 45, 5, 45, 5, 45, 5, 45")
    hip = 20 * 16 * 8 - (20 + 16) * 64 + 4 * 512 / 3
    assert e.size[2] == pytest.approx(13.0, abs=1e-6)
    assert glb_volume(m) == pytest.approx(20 * 16 * 5 + hip, rel=REL)
    # the same with a 9 m cap: cut and sealed flat at 9 (4 m of the hip)
    m, e = envelope("normal, 9, 5, 45, 5, 45, 5, 45, 5, 45")
    cut = 20 * 16 * 4 - (20 + 16) * 16 + 4 * 64 / 3
    assert e.size[2] == pytest.approx(9.0, abs=1e-6)
    assert glb_volume(m) == pytest.approx(20 * 16 * 5 + cut, rel=REL)


def test_sides_not_given_stay_vertical_and_named_sides_pick_their_edges():
    _, only_front = envelope("normal, 15, 5, 45")
    m_back, _ = envelope("normal, 15, 0, 90, back_base=5, back_angle=45")
    assert glb_volume(m_back) == pytest.approx(20 * 16 * 15 - 20 * 10 ** 2 / 2, rel=REL)
    m_left, _ = envelope("normal, 15, 0, 90, left_base=5, left_angle=45")
    assert glb_volume(m_left) == pytest.approx(20 * 16 * 15 - 16 * 10 ** 2 / 2, rel=REL)
    # angle 0: flat at the base height over the whole lot
    m0, e0 = envelope("normal, 15, 3, 0")
    assert e0.size[2] == pytest.approx(3.0, abs=1e-6)
    assert glb_volume(m0) == pytest.approx(20 * 16 * 3, rel=REL)


def test_non_convex_lot_is_watertight():
    ell = [(0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (8.0, 8.0), (8.0, 16.0), (0.0, 16.0)]
    m, _ = envelope("normal, 12, 3, 60, 3, 60, 3, 60, 3, 60", lot=ell)
    assert 0 < glb_volume(m) < (20 * 8 + 8 * 8) * 12


def test_bad_arguments_are_located_errors():
    for args, msg in (("normal, 15, -1, 45", "base height"), ("normal, 15, 5, 120", r"\[0, 90\]"),
                      ("normal, 0, 5, 45", "max height")):
        with pytest.raises(DerivationError, match=msg) as e:
            envelope(args)
        assert e.value.span is not None and e.value.span.line == 1
    with pytest.raises(GrammarError):
        envelope("sideways, 15, 5, 45")
    with pytest.raises(DerivationError, match="needs a face"):
        grammarkit.derive("Lot --> extrude(3) envelope(normal, 15, 5, 45) E.\n", lot=LOT)
    with pytest.raises(DerivationError, match="not horizontal"):
        grammarkit.derive("Lot --> extrude(3) comp(f) { front: envelope(worldUp, 2, 1, 45) E. }\n", lot=LOT)
