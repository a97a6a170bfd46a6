"""Generalisation on tile sets built independently of the project's (grammars/tiling/wfc/
foreign_sets.py): square plates whose diagonal neighbours touch along an edge (with a chiral
tile), hexagonal plates (turns of 60 degrees), and a stacked town under gravity (bridges held
sideways, one spire). Tilings come from a backtracking generator, every one judged first by an
independent checker that reads only the geometry and the tile set's rules; `learn`'s defaults
must accept held-out tilings (other sizes and seeds, also turned by 30 degrees off the world
axes) and reject every corruption (rotated, direction, unseen pair, hole, floating, squashed,
mirrored, count, span). `benchmarks/bench_wfc.py --foreign` prints the full matrix."""
from __future__ import annotations

import importlib.util
import math
import sys

import numpy as np
import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from _tiling_helpers import EXAMPLES  # noqa: E402

_spec = importlib.util.spec_from_file_location("foreign_sets", EXAMPLES / "wfc" / "foreign_sets.py")
F = importlib.util.module_from_spec(_spec)
sys.modules["foreign_sets"] = F
_spec.loader.exec_module(F)


def test_generator_is_deterministic_and_the_checker_judges_geometry():
    for name in ("roads", "hexes"):
        ts = F.SETS[name]
        g = F.backtrack(ts, (5, 4), 3)
        assert g == F.backtrack(ts, (5, 4), 3) and not F.socket_violations(ts, g)
        assert not F.check(name, F.tiling(ts, g, "t"))
        assert not F.check(name, F.tiling(ts, g, "t", 30.0, (2.0, 1.0, 0.0)))
        cs = F.corrupt(name, g, 0, 1)
        for kind in ("rotated", "direction", "unseen pair", "hole", "floating", "squashed"):
            assert cs[kind] and all(F.check(name, a) for a in cs[kind]), (name, kind)
    t = F.town((6, 4), 2)
    assert not F.check("town", F.town_assembly(t, "t")) and not F.check("town", F.town_assembly(t, "t", 30.0))
    cs = F.corrupt("town", t, 0, 1)
    for kind in ("floating", "squashed", "hole", "count", "span"):
        assert cs[kind] and all(F.check("town", a) for a in cs[kind]), kind


def test_tile_geometry_has_its_sockets_symmetry():
    from grammarkit.tiling.orientation import turn_order

    for name in ("roads", "hexes"):
        ts = F.SETS[name]
        for i, t in enumerate(ts.tiles):
            turns = sum(t.turned(k) == t.turned(0) for k in range(ts.n_dirs))
            mesh = F.tile_mesh(name, i)
            centre = (mesh.vertices.max(axis=0) + mesh.vertices.min(axis=0)) / 2
            assert mesh.is_watertight and turn_order(mesh.vertices, centre, (0, 0, 1)) == turns, (name, t.name)


@pytest.mark.parametrize("name", ["roads", "hexes", "town"])
def test_learned_defaults_generalise_to_foreign_sets(name, tmp_path):
    r = F.acceptance(name, tmp_path, held_out=1, per_kind=1)
    assert r["valid"] == [1, 1] and r["turned"] == [1, 1], r["failures"]
    for kind in F.KINDS:
        assert r[kind][0] == r[kind][1], (kind, r["failures"])
    assert sum(r[k][1] for k in F.KINDS) >= 6


def test_learned_from_tilings_turned_off_the_axes(tmp_path):
    # the examples themselves turned by 11, 28, ... degrees: sites, docks and holes learned
    # along the parts' own axes, so an unturned held-out tiling is still accepted
    r = F.acceptance("roads", tmp_path, held_out=1, per_kind=1, train=4, turn_train=True)
    assert r["valid"] == [1, 1] and r["turned"] == [1, 1], r["failures"]
    assert r["hole"][0] == r["hole"][1] >= 1 and r["rotated"][0] == r["rotated"][1] >= 1


def test_a_turned_outline_has_no_false_holes():
    # a tile on the border of a tiling turned by 30 degrees: its outer side opens outside
    from grammarkit.tiling.holes import Footprint

    ts = F.ROADS
    g = {c: 0 for c in ts.cells((3, 3))}
    a = F.tiling(ts, g, "grass", 30.0)
    lo = np.array([p.mesh.bounds[0] for p in a.parts])
    hi = np.array([p.mesh.bounds[1] for p in a.parts])
    fp = Footprint(lo, hi, 2, 1e-3, [p.mesh for p in a.parts])
    boxes = Footprint(lo, hi, 2, 1e-3)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    # just outside the middle of the patch's south side (turned), and the patch's centre
    outside = np.array([[c * 1.5 + s * 0.15, s * 1.5 - c * 0.15, 0.1]])
    centre = np.array([[c * 1.5 - s * 1.5, s * 1.5 + c * 1.5, 0.1]])
    assert fp.inside(centre)[0] and not fp.inside(outside)[0]
    assert boxes.inside(outside)[0]  # bounding rectangles reach past a turned tile's side
