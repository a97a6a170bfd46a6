"""`splitArea(axis) { area: A | ~area: B }*` (grammarkit/split/ops/area_split.py): split's sizes
(absolute, relative, floating, repeat groups) in area units; the parts' areas are exact on
non-rectangular faces."""
from __future__ import annotations

import io

import pytest

import grammarkit
from grammarkit.errors import DerivationError, GrammarError, LimitError

RECT = [(0.0, 0.0), (10.0, 0.0), (10.0, 6.0), (0.0, 6.0)]
TRAPEZOID = [(0.0, 0.0), (12.0, 0.0), (9.0, 6.0), (3.0, 6.0)]  # area 54
RULES = "".join(f'{n} --> report("{n}", geometry.area) extrude(1) {n}.\n' for n in "ABC")


def split(block: str, lot=TRAPEZOID):
    m = grammarkit.derive(f"Lot --> {block}\n{RULES}", lot=lot)
    return m, {k: (v["n"], v["min"], v["max"], v["sum"]) for k, v in m.reports.items()}


def test_absolute_floating_and_relative_areas():
    m, r = split("splitArea(x) { 12: A | ~1: B | '0.25: C }")
    assert r["A"][3] == pytest.approx(12.0, abs=1e-6)
    assert r["C"][3] == pytest.approx(0.25 * 54, abs=1e-6)
    assert r["B"][3] == pytest.approx(54 - 12 - 13.5, abs=1e-6)
    # the area left of x is x^2 up to x = 3 (the sloped left edge gives a width of 2x), then
    # 9 + 6 (x - 3): 12 is at x = 3.5, and 4 at x = 2 (the quadratic piece)
    a = next(p for p in m.parts if p.name == "A")
    assert a.size[0] == pytest.approx(3.5, abs=1e-6)
    m4, _ = split("splitArea(x) { 4: A | ~1: B }")
    assert next(p for p in m4.parts if p.name == "A").size[0] == pytest.approx(2.0, abs=1e-6)
    assert m.manifold.volume() == pytest.approx(54.0, rel=5e-3)  # solids are welded by 1 mm


def test_repeat_groups_follow_split_semantics():
    _, r = split("splitArea(y) { { ~10: A }* }")
    n, lo, hi, total = r["A"]
    assert n == 5 and lo == pytest.approx(10.8, abs=1e-6) and hi == pytest.approx(10.8, abs=1e-6)
    _, r = split("splitArea(x) { { 7: A | ~1: B }* | 5: C }")
    assert r["A"][0] == 6 and r["A"][1] == pytest.approx(7.0, abs=1e-6) and r["A"][2] == pytest.approx(7.0, abs=1e-6)
    assert r["B"][3] == pytest.approx(54 - 42 - 5, abs=1e-6) and r["C"][3] == pytest.approx(5.0, abs=1e-6)
    # CGA: the repeat group is made zero times when the fixed parts fill the face
    _, r = split("splitArea(x) { { ~10: A }* | 54: B }")
    assert "A" not in r and r["B"][3] == pytest.approx(54.0, abs=1e-6)


def test_no_adjust_scopes_tile_the_parent():
    m, r = split("splitArea(y, noAdjust) { 20: A | ~1: B }")
    a, b = (next(p for p in m.parts if p.name == n) for n in "AB")
    assert a.size[0] == pytest.approx(12.0) and b.size[0] == pytest.approx(12.0)  # the parent's width
    assert a.size[1] + b.size[1] == pytest.approx(6.0)
    assert r["A"][3] == pytest.approx(20.0, abs=1e-6)


def test_parts_are_watertight_solids():
    import trimesh

    from grammarkit.geometry.exporters import encode_glb

    m, _ = split("splitArea(x) { { ~9: A | 2: B }* }", lot=RECT)
    loaded = trimesh.load(io.BytesIO(encode_glb(m)), file_type="glb")
    mesh = loaded.to_mesh() if isinstance(loaded, trimesh.Scene) else loaded
    mesh = trimesh.Trimesh(mesh.vertices, mesh.faces)
    assert mesh.is_watertight and mesh.volume == pytest.approx(60.0, rel=5e-3)


def test_bad_input_is_located():
    with pytest.raises(DerivationError, match="needs a face") as e:
        grammarkit.derive("Lot --> extrude(2) splitArea(x) { 1: A. }\n", lot=RECT)
    assert e.value.span is not None and e.value.span.line == 1
    with pytest.raises(GrammarError) as e:
        grammarkit.derive("Lot --> splitArea(z) { 1: A. }\n", lot=RECT)
    assert e.value.span is not None
    with pytest.raises(LimitError, match="repeat limit"):
        grammarkit.derive("Lot --> splitArea(x) { { 0.0001: A. }* }\n", lot=RECT)
