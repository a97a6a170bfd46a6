import json
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from grammarkit.cli import main as cli
from grammarkit.dsl import load, parse
from grammarkit.printer import print_grammar
from grammarkit.tiling import (
    Assembly, learn, load_examples, read_assembly, rules_from_grammar, shape_graph, validate,
    write_assembly,
)

sys.path.insert(0, str(Path(__file__).parent))
from _tiling_helpers import EXAMPLES, box_part, lattice, load_make_examples  # noqa: E402

MK = load_make_examples()


@pytest.fixture(scope="module")
def castle_grammar():
    return load(EXAMPLES / "castle" / "castle.grammar")


def moved(asm: Assembly, pid: str, matrix: np.ndarray) -> Assembly:
    return Assembly([p.transformed(matrix) if p.id == pid else p for p in asm.parts], name=asm.name)


def translation(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def rules_of(report):
    return {(v.part_id, v.rule) for v in report.violations}


@pytest.mark.parametrize("name", ["castle", "balltrack", "facade"])
def test_committed_examples_validate(name):
    g = load(EXAMPLES / name / f"{name}.grammar")
    examples = load_examples(g)
    assert len(examples) == 2
    for asm in examples:
        report = validate(g, asm)
        assert report.ok, report.format()


def test_generator_is_deterministic_and_matches_committed_files():
    fresh = MK.castle("castle_small", 3, 2, {(0, 0, 1)})
    stored = read_assembly(EXAMPLES / "castle" / "castle_small.glb")
    assert [p.id for p in fresh.parts] == [p.id for p in stored.parts]
    for p, q in zip(fresh.parts, stored.parts):
        np.testing.assert_allclose(p.mesh.bounds, q.mesh.bounds, atol=1e-5)


def test_learn_print_parse_round_trip(tmp_path):
    asms = [read_assembly(EXAMPLES / "facade" / f) for f in ("facade_small.glb", "facade_large.glb")]
    g = learn(asms, name="facade", example_paths=["facade_small.glb", "facade_large.glb"],
              neighbors="multisets")
    text = print_grammar(g)
    again = parse(text)
    assert again == g
    assert print_grammar(again) == text
    kinds = [s.kind for s in g.statements]
    assert {"part", "neighbors", "dock", "constraint", "example"} <= set(kinds)
    # a learned grammar accepts its own examples (its mesh() files are relative to its folder)
    g = g.model_copy(update={"source_path": str(EXAMPLES / "facade" / "learned.grammar")})
    for a in asms:
        assert validate(g, a).ok


def test_learned_multisets_and_pairs_are_what_the_examples_show():
    a = MK.castle("c", 3, 2, {(0, 0, 1)})
    g = learn([a], name="c", neighbors="multisets", sockets=False)
    rules = rules_from_grammar(g)
    assert rules.neighbor_multisets["Gate"] == {("Tower", "Wall")}
    graph = shape_graph(a)
    observed = {tuple(sorted(graph.nodes[m]["type"] for m in graph.neighbors(n)))
                for n, d in graph.nodes(data=True) if d["type"] == "Tower"}
    assert rules.neighbor_multisets["Tower"] == observed
    assert rules.pairs == {("Gate", "Tower"), ("Gate", "Wall"), ("Tower", "Wall"), ("Wall", "Wall")}
    # one docking configuration per pair: symmetric towers and walls collapse to one cluster
    assert [len(d.placements) for d in g.docks] == [1, 1, 1, 1]
    # by default the sites' sockets generalise: a gate's end fits where a wall's end does
    # (walls meet walls), so two gates may meet end to end, though no example shows it
    g2 = learn([a], name="c", neighbors="multisets")
    assert rules_from_grammar(g2).pairs == rules.pairs | {("Gate", "Gate")}


def test_moved_tower_is_reported_with_its_id(castle_grammar):
    a = load_examples(castle_grammar)[0]
    r = validate(castle_grammar, moved(a, "Tower.1", translation(0.6, 0, 0)))
    assert not r.ok
    found = rules_of(r)
    # the gate on its -x side lost its tower; the walls on its +x side now sit too deep
    assert ("Gate.0", "neighbors") in found and ("Tower.1", "dock") in found
    v = next(v for v in r.violations if v.part_id == "Gate.0")
    assert v.part_type == "Gate" and v.observed == "{Wall}" and v.allowed == "{Tower, Wall}"


def test_interpenetrating_extra_part_is_reported(castle_grammar):
    a = load_examples(castle_grammar)[0]
    wall = a.by_id()["Wall.0"]
    tower = a.by_id()["Tower.0"]
    # a second tower dropped onto the middle of a wall segment
    extra = tower.transformed(translation(*(wall.centroid - tower.centroid) * [1, 1, 0]), new_id="Tower.99")
    r = validate(castle_grammar, Assembly([*a.parts, extra], name="bad"))
    assert not r.ok
    assert any(v.part_id == "Tower.99" or v.other_id == "Tower.99" for v in r.violations)
    assert {"dock", "neighbors"} & {v.rule for v in r.violations if "Tower.99" in (v.part_id, v.other_id)}


def test_misaligned_part_with_unchanged_graph_fails_the_dock_check():
    lat = lattice(3, 3, 1)
    g = learn([lat], name="lat", neighbors="multisets", holes=False)
    beam = next(p for p in lat.parts if p.type == "Beam")
    shifted = moved(lat, beam.id, translation(0, 0, 0.25))  # still touching both cubes
    assert {tuple(sorted(e)) for e in shape_graph(shifted).edges()} == {tuple(sorted(e)) for e in shape_graph(lat).edges()}
    r = validate(g, shifted)
    # the beam is off its docking placement; the cubes' sites it left read as open ("filled")
    rules = {v.rule for v in r.violations}
    assert "dock" in rules and rules <= {"dock", "constraint filled"}, r.format()
    assert any(beam.id in (v.part_id, v.other_id) for v in r.violations)
    assert validate(g, shifted, docks=False).ok


def test_extra_isolated_part_and_unknown_type(castle_grammar):
    a = load_examples(castle_grammar)[0]
    far = box_part("Tower.50", "Tower", (500, 500, 3))
    dragon = box_part("Dragon.0", "Dragon", (-500, 0, 0))
    r = validate(castle_grammar, Assembly([*a.parts, far, dragon], name="bad"))
    found = rules_of(r)
    assert ("Tower.50", "neighbors") in found
    assert ("Dragon.0", "unknown-type") in found
    assert any(v.rule == "constraint connected" and "Tower.50" in v.message for v in r.violations)
    json.dumps(r.to_json())  # JSON-able


def test_neighbor_count_rules_and_constraints_by_hand():
    text = """grammar towers
part Tower = box(2, 2, 6)
part Wall = box(4, 0.8, 3)
neighbors Tower: Wall in 1..2
neighbors Wall: Tower in 1..2, Wall in 0..1
dock Tower -- Wall
dock Wall -- Wall
constraint connected
constraint count(Tower, 2, 3)
constraint path(from=Tower, to=Wall)
example pair { Tower at (0, 0, 3); Wall at (3, 0, 1.5); Tower at (6, 0, 3) }
example bent { Tower at (0, 0, 3); Wall at (0, 3, 1.5) rot (0, 0, 90); Tower at (0, 6, 3) }
"""
    g = parse(text)
    exs = load_examples(g)
    assert [len(e) for e in exs] == [3, 3]
    for e in exs:
        assert validate(g, e).ok, validate(g, e).format()
    one = Assembly(exs[0].parts[:1], name="one")
    r = validate(g, one)
    assert {v.rule for v in r.violations} == {"neighbor-count", "constraint count", "constraint path"}
    assert r.violations[0].part_id == "Tower.0"


def test_grounded_and_downhill_path_on_the_ball_track():
    g = load(EXAMPLES / "balltrack" / "balltrack.grammar")
    track = load_examples(g)[0]
    assert validate(g, track).ok
    # lift the whole track off its pillars: not grounded any more
    lifted = Assembly([p.transformed(translation(0, 0, 5)) if p.type != "Pillar" else p for p in track.parts])
    assert any(v.rule == "constraint grounded" for v in validate(g, lifted, docks=False).violations)
    # a gap in the track: the entry cannot reach the exit
    ramp = next(p for p in track.parts if p.type == "Ramp")
    holed = Assembly([p for p in track.parts if p.id != ramp.id])
    rules = {v.rule for v in validate(g, holed).violations}
    assert "constraint path" in rules and "constraint connected" in rules


def test_downhill_path_rejects_climbing():
    from grammarkit.tiling.constraints import check_path
    a = Assembly([box_part("Entry.0", "Entry", (0, 0, 0)), box_part("Ramp.0", "Ramp", (1, 0, 0.5)),
                  box_part("Exit.0", "Exit", (2, 0, 1.0))])
    graph = shape_graph(a)
    assert check_path(graph, {"from": "Entry", "to": "Exit"}) == []
    assert "Entry.0" in check_path(graph, {"from": "Entry", "to": "Exit", "downhill": True})[0]


def test_cli_learn_and_validate(tmp_path):
    src = EXAMPLES / "castle"
    runner = CliRunner()
    out = tmp_path / "learned.grammar"
    res = runner.invoke(cli, ["learn", str(src / "castle_small.glb"), str(src / "castle_large.glb"), "-o", str(out),
                              "--neighbors", "multisets"])  # Kalojanov's exact rule, one option away
    assert res.exit_code == 0, res.output
    assert "neighbors Tower:" in out.read_text()
    res = runner.invoke(cli, ["validate", str(out)])  # the grammar's own (file) examples
    assert res.exit_code == 0 and res.output.count("OK") == 2, res.output
    bad = moved(read_assembly(src / "castle_small.glb"), "Tower.2", translation(0, 3, 0))
    write_assembly(bad, tmp_path / "bad.glb")
    res = runner.invoke(cli, ["validate", str(out), str(tmp_path / "bad.glb")])
    assert res.exit_code == 1 and "Tower.2" in res.output
    res = runner.invoke(cli, ["validate", str(out), str(tmp_path / "bad.glb"), "--json"])
    doc = json.loads(res.output)
    assert res.exit_code == 1 and doc["ok"] is False
    assert any(v["part_id"] == "Tower.2" for v in doc["violations"])
    res = runner.invoke(cli, ["validate", str(out), str(src / "castle.grammar")])
    assert res.exit_code == 1 and "not a mesh file" in res.output


def test_ten_thousand_parts_validate():
    big = lattice(14, 14, 13)  # 2,548 cubes + 7,098 beams = 9,646 parts
    assert len(big) > 9000
    g = learn([lattice(3, 3, 3)], name="lat")
    r = validate(g, big)
    assert r.ok, r.format()[:2000]
    assert r.contacts == 2 * sum(1 for p in big.parts if p.type == "Beam")


def test_hand_written_sites_give_docking_placements():
    text = """grammar towers
part Tower = box(2, 2, 6)
part Wall = box(4, 0.8, 3)
site Tower.side at (1, 0, -1.5) facing +x
site Wall.end at (2, 0, 0) facing +x mirror x
neighbors Tower: Wall in 1..4
neighbors Wall: Tower in 0..2, Wall in 0..1
dock Tower.side -- Wall.end
dock Wall.end -- Wall.end
example line { Tower at (0, 0, 3); Wall at (3, 0, 1.5); Wall at (7, 0, 1.5); Tower at (10, 0, 3) }
example corner { Tower at (0, 0, 3); Wall at (0, 3, 1.5) rot (0, 0, 90); Wall at (-3, 0, 1.5) rot (0, 0, 180) }
example raised { Tower at (0, 0, 3); Wall at (3, 0, 2.5) }
example sideways { Wall at (0, 0, 1.5); Wall at (4, 0.5, 1.5) }
"""
    g = parse(text)
    line, corner, raised, sideways = load_examples(g)
    # the square tower docks walls on any face (its symmetry), the wall at either end (mirror x)
    assert validate(g, line).ok and validate(g, corner).ok
    r = validate(g, raised)  # still touching, but 1 m too high for the sites to meet
    assert [(v.part_id, v.rule, v.other_id) for v in r.violations] == [("Tower.0", "dock", "Wall.0")]
    assert [v.rule for v in validate(g, sideways).violations] == ["dock"]
    assert validate(g, raised, docks=False).ok


def test_learning_is_deterministic_and_rules_pickle():
    import pickle

    asms = [read_assembly(EXAMPLES / "balltrack" / f) for f in ("track_short.glb", "track_long.glb")]
    texts = {print_grammar(learn(asms, name="b", example_paths=["a.glb", "b.glb"])) for _ in range(2)}
    assert len(texts) == 1
    rules = rules_from_grammar(load(EXAMPLES / "balltrack" / "balltrack.grammar"))
    again = pickle.loads(pickle.dumps(rules))
    assert again.to_json() == rules.to_json()
    assert ("path", {"from": "Entry", "to": "Exit", "downhill": True}) in [(n, a) for n, a, _ in again.constraints]
