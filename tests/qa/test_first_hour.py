"""A new user's first mistakes (issue 32): each answered in the project's words, located, and
`--json` for machines on the one-model derive too."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit.cli.lang import FMT_SHOWN_ERRORS

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"


def invoke(*args) -> "click.testing.Result":  # noqa: F821 - the annotation is only text
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.mark.parametrize("typed, meant", [("derve", "derive"), ("chek", "check"), ("fmat", "fmt"),
                                          ("plugin", "plugins")])
def test_a_misspelled_command_names_the_nearest_one(typed, meant):
    res = invoke(typed, "x")
    assert res.exit_code == 2
    assert f"No such command '{typed}'. Did you mean '{meant}'" in res.output, res.output


def test_an_unknown_command_far_from_every_name_points_at_help():
    res = invoke("xyzzy")
    assert res.exit_code == 2 and "Did you mean" not in res.output
    assert "No such command 'xyzzy'" in res.output and "grammarkit --help" in res.output


def test_one_model_derive_prints_json_for_machines(tmp_path):
    out, png = tmp_path / "p.glb", tmp_path / "p.png"
    res = invoke("derive", PARIS, "-o", out, "--preview", png, "--json", "--seed", "3")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["files"] == {"model": str(out), "png": str(png)} and doc["seed"] == 3
    assert doc["format"] == "glb" and doc["metrics"]["triangles"] > 1000
    assert out.stat().st_size > 0 and png.stat().st_size > 0
    people = invoke("derive", PARIS, "-o", tmp_path / "q.glb")  # without --json: one line
    assert people.exit_code == 0 and people.stdout.startswith("wrote ") and people.stdout.count("\n") == 1


def test_fmt_of_a_file_that_is_not_a_grammar_shows_its_first_errors_and_a_count(tmp_path):
    notes = tmp_path / "notes.md"
    notes.write_text("".join(f"- item {i}, with words\n" for i in range(40)), encoding="utf-8")
    res = invoke("fmt", notes)
    assert res.exit_code == 1
    assert res.output.count(": error: ") == FMT_SHOWN_ERRORS, res.output
    assert "more errors not shown (is it a grammar file?)" in res.output
    assert f"grammarkit check {notes}" in res.output and "Traceback" not in res.output
    full = invoke("check", notes)  # check still lists every problem
    assert full.output.count(": error: ") > FMT_SHOWN_ERRORS
