"""run_batch (the Python API of `grammarkit batch`): a building per lot with per-lot failures
recorded, datasets of variations with renders and an index pandas reads, resume, fail-fast,
merge, and the same files whatever the executor and the number of workers."""
from __future__ import annotations

import io
import json

import pytest
import trimesh
from PIL import Image

from _batch_helpers import (BLOCK, ROOT, TINY, feature, grid_lots, item_files, listed, rect,
                            without_timing, write_lots)
from grammarkit.errors import GrammarkitError
from grammarkit.run import RunMismatch
from grammarkit.run.batch import BatchFailed, run_batch
from grammarkit.run.executor import LocalExecutor


def mixed_lots(path):
    """Good lots and one of each kind of bad lot."""
    return write_lots(path, [
        feature(rect(0, 0, 12, 9), "good-1"),
        feature([(20, 0), (30, 10), (30, 0), (20, 10)], "bowtie"),
        feature(rect(40, 0, 30, 30), "court", holes=[[(50, 10), (50, 20), (60, 20), (60, 10)]]),
        feature(rect(80, 0, 12, 9), "too-tall", attrs={"h": 100}),
        feature([(100, 0), (114, 0), (114, 8), (106, 14), (100, 8)], "good-2", seed=11),
        feature(rect(120, 0, 0.5, 0.5), "sliver"),
    ])


def test_a_building_per_lot_with_failures_recorded_per_lot(tmp_path):
    lots = mixed_lots(tmp_path / "lots.geojson")
    out = tmp_path / "city"
    summary = run_batch(TINY, lots, out, workers=1, merge=tmp_path / "city.glb")
    assert (summary.requested, summary.ok, summary.failed, summary.written) == (6, 2, 4, 6)
    entries = {e["id"]: e for e in listed(out)}
    assert [e["id"] for e in listed(out)] == ["good-1", "bowtie", "court", "too-tall", "good-2", "sliver"]
    good = entries["good-2"]
    assert good["status"] == "ok" and good["seed"] == 11 and good["file"] == "good-2.glb"
    assert good["metrics"]["triangles"] > 0 and good["metrics"]["seconds"] > 0
    assert good["lot"] == "good-2" and good["feature"] == 4 and good["area_m2"] == pytest.approx(154.0)
    assert good["attrs"]["h"] == 6 and good["error"] is None
    assert "self-intersecting" in entries["bowtie"]["error"]
    assert "hole" in entries["court"]["error"]
    assert "is degenerate" in entries["sliver"]["error"]
    # a derive that fails in the worker names the attr's declaration in the grammar
    assert entries["too-tall"]["error"].startswith(f"lot 'too-tall': {TINY}:4:1: attr 'h' = 100 is "
                                                   "outside its range [3, 12]")
    for e in entries.values():
        if e["status"] == "failed":
            assert e["file"] is None and not (out / f"{e['id']}.glb").exists()
    # each building reads back watertight (grammarkit's reader, and trimesh welding by position)
    from grammarkit.geometry.meshio import face_labels, load_mesh

    for name in ("good-1.glb", "good-2.glb"):
        assert load_mesh(out / name, single=True).is_watertight
        mesh = trimesh.load(out / name).to_mesh()
        welded = trimesh.Trimesh(mesh.vertices, mesh.faces)
        assert welded.is_watertight and welded.body_count == 1
    # the merged city: both buildings where their lots are, a solid per item, labels kept
    city = load_mesh(tmp_path / "city.glb")
    assert sorted(city.geometry) == ["good-1", "good-2"]
    assert all(g.is_watertight for g in city.geometry.values())
    whole = load_mesh(tmp_path / "city.glb", single=True)
    assert whole.body_count == 2 and whole.bounds[1][0] == pytest.approx(114, abs=0.01)
    labels = face_labels(tmp_path / "city.glb")
    assert labels == face_labels(out / "good-1.glb") + face_labels(out / "good-2.glb")
    t = trimesh.load(tmp_path / "city.glb").to_mesh()
    assert trimesh.Trimesh(t.vertices, t.faces).body_count == 2
    assert summary.merged == tmp_path / "city.glb"


