"""The default mode's closing solid stands only for faces that survive (issue 26, found on
pyprt's envelope2002 package on the L lot, 4.55 m off PyPRT): a volume consumed by comp(f)
whose selected faces all end in NIL, or whose surviving faces do not reach across it,
leaves no solid of its own; what survives is kept (as slabs), every output watertight, and
`surfaces="cga"` is unchanged (grammarkit/split/closings.py)."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import grammarkit
from grammarkit.geometry.closing import THICKNESS
from grammarkit.split import derive

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]
# a 2 m box on the right half, so that every model has something besides the probe volume
BESIDE = "Lot --> split(x) {{ 10: extrude(5) {probe} | ~1: extrude(2) Box. }}\n"


def model(probe: str, extra: str = "", surfaces: str = "solid"):
    return derive(grammarkit.parse(BESIDE.format(probe=probe) + extra), lot=LOT, surfaces=surfaces)


def watertight_glb(m, tmp_path) -> bool:
    back = trimesh.load(m.save(tmp_path / "m.glb"), force="mesh")
    return bool(back.is_watertight and back.is_winding_consistent)


def bounds(m) -> np.ndarray:
    pts = [m.mesh.vertices]
    if m.surface_triangle_count:
        pts.append(m.surface_vertices)
    v = np.vstack(pts)
    return np.array([v.min(0), v.max(0)])


def test_every_selected_face_deleted_leaves_no_solid(tmp_path):
    m = model("comp(f) { bottom: Gone }", "Gone --> NIL\n")
    assert bounds(m)[1][2] == pytest.approx(2.0, abs=0.01)  # the 5 m volume is gone, as in CGA
    assert m.mesh.volume == pytest.approx(10 * 12 * 2, rel=0.01)
    assert "closing" not in {t.role for t in m.tags if m.face_labels().count(t.name)}
    assert watertight_glb(m, tmp_path)
    cga = model("comp(f) { bottom: Gone }", "Gone --> NIL\n", surfaces="cga")
    assert bounds(cga)[1][2] == pytest.approx(2.0, abs=0.01)


def test_only_what_survives_is_kept_when_it_does_not_span_the_volume(tmp_path):
    # envelope2002's pattern: the bottom face of a 5 m volume extruded into a 0.3 m slab
    m = model("comp(f) { bottom: extrude(0.3) Slab. }")
    lo, hi = bounds(m)
    assert hi[2] == pytest.approx(2.0, abs=0.01) and lo[2] == pytest.approx(-0.3, abs=0.01)
    assert m.mesh.volume == pytest.approx(10 * 12 * 0.3 + 10 * 12 * 2, rel=0.01)
    assert watertight_glb(m, tmp_path)
    # the front face alone survives: a slab of the documented thickness, not the 5 m volume
    m = model("comp(f) { front: Front. | top: NIL }")
    inside = m.mesh.contains([[5.0, THICKNESS / 2, 2.5], [5.0, 6.0, 2.5], [5.0, 3 * THICKNESS, 2.5]])
    assert inside.tolist() == [True, False, False]  # in the slab; not in the 5 m volume
    assert bounds(m)[1][2] == pytest.approx(5.0, abs=0.01)
    assert watertight_glb(m, tmp_path)


def test_faces_that_reach_across_keep_the_closing_solid(tmp_path):
    # the facades span the volume (top and bottom dropped): the closed 5 m box stays
    m = model("comp(f) { side: Wall. | top: NIL }")
    assert bounds(m)[1][2] == pytest.approx(5.0, abs=0.01)
    assert m.mesh.volume == pytest.approx(10 * 12 * 5 + 10 * 12 * 2, rel=0.01)
    assert {t.name: t.role for t in m.tags}["Lot"] == "closing"
    assert watertight_glb(m, tmp_path)
    # split into tiles, with some deleted: what survives still reaches across
    m = model("comp(f) { side: Facade }", "Facade --> split(x) { ~1: Wall. | ~1: NIL | ~1: Wall. }\n")
    assert bounds(m)[1][2] == pytest.approx(5.0, abs=0.01)
    assert m.mesh.volume == pytest.approx(10 * 12 * 5 + 10 * 12 * 2, rel=0.01)
