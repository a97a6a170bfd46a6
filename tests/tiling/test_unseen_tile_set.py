"""Issue 28 acceptance on a tile set made for this test alone (none of grammars/tiling's):
square plates with canals (grooves), walls (ridges), a sluice where a wall crosses a canal and
a wall's dead end. `learn`'s defaults, from 6 generated tilings, must accept a held-out tiling
of another size (also turned off the world axes and cut to a notched outline) and reject every
corruption of it: a rotated tile, a wrong direction, an unseen pair, a hole, a floating,
squashed or overlapping tile."""

from __future__ import annotations

import importlib.util
import sys

import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from _tiling_helpers import EXAMPLES  # noqa: E402

_spec = importlib.util.spec_from_file_location(
    "foreign_sets_unseen", EXAMPLES / "wfc" / "foreign_sets.py"
)
F = importlib.util.module_from_spec(_spec)
sys.modules["foreign_sets_unseen"] = F
_spec.loader.exec_module(F)

CANALS = F.TileSet(
    "canals",
    (
        F.Tile("Field", ("0", "0", "0", "0"), 3.0),
        F.Tile("Canal", ("2", "0", "2", "0"), 1.5),
        F.Tile("Elbow", ("2", "2", "0", "0"), 1.0),
        F.Tile("Wall", ("1", "0", "1", "0"), 1.0),
        F.Tile("Sluice", ("2", "1", "2", "1"), 0.4),
        F.Tile("End", ("1", "0", "0", "0"), 0.6),
    ),
    "square",
)


@pytest.fixture
def canals(monkeypatch):
    monkeypatch.setitem(F.SETS, "canals", CANALS)
    monkeypatch.setitem(
        F.TRAIN, "canals", [(5, 5), (6, 4), (4, 6), (6, 6), (7, 5), (5, 6)]
    )
    monkeypatch.setitem(F.HELD, "canals", [(8, 5)])
    return "canals"


def test_learned_defaults_accept_held_out_and_reject_every_corruption(canals, tmp_path):
    r = F.acceptance(canals, tmp_path, per_kind=1)
    assert (r["valid"], r["turned"], r["notched"]) == ([1, 1], [1, 1], [1, 1]), r[
        "failures"
    ]
    checked = {k: r[k] for k in F.KINDS if r[k][1]}
    assert {"rotated", "direction", "unseen pair", "hole"} <= set(checked), checked
    assert all(bad == n for bad, n in checked.values()), (checked, r["failures"])
