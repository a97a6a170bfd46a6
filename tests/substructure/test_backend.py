"""The back end, the Python API and the `substructures` command on the real examples."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from grammarkit.dsl import load
from grammarkit.run import run_backend
from grammarkit.tiling import read_assembly, rules_from_grammar, validate
from grammarkit_substructure import substructure
from grammarkit_substructure.options import SubstructureOptions

ROOT = Path(__file__).resolve().parents[2]
CASTLE = ROOT / "grammars" / "tiling" / "castle"
GRAMMAR = CASTLE / "castle.grammar"


def gk(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "grammarkit", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def castle():
    return read_assembly(CASTLE / "castle_small.glb"), rules_from_grammar(load(GRAMMAR))


def test_python_api_enumerate_and_apply(castle):
    asm, rules = castle
    ops = substructure.enumerate(asm, rules)
    assert len(ops) > 50
    applied = 0
    for op in ops[:40]:
        try:
            out = substructure.apply(asm, op, rules=rules)
        except Exception as exc:  # an embedding the grammar rejects: a ShapeError naming the rule
            assert type(exc).__name__ == "ShapeError" and "invalid shape" in str(exc)
            continue
        applied += 1
        assert len(out) == len(asm) - len(op.removed) + len(op.copied)
        assert validate(rules, out).ok
        assert all(p.mesh.is_watertight for p in out.parts)
    assert applied >= 10


def test_non_rigid_embedding_keeps_parts_watertight(castle):
    asm, rules = castle
    ops = substructure.enumerate(asm, rules)
    op = next(o for o in ops if len(o.pairs) >= 2)
    out = substructure.apply(asm, op, embedding="non-rigid")
    assert all(p.mesh.is_watertight for p in out.parts)


# rigid castles within the examples' counts are few (a ring of rigid walls: mostly where the
# gates sit), so the search is bounded: 40 candidates in a row with nothing new end it
BOUNDED = SubstructureOptions(patience=40)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The shipped castle grammar (parts rigid) with the back end's defaults."""
    out = tmp_path_factory.mktemp("subs") / "variants"
    summary = run_backend(load(GRAMMAR), out=out, backend="substructure", n=2, seed=0, workers=1, options=BOUNDED)
    return out, summary, GRAMMAR


def test_derive_writes_new_valid_rigid_castles_within_the_examples_counts(written):
    from grammarkit.tiling import example_count_ranges, load_examples

    out, summary, grammar = written
    files = sorted(out.glob("variant_*.glb"))
    assert len(files) == 2, summary.stats
    g = load(grammar)
    rules = rules_from_grammar(g)
    ranges = example_count_ranges(load_examples(g))
    assert ranges == {"Gate": (1, 2), "Tower": (6, 9), "Wall": (13, 22)}
    for f in files:
        asm = read_assembly(f)
        assert validate(rules, asm).ok  # the rigid-part check included: no part rescaled
        assert all(p.mesh.is_watertight and p.mesh.is_volume for p in asm.parts)
        have = example_count_ranges([asm], list(ranges))
        assert all(lo <= have[t][0] <= hi for t, (lo, hi) in ranges.items()), (f.name, have)
    rows = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    assert [r["id"] for r in rows] == [f.stem for f in files]
    assert all(r["parents"] and "operation" in r for r in rows)
    assert not any(r["metrics"]["repaired"] for r in rows)


def test_the_papers_centre_frames_sink_a_gate_and_only_repair_saves_it(castle):
    """With the boundary frames at the contact's centre (the paper's), a gate put where a
    shorter wall met a tower sinks below the ground; the greedy rescaling can stand it on the
    ground again, and the result is then no rigid copy. At the contact's foot (the default) the
    same operation needs no repair."""
    from grammarkit.errors import ShapeError

    asm, rules = castle
    ops = [op for op in substructure.enumerate(asm, rules)
           if len(op.removed) == 1 and len(op.copied) == 1
           and asm.parts[op.removed[0]].type == "Wall" and asm.parts[op.copied[0]].type == "Gate"]
    assert ops
    feet = 0
    for op in ops:
        try:
            substructure.apply(asm, op, rules=rules, repair=False)
            feet += 1
        except ShapeError:
            continue
        with pytest.raises(ShapeError, match="Gate"):  # sunk: off the ground, its site undocked
            substructure.apply(asm, op, rules=rules, repair=False, frame_origin="centre")
        try:
            fixed = substructure.apply(asm, op, rules=rules, repair=True, frame_origin="centre")
        except ShapeError:
            continue
        assert fixed.meta["substructure"]["repaired"]
        assert "rigid" in {v.rule for v in validate(rules, fixed).violations}
    assert feet >= 1
    with pytest.raises(ValueError, match="frame_origin"):
        substructure.apply(asm, ops[0], rules=rules, frame_origin="middle")


def test_counts_grammar_lets_variants_leave_the_examples_range():
    from grammarkit_substructure.backend import count_target
    from grammarkit_substructure.shape import Shape

    track = read_assembly(ROOT / "grammars" / "tiling" / "balltrack" / "track_short.glb")
    longer = read_assembly(ROOT / "grammars" / "tiling" / "balltrack" / "track_long.glb")
    shapes = [Shape.from_assembly(track), Shape.from_assembly(longer)]
    assert count_target(shapes, "grammar") is None
    assert count_target(shapes[:1], "examples") is None  # one example gives no range
    target = count_target(shapes, "examples")
    assert target["Pillar"] == (6, 15) and target["Entry"] == (1, 1)
    from grammarkit_substructure.backend import _counts_fit

    assert _counts_fit(target, shapes[0]) and _counts_fit(None, shapes[0])
    two_entries = Shape.from_assembly(longer)
    two_entries.types = two_entries.types + ["Entry"]
    assert not _counts_fit(target, two_entries)  # 2 entries: the examples have 1


