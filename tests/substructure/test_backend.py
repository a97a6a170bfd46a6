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


@pytest.fixture(scope="module")
def adapting(tmp_path_factory):
    """The castle with its rescaled types declared deformable: what the substructure search
    needs to adapt parts (`repair=true`, greedy rescaling along z). With the shipped castle
    grammar every part must stay a rigid copy, and no castle embedding stands on the ground."""
    import shutil

    folder = tmp_path_factory.mktemp("deformable_castle")
    for f in CASTLE.glob("*.glb"):
        shutil.copy(f, folder / f.name)
    text = GRAMMAR.read_text() + "constraint deformable(Gate)\nconstraint deformable(Tower)\nconstraint deformable(Wall)\n"
    (folder / "castle.grammar").write_text(text)
    return folder / "castle.grammar"


ADAPT = SubstructureOptions(repair=True)


@pytest.fixture(scope="module")
def written(tmp_path_factory, adapting):
    out = tmp_path_factory.mktemp("subs") / "variants"
    summary = run_backend(load(adapting), out=out, backend="substructure", n=4, seed=7, workers=1, options=ADAPT)
    return out, summary, adapting


def test_derive_writes_new_valid_watertight_variants(written):
    out, summary, grammar = written
    files = sorted(out.glob("variant_*.glb"))
    assert len(files) == 4
    rules = rules_from_grammar(load(grammar))
    for f in files:
        asm = read_assembly(f)
        assert validate(rules, asm).ok
        assert all(p.mesh.is_watertight and p.mesh.is_volume for p in asm.parts)
    rows = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    assert [r["id"] for r in rows] == [f.stem for f in files]
    assert all(r["parents"] and "operation" in r for r in rows)
    # the rescaled parts are declared (the grammar) and reported (the manifest); the shipped,
    # rigid castle grammar rejects them
    assert any(r["metrics"]["repaired"] for r in rows)
    shipped = rules_from_grammar(load(GRAMMAR))
    repaired = [f for f, r in zip(files, rows) if r["metrics"]["repaired"]]
    assert all("rigid" in {v.rule for v in validate(shipped, read_assembly(f)).violations} for f in repaired)


def test_cli_validate_accepts_the_variants(written):
    out, _, grammar = written
    r = gk("validate", grammar, *sorted(out.glob("variant_*.glb")))
    assert r.returncode == 0, r.stdout + r.stderr


def test_same_seed_same_files(written, tmp_path):
    out, _, grammar = written
    again = tmp_path / "again"
    run_backend(load(grammar), out=again, backend="substructure", n=4, seed=7, workers=1, options=ADAPT)
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

    g = load(ROOT / "grammars" / "tiling" / "balltrack" / "balltrack.grammar")
    one = run_backend(g, out=tmp_path / "one", backend="substructure", n=3, seed=3, workers=1)
    with LocalExecutor(2, parallel="always") as ex:
        two = run_backend(g, out=tmp_path / "two", backend="substructure", n=3, seed=3, executor=ex)
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
