"""docs/retarget.md: the Python example prints what the page says, and every option the page's
table lists exists. (tests/docs/test_docs_run.py runs every shell and Python block of the docs.)"""
from __future__ import annotations

import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "retarget.md").read_text(encoding="utf-8")


def blocks(lang: str) -> list[str]:
    return [m.group(3) for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", DOC, re.S)
            if not m.group(1) and m.group(2) == lang]


def test_python_examples_run(tmp_path, capsys):
    code = blocks("python")
    assert code
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        for block in code:
            exec(compile(block, "docs/retarget.md", "exec"), {})
    finally:
        os.chdir(old)
    out = capsys.readouterr().out
    assert "[3.39 0.35 1.93] True" in out and out.splitlines()[-1].endswith("True")


def test_every_documented_option_exists():
    from click.testing import CliRunner

    from grammarkit.cli import main

    help_text = CliRunner().invoke(main, ["retarget", "--help"]).output
    for option in re.findall(r"^\| `(--[a-z-]+|-o)", DOC, re.M):
        assert option in help_text, option
