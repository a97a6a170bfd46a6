"""`grammarkit check`, `fmt` and `plugins` through click's runner."""
from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit.dsl import parse

DATA = Path(__file__).parent / "data"


def run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def test_check_ok_file_exits_0():
    r = run("check", str(DATA / "split_full.grammar"), str(DATA / "tiling_full.grammar"))
    assert r.exit_code == 0, r.output
    assert "0 errors, 0 warnings in 2 files" in r.output


def test_check_reports_every_problem_in_every_file(tmp_path):
    a = tmp_path / "a.grammar"
    a.write_text("Lot --> extrdue(3) Mass\nattr h = 50 @range(1, 9)\n")
    b = tmp_path / "b.grammar"
    b.write_text("A --> split(x) { 1: B |\n")
    r = run("check", str(a), str(b))
    assert r.exit_code == 1
    out = r.output
    assert f"{a}:1:9: error: unknown operation 'extrdue'" in out
    assert "did you mean 'extrude'?" in out
    assert f"{a}:1:20: warning: no rule 'Mass'" in out
    assert f"{a}:2:10: error: default of 'h' (50) is outside its @range(1, 9)" in out
    assert f"{b}:1:24: error: syntax error: unexpected end of file" in out
    assert "    Lot --> extrdue(3) Mass\n            ^~~~~~~~~~" in out  # source line and caret
    assert "expected one of:" in out
    assert "3 errors, 1 warning in 2 files" in out


def test_check_json_and_emit_ir(tmp_path):
    f = tmp_path / "a.grammar"
    f.write_text("Lot --> extrude(3) Mass\n")
    r = run("check", "--json", "--emit-ir", str(f))
    assert r.exit_code == 0
    data = json.loads(r.output)
    (entry,) = data["files"]
    assert entry["ok"] and data["errors"] == 0 and data["warnings"] == 1
    d = entry["diagnostics"][0]
    assert (d["severity"], d["line"], d["column"], d["code"]) == ("warning", 1, 20, "undefined-successor")
    from grammarkit.ir import Grammar
    assert Grammar.model_validate(entry["ir"]) == parse(f)
    r = run("check", "--emit-ir", str(f))
    assert Grammar.model_validate_json(r.stdout) == parse(f)


def test_check_bad_files_give_errors_not_tracebacks(tmp_path):
    bad = tmp_path / "bin.grammar"
    bad.write_bytes(b"A --> B\n\xff\xfe\n")
    r = run("check", str(bad), str(tmp_path / "missing.grammar"))
    assert r.exit_code == 1
    assert f"{bad}:2:1: error: file is not valid UTF-8" in r.output
    assert "cannot read" in r.output
    big = tmp_path / "big.grammar"
    big.write_text("A --> B\n" * 2000)
    r = run("check", "--max-size", "1000", str(big))
    assert r.exit_code == 1 and "too large" in r.output


def test_fmt_prints_checks_and_rewrites_atomically(tmp_path):
    f = tmp_path / "a.grammar"
    messy = "attr  h=3\nLot-->extrude( h )split(y){1:A|{~2:B}*}\n"
    f.write_text(messy)
    r = run("fmt", str(f))
    assert r.exit_code == 0
    assert r.output == "attr h = 3\n\nLot --> extrude(h) split(y) { 1: A | { ~2: B }* }\n"
    r = run("fmt", "--check", str(f))
    assert r.exit_code == 1 and "would reformat" in r.output
    assert f.read_text() == messy
    r = run("fmt", "--in-place", str(f))
    assert r.exit_code == 0
    assert f.read_text() == "attr h = 3\n\nLot --> extrude(h) split(y) { 1: A | { ~2: B }* }\n"
    assert run("fmt", "--check", str(f)).exit_code == 0
    assert [p.name for p in tmp_path.iterdir()] == ["a.grammar"]  # no temporary files left


def test_fmt_on_syntax_error_leaves_file_untouched(tmp_path):
    f = tmp_path / "a.grammar"
    f.write_text("A --> split(x) {\n")
    r = run("fmt", "--in-place", str(f))
    assert r.exit_code == 1 and "syntax error" in r.output
    assert f.read_text() == "A --> split(x) {\n"


def test_plugins_lists_builtin_plugins():
    r = run("plugins", "--json")
    assert r.exit_code == 0
    infos = {p["name"]: p for p in json.loads(r.output)}
    assert "split" in infos["split-operations"]["provides"]["operation"]
    assert "rand" in infos["core-functions"]["provides"]["function"]
    assert infos["split-operations"]["distribution"] == "grammarkit"
    r = run("plugins")
    assert r.exit_code == 0 and "split-operations" in r.output and "operation:" in r.output
