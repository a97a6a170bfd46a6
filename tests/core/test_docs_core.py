"""docs/plugins.md, docs/operations.md and docs/language.md: their examples run as written."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ["plugins.md", "operations.md", "language.md"]


def blocks(doc: str, lang: str) -> list[str]:
    text = (ROOT / "docs" / doc).read_text(encoding="utf-8")
    return [m.group(3) for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", text, re.S)
            if not m.group(1) and m.group(2) == lang]


@pytest.mark.parametrize("doc", DOCS)
def test_python_examples_run(doc, capsys):
    old = os.getcwd()
    os.chdir(ROOT)
    try:
        for block in blocks(doc, "python"):
            exec(compile(block, f"docs/{doc}", "exec"), {"__name__": "docs_example"})
    finally:
        os.chdir(old)
    if doc == "plugins.md":
        out = capsys.readouterr().out.split("\n")
        assert "['Top'] 5.0" in out and "12" in out


def test_plugins_shell_example_runs():
    for block in blocks("plugins.md", ""):
        for line in block.strip().splitlines():
            args = line.split("#")[0].split()
            assert args[0] == "grammarkit"
            r = subprocess.run([sys.executable, "-m", "grammarkit", *args[1:]], capture_output=True,
                               text=True, cwd=ROOT, timeout=120)
            assert r.returncode == 0, r.stderr


def test_language_expression_table_matches_the_evaluator():
    from grammarkit.dsl import parse
    from grammarkit.errors import GrammarkitError
    from grammarkit.expr_eval import evaluate
    from grammarkit.functions import BUILTIN_FUNCTIONS

    functions = {f.name: f for f in BUILTIN_FUNCTIONS}
    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    table = text[text.index("### What the operators do"):text.index("An error is located")]
    rows = [r for r in table.splitlines() if r.startswith("| `")]
    assert len(rows) >= 8
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        exprs = re.findall(r"`([^`]+)`", cells[0])
        if cells[1] == "error":
            for e in exprs:
                with pytest.raises(GrammarkitError):
                    evaluate(parse(f"const v = {e}").consts[0].value, functions=functions)
        else:
            values = re.findall(r"`([^`]+)`", cells[1])
            for e, v in zip(exprs, values):
                got = evaluate(parse(f"const v = {e}").consts[0].value, functions=functions)
                assert got == evaluate(parse(f"const v = {v}").consts[0].value, functions=functions), (e, got)
