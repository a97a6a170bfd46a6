"""docs/batch.md runs as written: every code block not marked illustrative (shell commands and
Python), in order, from a folder where grammars/ is the repository's."""
from __future__ import annotations

import re
import shlex
import subprocess
import sys

from _batch_helpers import ROOT

DOC = ROOT / "docs" / "batch.md"


def blocks() -> list[tuple[str, str]]:
    text = DOC.read_text(encoding="utf-8")
    out = []
    for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", text, flags=re.S):
        if not m.group(1):
            out.append((m.group(2) or "sh", m.group(3)))
    return out


def test_every_block_of_docs_batch_runs(tmp_path):
    (tmp_path / "grammars").symlink_to(ROOT / "grammars")
    (tmp_path / "tests").symlink_to(ROOT / "tests")
    found = blocks()
    assert {kind for kind, _ in found} == {"sh", "python"}
    for kind, code in found:
        if kind == "python":
            p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                               text=True, timeout=600)
            assert p.returncode == 0, f"{code}\n{p.stderr}"
            continue
        for line in code.strip().splitlines():
            args = shlex.split(line)
            assert args[0] == "grammarkit", line
            p = subprocess.run([sys.executable, "-m", "grammarkit", *args[1:]], cwd=tmp_path,
                               capture_output=True, text=True, timeout=600)
            assert p.returncode == 0, f"{line}\n{p.stderr}"
    assert (tmp_path / "out" / "city.glb").is_file() and (tmp_path / "out" / "ds_sheet.png").is_file()
