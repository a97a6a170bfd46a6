"""docs/retarget.md: its Python and shell examples run as written (in a scratch folder)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "retarget.md").read_text(encoding="utf-8")


def blocks(lang: str) -> list[str]:
    return [m.group(3) for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", DOC, re.S)
            if not m.group(1) and m.group(2) == lang]


def test_shell_examples_run(tmp_path):
    lines = [line for block in blocks("") for line in block.strip().splitlines()]
    assert any(line.startswith("grammarkit retarget") for line in lines)
    for line in lines:
        argv = line.split()
        if argv[0] == "grammarkit":
            argv = [sys.executable, "-m", "grammarkit", *argv[1:]]
        else:
            assert argv[:2] == ["python", "-m"], line
            argv = [sys.executable, *argv[1:]]
        res = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, (line, res.stderr)
    assert (tmp_path / "out" / "wide_shelf.glb").exists()
    assert (tmp_path / "out" / "wide_shelf_explain.png").exists()


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
