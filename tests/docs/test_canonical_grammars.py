"""Issue 32: the grammars a new user reads first are in the form `grammarkit fmt` prints, so
`grammarkit fmt --check` passes on every top-level grammars/*.grammar and on the README's
grammar blocks (the tower a user saves as tower.grammar)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from grammarkit.cli import main

ROOT = Path(__file__).resolve().parents[2]
README_GRAMMARS = re.findall(r"```\n(grammar .*?)```", (ROOT / "README.md").read_text(), re.DOTALL)


@pytest.mark.parametrize("path", sorted((ROOT / "grammars").glob("*.grammar")), ids=lambda p: p.name)
def test_shipped_grammar_is_canonical(path):
    result = CliRunner().invoke(main, ["fmt", "--check", str(path)])
    assert result.exit_code == 0, result.output


def test_readme_grammar_blocks_are_canonical(tmp_path):
    assert README_GRAMMARS, "the README shows the tower grammar"
    for i, text in enumerate(README_GRAMMARS):
        path = tmp_path / f"readme_{i}.grammar"
        path.write_text(text)
        result = CliRunner().invoke(main, ["fmt", "--check", str(path)])
        assert result.exit_code == 0, result.output
