"""One run path (issue 25): the command line's one-model derive, `--variations`, `-n`, `batch`
(lots and variations) and the Python API all go through `grammarkit.run.run_backend` and return
its `RunSummary`; a `--set` value travels from the click command to the written file in at most
8 calls."""
from __future__ import annotations

import inspect
from pathlib import Path

import pytest
from click.testing import CliRunner

import grammarkit.run.api as api
import grammarkit.run.writer as writer
from grammarkit.cli import main
from grammarkit.run import RunSummary, run_backend

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"
GRAMMAR = "attr h = 3 @range(1, 30)\nLot --> extrude(h) Mass.\n"


@pytest.fixture
def calls(monkeypatch):
    """Every call of run_backend, with what it returned."""
    seen: list[tuple[dict, object]] = []
    real = api.run_backend

    def spy(*args, **kwargs):
        summary = real(*args, **kwargs)
        seen.append((kwargs, summary))
        return summary

    monkeypatch.setattr(api, "run_backend", spy)
    return seen


def test_cli_one_model_variations_n_and_the_api_share_one_function_and_summary(tmp_path, calls):
    grammar = tmp_path / "g.grammar"
    grammar.write_text(GRAMMAR)
    for args in (["-o", str(tmp_path / "one.glb")],
                 ["-o", str(tmp_path / "var"), "--variations", "2", "--workers", "1"],
                 ["-o", str(tmp_path / "n"), "-n", "2", "--workers", "1"]):
        r = CliRunner().invoke(main, ["derive", str(grammar), *args])
        assert r.exit_code == 0, r.output
    summary = api.run_backend(grammar, out=tmp_path / "api", n=2, workers=1)
    kinds = [type(s) for _, s in calls]
    assert len(calls) == 4 and set(kinds) == {RunSummary}, kinds
    assert isinstance(calls[0][0]["out"], writer.ModelFile)  # one model: the same writer
    assert summary.written == 2 and run_backend is not api.run_backend  # the package's name, spied


def test_batch_lots_and_variations_take_the_same_function_and_summary(tmp_path, calls):
    import json

    from grammarkit.run.batch import run_batch

    grammar = tmp_path / "g.grammar"
    grammar.write_text(GRAMMAR)
    lots = tmp_path / "lots.geojson"
    ring = [[0, 0], [9, 0], [9, 7], [0, 7], [0, 0]]
    lots.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "a"},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))
    for args in (["--lots", str(lots)], ["--variations", "2"]):
        r = CliRunner().invoke(main, ["batch", str(grammar), "-o", str(tmp_path / args[0][2:]),
                                      "--workers", "1", *args])
        assert r.exit_code == 0, r.output
    summary = run_batch(grammar, 2, tmp_path / "api", workers=1)
    assert [type(s) for _, s in calls] == [RunSummary] * 3
    assert [kw["backend"] for kw, _ in calls] == ["split"] * 3  # the split back end's one driver
    assert [s.kind for _, s in calls] == ["lots", "variations", "variations"]
    assert summary.ok == 2 and (tmp_path / "api" / "index.jsonl").exists()


def test_a_set_value_reaches_the_written_file_in_at_most_8_calls(tmp_path, monkeypatch):
    grammar = tmp_path / "g.grammar"
    grammar.write_text(GRAMMAR)
    depths: list[int] = []
    real = writer.write_files

    def measured(files):
        frames = [f.function for f in inspect.stack()]
        # frames[0] is this function (write_files' stand-in); count up to the click callback
        depths.append(frames.index("derive") if "derive" in frames else 99)
        return real(files)

    monkeypatch.setattr(writer, "write_files", measured)
    out = tmp_path / "a.stl"
    r = CliRunner().invoke(main, ["derive", str(grammar), "-o", str(out), "--set", "h=17"])
    assert r.exit_code == 0, r.output
    assert depths and depths[0] <= 8, depths
    # the value did travel: the box is 17 high in the written file
    import trimesh

    mesh = trimesh.load(out)
    assert mesh.bounds[1][2] - mesh.bounds[0][2] == pytest.approx(17, abs=0.01)
