from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GRAMMARS = ROOT / "grammars"
EXAMPLES = ["paris", "skyscraper", "lshape"]
PLUGIN_DIR = ROOT / "tests" / "fixtures" / "split_op_plugin"


CGA_PACKAGES = sorted((GRAMMARS / "cga" / "packages").glob("*.rpk"))


@pytest.fixture(scope="session")
def cga_packages(tmp_path_factory):
    """Corpus rule package name -> its parsed grammar, imported as it comes, once per session
    (tests/split/test_cga_solid.py and test_cga_speed.py derive them)."""
    pytest.importorskip("py7zr", reason="7z rule packages need the optional py7zr (grammarkit[cga])")
    import grammarkit
    from grammarkit.cga import translate_cga
    from grammarkit.cga.project import open_input

    out = {}
    tmp = tmp_path_factory.mktemp("packages")
    for rpk in CGA_PACKAGES:
        target = tmp / rpk.stem / f"{rpk.stem}.grammar"
        target.parent.mkdir(parents=True)
        project = open_input(rpk, extract_to=target.parent / (rpk.name + ".d"))
        result = translate_cga(project.rule_file, output=target, project=project)
        assert result.ok, f"{rpk.name} does not import"
        target.write_text(result.text, encoding="utf-8")
        out[rpk.stem] = grammarkit.parse(result.text, filename=str(target))
    return out


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
