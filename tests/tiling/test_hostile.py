"""Issue 28, hostile round: inputs built apart from the project's (tests/tiling/_hostile_sets.py):
a triangle tile set with road sockets (turns of 120 degrees, up and down triangles, six
triangles meeting at every corner), stacked blocks with cantilevered ledges, and a chiral
part at quarter turns and mirrored."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import _hostile_sets as H  # noqa: E402

from grammarkit.dsl import load  # noqa: E402
from grammarkit.printer import print_grammar  # noqa: E402
from grammarkit.tiling import learn, rules_from_grammar, shape_graph, validate, write_assembly  # noqa: E402


@pytest.mark.xfail(strict=True, reason="issue 28 open defect: a contact is read at the centre of the two "
                   "bounding boxes' intersection, off the corner two triangles share (fix drafted, it "
                   "changed the hex set's learned sites; see the tiling helper's report)")
def test_triangles_meeting_at_a_corner_are_a_corner_contact_at_that_corner():
    # the contact was read at the centre of the two bounding boxes' intersection, 0.43 from
    # the corner they share, so it fell on a face site and a valid held-out tiling was rejected
    from grammarkit.tiling.sitegeom import contact_geometry
    from grammarkit.tiling.validate import _Shape

    grid = {(0, 0, 0): ("Bend", 1), (0, 1, 0): ("Bend", 0)}  # two up triangles, one above the other's apex
    a = H.triangle_tiling(grid, "pair")
    g = shape_graph(a)
    assert g.number_of_edges() == 1
    shape = _Shape(a, g)
    rules = rules_from_grammar(learn([a], name="pair", constraints=False))
    points, _, corner = contact_geometry(rules, shape, np.arange(1))
    apex = H.triangle_pose((0, 0, 0), 0)[:3, 3] + [0, 1 / H.SQ3, 0]
    assert corner[0] and np.allclose(points[0][:2], apex[:2], atol=1e-6), points


@pytest.mark.xfail(strict=True, reason="issue 28 open defect: a contact is read at the centre of the two "
                   "bounding boxes' intersection, off the corner two triangles share (fix drafted, it "
                   "changed the hex set's learned sites; see the tiling helper's report)")
def test_learned_triangle_tiles_accept_held_out_tilings_and_reject_broken_ones(tmp_path):
    grids = [H.triangle_grid(4 + i % 3, 3 + i % 2, i) for i in range(6)]
    assert not any(H.triangle_socket_errors(g) for g in grids)
    files = [write_assembly(H.triangle_tiling(g, f"tri{i}"), tmp_path / f"tri{i}.glb") for i, g in enumerate(grids)]
    (tmp_path / "tri.grammar").write_text(print_grammar(learn(files, name="tri")))
    rules = rules_from_grammar(load(tmp_path / "tri.grammar"))
    held = H.triangle_grid(5, 4, 101)  # the seed whose corner contact was read on a face site
    assert validate(rules, H.triangle_tiling(held, "held")).ok
    inner = H.interior_cells(held)
    hole = validate(rules, H.triangle_tiling(held, "hole", edits={inner[2]: None}))
    assert not hole.ok and all(v.part_id or v.rule.startswith("constraint") for v in hole.violations)
    chiral = next(c for c in inner if held[c][0] in ("End", "Bend"))
    turned = dict(held)
    turned[chiral] = (held[chiral][0], (held[chiral][1] + 1) % 3)
    assert H.triangle_socket_errors(turned)
    assert not validate(rules, H.triangle_tiling(turned, "turned")).ok


def test_cantilevers_learn_their_longest_run_and_a_longer_one_is_named():
    train = [H.stack([3, 2, 4], [(0, 1, 2), (2, 3, 1)], "s0"), H.stack([2, 3], [(1, 0, 2)], "s1"),
             H.stack([1, 2, 2, 3], [(3, 2, 1), (1, 0, 1)], "s2")]
    g = learn(train, name="stack")
    assert "max_span=2" in print_grammar(g)
    assert validate(g, H.stack([4, 1, 2], [(0, 3, 2), (2, 1, 1)], "held")).ok
    r = validate(g, H.stack([4, 1, 2], [(0, 3, 3)], "span3"))
    assert not r.ok and "max_span=2" in r.format() and "Ledge.2" in r.format(), r.format()
    lifted = validate(g, H.stack([2, 2], [(0, 1, 1)], "lifted", lift={"Block.3": (0, 0, 0.3)}))
    assert any(v.part_id == "Block.3" for v in lifted.violations) and "Block.3" in lifted.format()


def test_a_chiral_part_at_quarter_turns_is_accepted_and_its_mirror_image_is_not():
    g = learn([H.pinwheel(4, "pw0"), H.pinwheel(3, "pw1", turns=(90, 270, 0))], name="pw")
    assert validate(g, H.pinwheel(5, "held", turns=(180, 0, 270, 90))).ok
    r = validate(g, H.pinwheel(4, "mirrored", mirror_one=2))
    assert [(v.rule, v.part_id) for v in r.violations] == [("mirrored", "Ell.2")], r.format()
