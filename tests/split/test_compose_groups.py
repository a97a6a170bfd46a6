"""The final boolean unites groups of solids whose bounding boxes touch on their own and composes
the groups side by side (grammarkit/split/model.py): the same solid as one union of everything."""
from __future__ import annotations

from pathlib import Path

import pytest

import grammarkit
from grammarkit.split import model as split_model

LOT = [(0.0, 0.0), (40.0, 0.0), (40.0, 10.0), (0.0, 10.0)]
# 20 kiosks 1 m apart, each with a recessed window, and one long wall made of touching parts
TEXT = ("Lot --> split(y) { 4: split(x) { { 1: extrude(3) comp(f) { front: split(x) { ~1: W. | 0.5: recess(0.2) G. "
        "| ~1: W. } | volume: K. } | 1: NIL }* } | 2: NIL | ~1: split(x) { { 2: extrude(4) Wall. }* } }\n")


def test_grouped_union_equals_the_single_union(monkeypatch):
    calls = []
    real = split_model._compose_groups
    monkeypatch.setattr(split_model, "_compose_groups", lambda *a: calls.append(len(a[2])) or real(*a))
    grouped = grammarkit.derive(TEXT, lot=LOT)
    assert calls == [21]  # 20 kiosks and the wall, each united on its own
    monkeypatch.setattr(split_model, "MIN_GROUPED", 10 ** 9)  # force one union of everything
    single = grammarkit.derive(TEXT, lot=LOT)
    assert grouped.manifold.volume() == pytest.approx(single.manifold.volume(), rel=1e-9)
    assert len(grouped.manifold.decompose()) == len(single.manifold.decompose()) == 21
    assert grouped.mesh.is_watertight and single.mesh.is_watertight
    assert sorted(grouped.mesh.area_faces.round(9)) == pytest.approx(sorted(single.mesh.area_faces.round(9)))
    # the recess cuts reached their kiosks: the tags of the cut faces are there in both
    assert (grouped.triangle_tags >= 0).all()
    assert sorted(grouped.face_labels()) == sorted(single.face_labels())


def test_groups_are_found_by_touching_boxes():
    import manifold3d

    cube = manifold3d.Manifold.cube((1.0, 1.0, 1.0))
    solids = [cube, cube.translate((1.0, 0, 0)), cube.translate((3.0, 0, 0)), cube.translate((2.0, 0, 0)),
              cube.translate((10.0, 0, 0))]
    # 0-1 touch, 1-3 touch, 3-2 touch: one chain; the fifth apart
    assert split_model._disjoint_groups(solids) == [[0, 1, 2, 3], [4]]


def test_a_connected_building_takes_the_single_union(monkeypatch):
    calls = []
    monkeypatch.setattr(split_model, "_disjoint_groups", lambda *a: calls.append(1) or [[0]])
    m = grammarkit.derive(Path(__file__).resolve().parents[2] / "grammars" / "paris.grammar")
    assert calls == [] and m.mesh.is_watertight  # no gap along an axis, fewer than 256 solids