def test_the_same_files_whatever_the_executor_and_workers(tmp_path, dask_executor):
    lots = grid_lots(tmp_path / "lots.geojson", 10)
    runs = {
        "local-1": dict(executor=LocalExecutor(1, parallel="never")),
        "local-2": dict(executor=LocalExecutor(2, parallel="always")),
        "dask-2": dict(executor=dask_executor),
    }
    got = {}
    for name, kw in runs.items():
        out = tmp_path / name
        run_batch(TINY, lots, out, seed=5, render="sketch", render_size=48, **kw)
        got[name] = (item_files(out), without_timing(listed(out)))
    files, manifest = got["local-1"]
    assert len(files) == 20
    for name in ("local-2", "dask-2"):
        assert got[name][1] == manifest, name
        assert got[name][0].keys() == files.keys(), name
        assert all(got[name][0][k] == files[k] for k in files), name


def test_variations_make_a_dataset_that_pandas_and_torch_style_loaders_read(tmp_path):
    out = tmp_path / "ds"
    summary = run_batch(TINY, 8, out, seed=2, render=("sketch", "shaded"), render_size=64,
                        workers=1)
    assert summary.ok == 8 and summary.kind == "variations"
    rows = [json.loads(line) for line in (out / "index.jsonl").read_text().splitlines()]
    assert [r["id"] for r in rows] == [f"tiny_{i:06d}" for i in range(8)]
    meta = json.loads((out / "dataset.json").read_text())
    names = [c["name"] for c in meta["attr_vector"]]
    assert names == ["h", "roof_deg", "wall=#ddccbb", "wall=#c8b8a0"]
    assert meta["renders"]["camera"]["pitch"] == 30 and meta["renders"]["size"] == 64
    for r in rows:
        h, deg, w1, w2 = r["attr_vector"]
        assert r["attr_mask"] == [1, 1, 1, 1]
        assert h == pytest.approx((r["attr.h"] - 3) / 9) and 0 <= h <= 1
        assert deg == pytest.approx((r["attr.roof_deg"] - 20) / 25)
        assert (w1, w2) == ((1.0, 0.0) if r["attr.wall"] == "#ddccbb" else (0.0, 1.0))
        for style in ("sketch", "shaded"):
            image = Image.open(out / r[f"render_{style}"])
            assert image.size == (64, 64)
    assert len({r["attr.h"] for r in rows}) > 1, "attrs are sampled"
    assert len({r["seed"] for r in rows}) == 8
    sketch = Image.open(out / rows[0]["render_sketch"]).convert("L")
    assert sketch.getextrema()[0] < 100  # strokes were drawn
    pd = pytest.importorskip("pandas")
    df = pd.read_json(out / "index.jsonl", lines=True)
    assert len(df) == 8 and list(df["status"].unique()) == ["ok"]
    assert len(df["attr_vector"][0]) == 4


def test_parquet_index_loads_with_pandas(tmp_path):
    pytest.importorskip("pyarrow")  # the optional [parquet] extra
    pd = pytest.importorskip("pandas")
    out = tmp_path / "ds"
    run_batch(TINY, 4, out, index="parquet", workers=1)
    df = pd.read_parquet(out / "index.parquet")
    js = pd.read_json(out / "index.jsonl", lines=True)
    assert list(df["id"]) == list(js["id"]) and list(df["attr.h"]) == list(js["attr.h"])
    exact = [json.loads(x)["attr_vector"] for x in (out / "index.jsonl").read_text().splitlines()]
    assert [list(v) for v in df["attr_vector"]] == exact


def test_default_attrs_vary_the_seed_only(tmp_path):
    out = tmp_path / "ds"
    run_batch(TINY, 3, out, seed=10, sample=False, attrs={"h": 4}, workers=1)
    entries = listed(out)
    assert [e["seed"] for e in entries] == [10, 11, 12]
    assert {e["attrs"]["h"] for e in entries} == {4}


