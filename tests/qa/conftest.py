"""QA tests: bad input, resource guards, determinism and watertightness across the finished
commands and APIs (split engine, geometry, tiling). Small grammars keep the suite fast."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from _qa_helpers import SMALL  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
GRAMMARS = ROOT / "grammars"


@pytest.fixture
def small_grammar(tmp_path: Path) -> Path:
    p = tmp_path / "small.grammar"
    p.write_text(SMALL, encoding="utf-8")
    return p


@pytest.fixture
def cli():
    """Run the `grammarkit` command in-process; returns (exit code, stdout+stderr text)."""
    from click.testing import CliRunner

    from grammarkit.cli import main

    def run(*args: str) -> tuple[int, str]:
        res = CliRunner().invoke(main, [str(a) for a in args])
        if res.exception is not None and not isinstance(res.exception, SystemExit):
            import traceback

            text = "".join(traceback.format_exception(res.exception))
            return 99, res.output + "\nTRACEBACK:\n" + text
        return res.exit_code, res.output

    return run
