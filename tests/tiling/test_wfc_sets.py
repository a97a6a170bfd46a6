"""Issue 28's acceptance on tile sets that are not the project's own: a grammar learned with
`learn`'s defaults from valid WFC tilings (grammars/tiling/wfc/wfc_sets.py: knots, circuit,
summer-style corner terrain, stacked 3D pipes; solved by WFC, written as GLB files, the
grammar printed and read back) accepts every held-out valid tiling (other sizes and seeds) and
rejects every tiling broken by one rotated tile, a reversed pair (wrong direction), an unseen
pair or a hole. Every corruption is first checked invalid by the tile set's own socket rules.
`benchmarks/bench_wfc.py` prints the full matrix (more held-out tilings and corruptions)."""
from __future__ import annotations

import importlib.util
import sys

import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from _tiling_helpers import EXAMPLES  # noqa: E402

_spec = importlib.util.spec_from_file_location("wfc_sets", EXAMPLES / "wfc" / "wfc_sets.py")
W = importlib.util.module_from_spec(_spec)
sys.modules["wfc_sets"] = W
_spec.loader.exec_module(W)


def test_the_solver_makes_valid_tilings_and_the_corruptions_break_the_rules():
    for ts in W.SETS.values():
        size = W.TRAINING_SIZES[ts.dims][0]
        grid = W.solve(ts, size, 3)
        assert len(grid) == __import__("math").prod(size) and not W.rule_violations(ts, grid)
        assert W.solve(ts, size, 3) == grid  # deterministic
        for kind, grids in W.corruptions(ts, grid, 0, 2).items():
            assert grids, (ts.name, kind)
            assert all(W.rule_violations(ts, g) for g in grids), (ts.name, kind)


def test_tile_geometry_has_the_sockets_symmetry():
    from grammarkit.tiling.orientation import turn_order

    for ts in W.SETS.values():
        for t in ts.tiles:
            turns = sum(t.turned(k) == t.turned(0) for k in range(4))
            mesh = W._tile_mesh(ts.name, ts.tiles.index(t))
            centre = (mesh.vertices.max(axis=0) + mesh.vertices.min(axis=0)) / 2
            assert turn_order(mesh.vertices, centre, (0, 0, 1)) % turns == 0, (ts.name, t.name)
            assert mesh.is_watertight, (ts.name, t.name)


@pytest.mark.parametrize("name", sorted(W.SETS))
def test_learned_defaults_accept_held_out_and_reject_every_corruption(name, tmp_path):
    r = W.acceptance(W.SETS[name], tmp_path, held_out=2, per_kind=1)
    assert r["accepted"][0] == r["accepted"][1] == 2, r["failures"]
    for kind in W.KINDS:
        rejected, total = r[kind]
        assert total >= 2 and rejected == total, (kind, r["failures"])


def test_observed_pairs_only_is_one_option_away_and_rejects_valid_tilings(tmp_path):
    # the knot set learned without socket classes allows only the site pairs its examples show
    r = W.acceptance(W.KNOTS, tmp_path, held_out=2, per_kind=1, sockets=False)
    assert r["accepted"][0] < r["accepted"][1]


def test_socket_classes_close_symmetric_sockets_and_keep_mirrored_ones_apart():
    from grammarkit.tiling.learn_sockets import socket_pairs, yaw_group

    # a symmetric socket: A.e meets B.w and itself, B.w meets C.n -> every two of them fit
    sym = {(u, v) for u, v, _ in socket_pairs([(("A", "e"), ("B", "w")), (("A", "e"), ("A", "e")),
                                              (("B", "w"), ("C", "n"))])}
    assert (("B", "w"), ("B", "w")) in sym and (("A", "e"), ("C", "n")) in sym
    # a socket and its mirror (bipartite): P.x meets Q.y and R.y; Q.y and R.y never meet each other
    mir = {(u, v) for u, v, _ in socket_pairs([(("P", "x"), ("Q", "y")), (("P", "x"), ("R", "y")),
                                              (("S", "x"), ("Q", "y"))])}
    assert (("R", "y"), ("S", "x")) in mir and (("Q", "y"), ("R", "y")) not in mir
    assert (("P", "x"), ("S", "x")) not in mir
    # sites no observed chain connects stay apart
    apart = {(u, v) for u, v, _ in socket_pairs([(("A", "e"), ("A", "e")), (("B", "w"), ("B", "w"))])}
    assert (("A", "e"), ("B", "w")) not in apart
    assert yaw_group([0.4, 89.6]) == [0.0, 90.0, 180.0, 270.0] and yaw_group([1.0]) == [0.0]


def test_the_learn_command_learns_socket_classes_unless_told_not_to(tmp_path):
    # the CLI's `--no-sockets` is the Python API's `sockets=False`: observed site pairs only
    from click.testing import CliRunner

    from grammarkit.cli import main
    from grammarkit.dsl import load
    from grammarkit.tiling import validate, write_assembly

    ts = W.KNOTS
    files = [str(write_assembly(W.tiling(ts, W.solve(ts, size, 10 + i), f"k{i}"), tmp_path / f"k{i}.glb"))
             for i, size in enumerate(W.TRAINING_SIZES[ts.dims])]
    held = W.tiling(ts, W.solve(ts, W.HELD_OUT_SIZES[ts.dims][0], 100), "held")
    verdicts = {}
    for flag in ([], ["--no-sockets"]):
        out = tmp_path / f"knots{len(flag)}.grammar"
        res = CliRunner().invoke(main, ["learn", *files, *flag, "-o", str(out)])
        assert res.exit_code == 0, res.output
        verdicts[bool(flag)] = validate(load(out), held).ok
    assert verdicts == {False: True, True: False}
