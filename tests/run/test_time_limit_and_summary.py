"""--time-limit (the graceful budget, INTERFACES.md item 4) on derive, batch and the Python API,
and what the commands print: a few lines for people by default, the summary as JSON with --json."""
from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit.run import run_backend
from grammarkit.run.api import iter_results
from grammarkit.run.batch import run_batch

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"
BOX = "Lot --> extrude(3) Mass.\n"


def box(tmp_path: Path) -> Path:
    path = tmp_path / "box.grammar"
    path.write_text(BOX)
    return path


def lines(folder: Path) -> list[dict]:
    return [json.loads(x) for x in (folder / "manifest.jsonl").read_text().splitlines()]


def test_a_spent_time_limit_keeps_what_was_made_and_says_why(tmp_path):
    # a limit that is spent as soon as the first model is made: exactly one result, reported
    summary = run_backend(box(tmp_path), out=tmp_path / "out", n=50, time_limit=1e-9, workers=1)
    assert summary.written == 1 and len(lines(tmp_path / "out")) == 1
    assert summary.shortfall == "the time limit (1e-09 s) was reached"
    assert "made 1 of 50: the time limit" in summary.lines()[-1]
    # the same command continues the run: the budget is per run, not per folder
    again = run_backend(box(tmp_path), out=tmp_path / "out", n=3, workers=1)
    assert again.resumed == 1 and again.written == 2 and again.shortfall is None


def test_without_a_limit_everything_is_made(tmp_path):
    summary = run_backend(box(tmp_path), out=tmp_path / "out", n=3, time_limit=3600, workers=1)
    assert summary.written == 3 and summary.shortfall is None


def test_iter_results_stops_at_the_time_limit():
    results = list(iter_results(BOX, n=20, time_limit=1e-9))
    assert len(results) < 20


def test_batch_time_limit(tmp_path):
    summary = run_batch(box(tmp_path), 40, tmp_path / "ds", workers=1, time_limit=1e-9)
    assert summary.ok < 40 and "the time limit (1e-09 s) was reached" in summary.shortfall
    assert (tmp_path / "ds" / "index.jsonl").exists()  # what was made is indexed
    assert len(lines(tmp_path / "ds")) == summary.ok


def test_derive_prints_lines_for_people_and_json_on_request(tmp_path):
    grammar = box(tmp_path)
    r = CliRunner().invoke(main, ["derive", str(grammar), "-n", "30", "-o", str(tmp_path / "a"),
                                  "--time-limit", "0.000001", "--workers", "1"])
    assert r.exit_code == 0, r.output
    out = r.stdout.splitlines()
    assert out[0].startswith("wrote ") and str(tmp_path / "a") in out[0]
    assert out[-1].startswith("made ") and "of 30: the time limit (1e-06 s) was reached" in out[-1]
    assert len(out) <= 4
    r = CliRunner().invoke(main, ["derive", str(grammar), "-n", "2", "-o", str(tmp_path / "b"),
                                  "--json", "--workers", "1"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["written"] == 2 and data["shortfall"] is None


def test_batch_prints_lines_for_people_and_json_on_request(tmp_path):
    grammar = box(tmp_path)
    r = CliRunner().invoke(main, ["batch", str(grammar), "--variations", "30", "-o", str(tmp_path / "a"),
                                  "--time-limit", "0.000001", "--workers", "1"])
    assert r.exit_code == 0, r.output
    out = r.stdout.splitlines()
    assert out[0].startswith("wrote ") and "manifest" in out[0]
    assert "of 30: the time limit (1e-06 s) was reached" in out[-1] and len(out) <= 5
    r = CliRunner().invoke(main, ["batch", str(grammar), "--variations", "2", "-o", str(tmp_path / "b"),
                                  "--json", "--workers", "1"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["ok"] == 2


def test_time_limit_must_be_positive(tmp_path):
    r = CliRunner().invoke(main, ["derive", str(box(tmp_path)), "-n", "2", "-o", str(tmp_path / "a"),
                                  "--time-limit", "0"])
    assert r.exit_code == 2 and "--time-limit" in r.output


def test_a_time_limit_shortfall_keeps_the_back_ends_own_account():
    # a back end that says where its candidates went (stats["shortfall"], e.g. the substructure
    # search's "n embeddings tried, k outside the examples' counts") keeps saying it when the
    # clock stopped the run; without one the time limit alone is the reason
    from grammarkit.ir import Grammar
    from grammarkit.run import Request
    from grammarkit.run.api import shortfall_reason

    spent = Request(grammar=Grammar.model_construct(), soft_deadline=0.0)
    account = {"shortfall": "12 embeddings tried, 3 outside the examples' counts"}
    assert shortfall_reason(spent, account, 90) == (
        "the time limit (90 s) was reached; 12 embeddings tried, 3 outside the examples' counts")
    assert shortfall_reason(spent, {}, 90) == "the time limit (90 s) was reached"
    assert shortfall_reason(Request(grammar=Grammar.model_construct()), account, None) == account["shortfall"]