def test_fail_fast_stops_at_the_first_failure_without_recording_it(tmp_path):
    lots = mixed_lots(tmp_path / "lots.geojson")
    out = tmp_path / "city"
    with pytest.raises(BatchFailed, match=r"lot 'bowtie'.*self-intersecting.*--fail-fast; 1 items"):
        run_batch(TINY, lots, out, workers=1, fail_fast=True)
    assert [e["id"] for e in listed(out)] == ["good-1"]
    # the same batch without --fail-fast continues and records the failures
    summary = run_batch(TINY, lots, out, workers=1)
    assert summary.resumed == 1 and summary.written == 5 and summary.failed == 4


def test_a_resumed_batch_does_not_redo_finished_items(tmp_path):
    out = tmp_path / "ds"
    first = run_batch(TINY, 3, out, seed=1, workers=1)
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.glb")}
    more = run_batch(TINY, 5, out, seed=1, workers=1)  # a larger N extends the run
    assert (first.written, more.resumed, more.written) == (3, 3, 2)
    assert all((out / n).stat().st_mtime_ns == t for n, t in stamps.items())
    again = run_batch(TINY, 5, out, seed=1, workers=1)
    assert again.written == 0 and again.resumed == 5 and (out / "index.jsonl").exists()
    with pytest.raises(RunMismatch, match="seed"):
        run_batch(TINY, 5, out, seed=2, workers=1)
    with pytest.raises(GrammarkitError, match="holds 5 items of this run, more than the 4"):
        run_batch(TINY, 4, out, seed=1, workers=1)


def test_a_changed_lots_file_is_another_run(tmp_path):
    lots = grid_lots(tmp_path / "lots.geojson", 2)
    out = tmp_path / "city"
    run_batch(TINY, lots, out, workers=1)
    grid_lots(lots, 3)
    with pytest.raises(RunMismatch, match="lots="):
        run_batch(TINY, lots, out, workers=1)
    summary = run_batch(TINY, lots, out, workers=1, overwrite=True)
    assert summary.written == 3 and len(listed(out)) == 3


def test_a_grammar_that_replaces_the_lot_is_warned_about(tmp_path):
    lots = write_lots(tmp_path / "lots.geojson", [feature(rect(0, 0, 20, 14), "a")])
    summary = run_batch(ROOT / "grammars" / "paris.grammar", lots, tmp_path / "out", workers=1,
                        limits={"max_triangles": 200_000})
    assert summary.ok == 1
    assert any("paris.grammar:17:9: the axiom rule 'Lot' starts with footprint()" in w
               for w in summary.warnings)
    block = run_batch(BLOCK, lots, tmp_path / "block", workers=1)
    assert block.ok == 1 and not block.warnings


def test_limits_fail_items_not_the_batch(tmp_path):
    out = tmp_path / "ds"
    summary = run_batch(TINY, 3, out, workers=1, limits={"max_triangles": 8})
    entries = listed(out)
    assert summary.failed == 3 and summary.ok == 0
    assert all("triangle" in e["error"] for e in entries), entries[0]["error"]


@pytest.mark.parametrize("kw,words", [
    (dict(render="pencil"), "unknown render style 'pencil'"),
    (dict(render_size=4), "render size must be"),
    (dict(format="xyz"), "unknown output format 'xyz'"),
    (dict(index="csv"), "index must be 'jsonl' or 'parquet'"),
    (dict(attrs={"h": 99}), "attr 'h' = 99 is outside its range"),
    (dict(attrs={"nope": 1}), "unknown attr 'nope'"),
    (dict(limits={"max_cows": 1}), "limits:"),
])
def test_bad_arguments_are_refused_before_any_work(tmp_path, kw, words):
    with pytest.raises(GrammarkitError, match=words):
        run_batch(TINY, 2, tmp_path / "out", workers=1, **kw)
    assert not (tmp_path / "out").exists()


def test_sampled_attrs_are_for_variations_only(tmp_path):
    lots = grid_lots(tmp_path / "lots.geojson", 1)
    with pytest.raises(GrammarkitError, match="apply to --variations"):
        run_batch(TINY, lots, tmp_path / "out", sample=True)


