"""docs/cga.md: its Python and shell examples run as written."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "cga.md").read_text(encoding="utf-8")


def blocks(lang: str) -> list[str]:
    out = []
    for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", DOC, re.S):
        if not m.group(1) and m.group(2) == lang:
            out.append(m.group(3))
    return out


def test_python_examples_run(capsys):
    code = blocks("python")
    assert code
    old = os.getcwd()
    os.chdir(ROOT)
    try:
        for block in code:
            exec(compile(block, "docs/cga.md", "exec"), {})
    finally:
        os.chdir(old)
    out = capsys.readouterr().out
    assert "True 3 1" in out and "<string>:1:21: warning: not translated: copyUV()" in out


def test_shell_examples_run(tmp_path):
    # Each run gets its own folder: tests/docs runs the same blocks in parallel, and a shared
    # output folder let one run unpack a package while the other derived from it.
    for name in ("grammars", "assets"):
        if (ROOT / name).exists():
            (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    shell = blocks("")
    assert shell
    grammarkit = [sys.executable, "-m", "grammarkit"]
    for block in shell:
        if ".rpk" in block:
            pytest.importorskip("py7zr", reason="the rule-package example needs the optional py7zr")
        for line in block.strip().splitlines():
            argv = line.split()
            assert argv[0] == "grammarkit"
            res = subprocess.run(grammarkit + argv[1:], cwd=tmp_path, capture_output=True, text=True,
                                 timeout=300)
            assert res.returncode == 0, res.stderr