def test_cli_validate_accepts_the_variants(written):
    out, _, grammar = written
    r = gk("validate", grammar, *sorted(out.glob("variant_*.glb")))
    assert r.returncode == 0, r.stdout + r.stderr


def test_same_seed_same_files(written, tmp_path):
    out, _, grammar = written
    again = tmp_path / "again"
    run_backend(load(grammar), out=again, backend="substructure", n=2, seed=0, workers=1, options=BOUNDED)
    for f in sorted(out.glob("variant_*.glb")):
        assert (again / f.name).read_bytes() == f.read_bytes()


def test_substructures_command_json_and_pictures(tmp_path):
    r = gk("substructures", CASTLE / "castle_small.glb", "--grammar", GRAMMAR, "--json", "--limit", "3",
           "--pictures", tmp_path / "pics")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["operations_total"] > 50 and len(data["operations"]) == 3
    op = data["operations"][0]
    assert {"removed", "copied", "cut_removed", "cut_copied", "boundary", "recursive"} <= set(op)
    assert len(list((tmp_path / "pics").glob("*.png"))) == 3
    text = gk("substructures", CASTLE / "castle_small.glb", "--limit", "2")
    assert text.returncode == 0 and text.stdout.count("\n") == 2 and "operation(s)" in text.stderr


def test_a_shape_without_substructure_says_so(tmp_path):
    import trimesh

    from grammarkit.tiling import Assembly, Part, write_assembly

    parts = []
    for k, t in enumerate("AB"):  # two different parts: nothing to exchange
        m = trimesh.creation.box(extents=(1, 1, 1))
        m.apply_translation([k, 0, 0])
        parts.append(Part(f"{t}.0", t, m))
    path = write_assembly(Assembly(parts, name="row"), tmp_path / "row.glb")
    r = gk("substructures", path)
    assert r.returncode == 0 and "no replaceable substructure" in r.stderr and "Traceback" not in r.stderr


def test_options_out_of_range_are_located_errors(tmp_path):
    r = gk("derive", GRAMMAR, "--backend", "substructure", "-n", "1", "--option", "q=7", "-o", tmp_path / "x")
    assert r.returncode != 0 and "q" in r.stderr and "Traceback" not in r.stderr
    r = gk("substructures", CASTLE / "castle_small.glb", "--q", "9")
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert not (tmp_path / "x").exists()


def test_backend_is_registered():
    r = gk("plugins")
    assert "substructure" in r.stdout and "substructures" in r.stdout


def test_derive_from_examples_without_substructure_is_a_clear_error(tmp_path):
    import trimesh

    from grammarkit.tiling import Assembly, Part, write_assembly

    parts = []
    for k, t in enumerate("AB"):
        m = trimesh.creation.box(extents=(1, 1, 1))
        m.apply_translation([k, 0, 0.5])
        parts.append(Part(f"{t}.0", t, m))
    write_assembly(Assembly(parts, name="pair"), tmp_path / "pair.glb")
    (tmp_path / "pair.grammar").write_text(
        "grammar pair\n\npart A = box(1, 1, 1)\npart B = box(1, 1, 1)\n\nneighbors A: {B}\nneighbors B: {A}\n\nexample pair = assembly(\"pair.glb\")\n")
    r = gk("derive", tmp_path / "pair.grammar", "--backend", "substructure", "-n", "2", "-o", tmp_path / "out")
    assert r.returncode != 0 and "no replaceable substructure" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "out").exists()


def test_results_do_not_depend_on_the_number_of_workers(tmp_path):
    from grammarkit.run.executor import LocalExecutor

    # tries=16: the same 16 candidates (a batch, split over both workers) and 3 variants as
    # with the default 64, for a fifth of the embeddings
    g = load(ROOT / "grammars" / "tiling" / "balltrack" / "balltrack.grammar")
    opts = {"tries": 16}
    one = run_backend(g, out=tmp_path / "one", backend="substructure", n=3, seed=3, workers=1, options=opts)
    with LocalExecutor(2, parallel="always") as ex:
        two = run_backend(g, out=tmp_path / "two", backend="substructure", n=3, seed=3, executor=ex, options=opts)
    assert one.stats["candidates"] == two.stats["candidates"] > 3
    assert one.stats["embeddings_tried"] == two.stats["embeddings_tried"]
    files = sorted((tmp_path / "one").glob("variant_*.glb"))
    assert len(files) == 3
    for f in files:
        assert (tmp_path / "two" / f.name).read_bytes() == f.read_bytes()


def test_dummy_edges_option_on_an_example():
    track = read_assembly(ROOT / "grammars" / "tiling" / "balltrack" / "track_short.glb")
    ops0 = substructure.enumerate(track)
    ops1 = substructure.enumerate(track, q=1)
    assert ops1 and all(o.violations <= 1 for o in ops1)
    assert len(ops1) >= len(ops0) // 2
    with pytest.raises(ValueError):
        substructure.enumerate(track, q=5)


def test_a_short_run_says_where_its_shapes_went(tmp_path):
    # coast tilings within the examples' counts are the examples themselves or their turns:
    # the run writes nothing, and its shortfall says why (valid shapes outside the counts)
    g = load(ROOT / "grammars" / "tiling" / "wfc" / "coast.grammar")
    summary = run_backend(g, out=tmp_path / "v", backend="substructure", n=2, seed=0, workers=1,
                          options={"max_candidates": 4, "operations": 2, "tries": 8})
    assert summary.total == 0
    text = summary.shortfall
    assert "max_candidates (4) reached after 4 candidates" in text, text
    assert "embeddings tried" in text and "outside the examples'" in text and "counts=grammar" in text, text
