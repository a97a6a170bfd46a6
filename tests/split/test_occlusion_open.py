"""Occlusion queries and open surfaces (issue 26, from a real rule set whose inserted windows
are open meshes): CGA tests only against closed geometry, so an open surface is never an
occluder; a queried open surface is tested by its geometry, as a face is. Never an internal
error (grammarkit/split/occlusion.py)."""
from __future__ import annotations

import grammarkit

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]
QUERIES = ('report("overlaps", overlaps()) report("touches", touches()) '
           'report("inside", inside())')


def answers(grammar: str, surfaces: str = "solid") -> dict[str, bool]:
    m = grammarkit.derive(grammar, lot=LOT, surfaces=surfaces)
    return {k: bool(m.reports[k]["sum"]) for k in ("overlaps", "touches", "inside")}


def test_an_open_mesh_is_never_an_occluder():
    # a pane (builtin:quad, an open mesh) at the bottom of the first 10 m; the probe's box sits
    # on it and a face lies in it: a closed occluder there would be touched / overlapped
    for probe in ("t(-4, 1, 0) s(2, 2, 0) extrude(2)", "t(-4, 1, 0) s(2, 2, 0)"):
        g = ('Lot --> split(x) { 10: extrude(4) i("builtin:quad") Pane. | ~1: Probe }\n'
             f"Probe --> {probe} {QUERIES} NIL\n")
        for mode in ("solid", "cga"):
            assert answers(g, mode) == {"overlaps": False, "touches": False, "inside": False}, (probe, mode)


def test_a_queried_open_mesh_is_tested_by_its_geometry():
    base = 'Lot --> split(x) { 10: extrude(5) W. | ~1: Probe }\n'
    # a pane inside the volume W: inside and overlapping
    g = base + f'Probe --> t(-8, 2, 1) s(3, 3, 2) i("builtin:quad") {QUERIES} NIL\n'
    assert answers(g) == {"overlaps": True, "touches": False, "inside": True}
    # a pane lying on W's side (x = 10): touching only
    g = base + ('Probe --> s(0.001, 4, 3) t(0, 2, 1) i("builtin:quad") rotateScope(0, -90, 0) '
                f"{QUERIES} NIL\n")
    m = grammarkit.derive(g, lot=LOT)
    assert {k: bool(m.reports[k]["sum"]) for k in ("overlaps", "touches", "inside")}["inside"] is False
    # a pane away from W: nothing
    g = base + f'Probe --> t(3, 2, 1) s(3, 3, 2) i("builtin:quad") {QUERIES} NIL\n'
    assert answers(g) == {"overlaps": False, "touches": False, "inside": False}


def test_a_facade_tile_queried_next_to_inserted_open_windows():
    # the shape of the real case (2OldHouse of a public rule set): facade tiles ask
    # `inside() || touches()` after windows (open meshes) were inserted on earlier tiles
    g = ("Lot --> extrude(6) comp(f) { side: Facade }\n"
         "Facade --> split(x) { { ~3: Tile }* }\n"
         "Tile --> case inside() || touches(): Wall. else: i(\"builtin:quad\") Window.\n")
    m = grammarkit.derive(g, lot=LOT)
    names = [p.name for p in m.parts]
    assert "Window" in names
