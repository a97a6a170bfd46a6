from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GRAMMARS = ROOT / "grammars"
EXAMPLES = ["paris", "skyscraper", "lshape"]
PLUGIN_DIR = ROOT / "tests" / "fixtures" / "split_op_plugin"


@pytest.fixture(scope="session")
def examples():
    from grammarkit.dsl import load

    return {name: load(GRAMMARS / f"{name}.grammar") for name in EXAMPLES}


@pytest.fixture
def G():
    """Grammar text -> checked Grammar IR (via the DSL's load)."""
    from grammarkit.dsl import load

    return lambda text: load(text)


@pytest.fixture
def plugin_path():
    sys.path.insert(0, str(PLUGIN_DIR))
    yield PLUGIN_DIR
    sys.path.remove(str(PLUGIN_DIR))
