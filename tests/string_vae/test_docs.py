"""The code blocks of docs/string-vae.md run: Python blocks, and the `grammarkit strings` commands
(the dataset, training and sampling commands run for minutes; test_model.py covers them)."""
from __future__ import annotations

import os
import re
import shlex

import pytest
from click.testing import CliRunner

from grammarkit.cli import main

from .conftest import ROOT

DOC = ROOT / "docs" / "string-vae.md"


def _blocks(lang: str | None):
    text = DOC.read_text(encoding="utf-8")
    out = []
    for m in re.finditer(r"(<!-- illustrative -->\n)?```(\w*)\n(.*?)```", text, re.S):
        if m.group(1):
            continue
        if lang is None or m.group(2) == lang:
            out.append((m.group(2), m.group(3)))
    return out


def test_python_blocks_run(monkeypatch):
    monkeypatch.chdir(ROOT)
    blocks = [code for lang, code in _blocks("python")]
    assert blocks
    for code in blocks:
        exec(compile(code, str(DOC), "exec"), {})


def test_strings_commands_in_the_docs_run(monkeypatch):
    monkeypatch.chdir(ROOT)
    commands = [line for lang, code in _blocks("") for line in code.splitlines()
                if line.startswith("grammarkit strings")]
    assert len(commands) >= 2
    for line in commands:
        res = CliRunner().invoke(main, shlex.split(line)[1:])
        # the decode example in the docs is an invalid string on purpose (exit status 1)
        assert res.exit_code in (0, 1) and "Traceback" not in res.output, (line, res.output)
        if "--decode" not in line:
            assert res.exit_code == 0


def test_no_benchmark_placeholder_is_left():
    if os.environ.get("GRAMMARKIT_DOCS_DRAFT"):
        pytest.skip("draft")
    assert "BENCHMARK_TABLES" not in DOC.read_text(encoding="utf-8")