def test_the_merged_file_may_not_replace_an_item_and_is_a_glb(tmp_path):
    lots = write_lots(tmp_path / "lots.geojson", [feature(rect(0, 0, 9, 9), "city")])
    with pytest.raises(GrammarkitError, match="--merge would overwrite an item's file"):
        run_batch(TINY, lots, tmp_path / "out", merge=tmp_path / "out" / "city.glb")
    with pytest.raises(GrammarkitError, match="use --format glb and a .glb name"):
        run_batch(TINY, lots, tmp_path / "out", merge=tmp_path / "city.obj")
    with pytest.raises(GrammarkitError, match="use --format glb and a .glb name"):
        run_batch(TINY, lots, tmp_path / "out", merge=tmp_path / "city.glb", format="obj")


def test_run_backend_runs_on_the_dask_executor(tmp_path, dask_executor):
    """What `grammarkit derive --executor dask` will do: the split back end, through the run
    layer, with its items derived on the Dask workers; the same files as locally."""
    from grammarkit.run import run_backend

    a = run_backend(TINY, out=tmp_path / "dask", n=4, seed=3, options={"variations": True},
                    executor=dask_executor)
    b = run_backend(TINY, out=tmp_path / "local", n=4, seed=3, options={"variations": True},
                    executor=LocalExecutor(1, parallel="never"))
    assert a.written == b.written == 4
    assert item_files(tmp_path / "dask") == item_files(tmp_path / "local")


def test_renders_are_pngs_of_the_model(tmp_path):
    out = tmp_path / "ds"
    run_batch(TINY, 1, out, render="shaded+lines,lines", render_size=80, workers=1)
    (entry,) = listed(out)
    assert entry["attachments"] == {"shaded+lines.png": "tiny_000000.shaded+lines.png",
                                    "lines.png": "tiny_000000.lines.png"}
    shaded = Image.open(io.BytesIO((out / "tiny_000000.shaded+lines.png").read_bytes()))
    assert shaded.size == (80, 80) and len(shaded.convert("RGB").getcolors(maxcolors=100000)) > 4


def test_merging_refuses_files_it_cannot_merge_exactly(tmp_path):
    from grammarkit.run.merge import MergeError, merge_glb

    foreign = tmp_path / "foreign.glb"
    foreign.write_bytes(trimesh.creation.box().export(file_type="glb"))
    with pytest.raises(MergeError, match="not a GLB written by this grammarkit"):
        merge_glb([("a", foreign)], tmp_path / "m.glb")
    broken = tmp_path / "broken.glb"
    broken.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(MergeError, match="broken.glb: not a readable GLB file"):
        merge_glb([("a", broken)], tmp_path / "m.glb")
    assert not (tmp_path / "m.glb").exists()


def test_lots_choose_snippets_for_their_anchors(tmp_path):
    lots = write_lots(tmp_path / "lots.geojson", [
        feature(rect(0, 0, 14, 10), "flat", choices={"Roof": "roof_flat"}),
        feature(rect(30, 0, 14, 10), "wrong", choices={"Roof": "facade_grid"}),
        feature(rect(60, 0, 14, 10), "plain")])
    summary = run_batch(BLOCK, lots, tmp_path / "out", workers=1)
    flat, wrong, plain = listed(tmp_path / "out")
    assert summary.ok == 2
    assert flat["bindings"]["Roof"] == "roof_flat" and plain["bindings"]["Roof"] == "roof_hip"
    assert "snippet 'facade_grid' is of object type 'Facade'" in wrong["error"]


def test_a_time_budget_stops_resumably_and_progress_is_reported(tmp_path):
    from grammarkit.errors import LimitError

    out = tmp_path / "ds"
    seen = []
    with pytest.raises(LimitError, match=r"time budget \(--timeout 0.001 s\) is spent after \d+ of 20"):
        run_batch(TINY, 20, out, workers=1, timeout=0.001,
                  progress=lambda done, total, entry: seen.append((done, total, entry and entry["id"])))
    done = len(listed(out))
    assert 1 <= done < 20
    assert seen[0] == (0, 20, None) and seen[-1][0] == done
    summary = run_batch(TINY, 20, out, workers=1)
    assert summary.resumed == done and summary.written == 20 - done
