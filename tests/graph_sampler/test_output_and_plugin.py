"""The graph sampler through the run layer: variants written by the one writer (GLB +
manifest.jsonl), read back valid, and the back end as the plugin manager sees it."""
import json
from pathlib import Path

import pytest

from grammarkit.dsl import load
from grammarkit.run import run_backend
from grammarkit.tiling import read_assembly, shape_graph, validate

GRAMMAR = Path(__file__).parent / "data" / "minicastle.grammar"
# counts="grammar": the mini castle's two examples have nearly the same counts (test_counts.py
# tests the default)
OPTIONS = {"attempts_per_shape": 64, "min_attempts": 256, "counts": "grammar"}


def test_backend_is_found_through_its_entry_point():
    from grammarkit.plugins import PluginManager

    pm = PluginManager()  # fresh: loads the entry points of group "grammarkit"
    spec = pm.backends()["graph-sampler"]
    assert spec.families == frozenset({"tiling"}) and "tiling" in spec.default_for
    assert pm.default_backend("tiling").name == "graph-sampler"
    assert spec.plugin == "graph-sampler" and callable(spec.run)
    assert "tolerance" in spec.options.model_fields
    info = {i.name: i for i in pm.plugins()}["graph-sampler"]
    assert info.ok and info.provides["backend"] == ["graph-sampler"]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("variants") / "out"
    calls = []

    def progress(description, total):
        calls.append(("bar", description, total))
        return lambda n=1, **fields: calls.append(("advance", n, fields))

    summary = run_backend(GRAMMAR, out=out, n=5, iterations=3, seed=3, options=OPTIONS, workers=1,
                          progress=progress)
    return out, summary, calls


def records(out):
    return [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]


def test_every_written_variant_reads_back_valid_and_watertight(written):
    out, summary, _ = written
    recs = records(out)
    assert len(recs) == summary.written == 5 and summary.shortfall is None
    assert sorted(p.name for p in out.glob("*.glb")) == sorted(r["file"] for r in recs)
    grammar = load(GRAMMAR)
    for r in recs:
        asm = read_assembly(out / r["file"])
        assert validate(grammar, asm).ok
        assert all(p.mesh.is_watertight for p in asm.parts)
        # manifest: histogram and graph are those of the geometry read back
        assert asm.type_histogram() == r["histogram"]
        g = shape_graph(asm)
        assert {frozenset(e) for e in g.edges()} == {frozenset(e) for e in r["graph"]["edges"]}
        assert {n["id"]: n["type"] for n in r["graph"]["nodes"]} == {p.id: p.type for p in asm.parts}


def test_manifest_records_parents_and_the_operation(written):
    out, summary, _ = written
    known = {"example:strip2", "example:strip3"}
    for i, r in enumerate(records(out)):
        assert {"id", "index", "seed", "parents", "metrics", "file"} <= set(r)
        assert r["index"] == i and r["dedupe"] == "isomorphism" and r["seed"] == 3
        assert set(r["parents"]) <= known  # parents come first (examples or earlier variants)
        op = r["operation"]
        assert [op["donor"], op["recipient"]] == r["parents"]
        assert op["replaced"] and op["inserted"] and len(op["boundary"]) >= 3
        assert op["residual"] >= 0 and len(op["transform"]) == 4
        ids = {n["id"] for n in r["graph"]["nodes"]}
        assert set(op["inserted"].values()) <= ids
        assert all(b["variant"] in ids for b in op["boundary"])
        assert r["metrics"]["parts"] == len(ids)
        known.add(r["id"])
    stats = summary.stats
    json.dumps(summary.to_dict())  # JSON-able
    assert stats["growth"][0] == {"iteration": 0, "shapes": 2, "new": 2}
    assert stats["growth"][-1]["shapes"] >= 2 + summary.written


def test_progress_reports_attempts_valid_and_new(written):
    _, summary, calls = written
    bars = [c for c in calls if c[0] == "bar"]
    assert bars and bars[0][1].startswith("iteration 1/64")  # the cap: max(--iterations, max-iterations)
    adv = [c for c in calls if c[0] == "advance"]
    assert sum(c[1] for c in adv) == summary.stats["attempts"]
    assert {"attempts", "valid", "new"} <= set(adv[-1][2])


def test_an_interrupted_run_continues_to_the_same_files(written, tmp_path):
    out, _, _ = written
    part = tmp_path / "part"
    first = run_backend(GRAMMAR, out=part, n=3, iterations=3, seed=3, options=OPTIONS, workers=1)
    assert first.written == 3
    rest = run_backend(GRAMMAR, out=part, n=5, iterations=3, seed=3, options=OPTIONS, workers=1)
    assert rest.resumed == 3 and rest.written == 2
    assert (part / "manifest.jsonl").read_text() == (out / "manifest.jsonl").read_text()
    for f in out.glob("*.glb"):
        assert (part / f.name).read_bytes() == f.read_bytes()


def test_output_path_that_is_a_file_is_an_error(tmp_path):
    from grammarkit.errors import ShapeError

    f = tmp_path / "taken"
    f.write_text("x")
    with pytest.raises(ShapeError, match="is a file"):
        run_backend(GRAMMAR, out=f, n=1)
    assert f.read_text() == "x"
