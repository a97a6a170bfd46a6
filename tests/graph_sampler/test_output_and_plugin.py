"""Written variants (GLB + manifest.jsonl) and the back end as the plugin manager sees it."""
import json

import pytest

from grammarkit.registry import DeriveRequest
from grammarkit.tiling import read_assembly, shape_graph, validate
from grammarkit_graph_sampler.plugin import write_variants
from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions


def test_backend_is_found_through_its_entry_point():
    from grammarkit.plugins import PluginManager

    pm = PluginManager()  # fresh: loads the entry points of group "grammarkit"
    spec = pm.backends()["graph-sampler"]
    assert spec.families == frozenset({"tiling"}) and "tiling" in spec.default_for
    assert pm.default_backend("tiling").name == "graph-sampler"
    assert spec.plugin == "graph-sampler" and callable(spec.derive)
    info = {i.name: i for i in pm.plugins()}["graph-sampler"]
    assert info.ok and info.provides["backend"] == ["graph-sampler"]


@pytest.fixture(scope="module")
def written(kit, tmp_path_factory):
    out = tmp_path_factory.mktemp("variants")
    calls = []

    def progress(description, total):
        calls.append(("bar", description, total))
        return lambda n=1, **fields: calls.append(("advance", n, fields))

    sampler = GraphSampler(rules=kit.rules(), examples=kit.examples(), seed=3, workers=1,
                           options=SamplerOptions(attempts_per_shape=64, min_attempts=256))
    summary = write_variants(sampler, DeriveRequest(out=out, n=8, iterations=3, seed=3, progress=progress))
    return out, summary, calls, kit


def test_every_written_variant_reads_back_valid_and_watertight(written):
    out, summary, _, kit = written
    records = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    assert len(records) == summary["variants"] == 8
    assert sorted(p.name for p in out.glob("*.glb")) == sorted(r["file"] for r in records)
    rules = kit.rules()
    for r in records:
        asm = read_assembly(out / r["file"])
        assert validate(rules, asm).ok
        assert all(p.mesh.is_watertight for p in asm.parts)
        # manifest: histogram and graph are those of the geometry read back
        assert asm.type_histogram() == r["histogram"]
        g = shape_graph(asm)
        assert {frozenset(e) for e in g.edges()} == {frozenset(e) for e in r["graph"]["edges"]}
        assert {n["id"]: n["type"] for n in r["graph"]["nodes"]} == {p.id: p.type for p in asm.parts}


def test_manifest_records_parents_and_the_operation(written):
    out, summary, _, _ = written
    records = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    known = {"example:grid22", "example:strip3"}
    for r in records:
        assert r["dedupe"] == "histogram" and r["seed"] == 3
        assert set(r["parents"]) <= known  # parents come first (examples or earlier variants)
        op = r["operation"]
        assert [op["donor"], op["recipient"]] == r["parents"]
        assert op["replaced"] and op["inserted"] and len(op["boundary"]) >= 3
        assert op["residual"] >= 0 and len(op["transform"]) == 4
        ids = {n["id"] for n in r["graph"]["nodes"]}
        assert set(op["inserted"].values()) <= ids
        assert all(b["variant"] in ids for b in op["boundary"])
        known.add(r["id"])
    json.dumps(summary)  # JSON-able
    assert summary["growth"][0] == {"iteration": 0, "shapes": 2, "new": 2}
    assert summary["growth"][-1]["shapes"] == 2 + summary["variants"]


def test_progress_reports_attempts_valid_and_new(written):
    _, summary, calls, _ = written
    bars = [c for c in calls if c[0] == "bar"]
    assert bars and bars[0][1].startswith("iteration 1/3")
    adv = [c for c in calls if c[0] == "advance"]
    assert sum(c[1] for c in adv) == summary["attempts"]
    assert {"attempts", "valid", "new"} <= set(adv[-1][2])
    assert adv[-1][2]["total_new"] == summary["variants"]


def test_output_path_that_is_a_file_is_an_error(kit, tmp_path):
    from grammarkit.errors import DerivationError

    f = tmp_path / "taken"
    f.write_text("x")
    sampler = GraphSampler(rules=kit.rules(), examples=kit.examples(), workers=1)
    with pytest.raises(DerivationError, match="not a folder"):
        write_variants(sampler, DeriveRequest(out=f, n=1))
