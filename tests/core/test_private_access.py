"""Plugins reach grammarkit through its public API only: besides importing public modules
(test_plugin_boundaries.py), they never touch a `_private` name of grammarkit's objects or
modules (`geometry._manifolds`, `split._mapping`, ...)."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _grammarkit_names(tree: ast.AST) -> set[str]:
    """Local names bound to grammarkit modules or objects by imports."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] == "grammarkit":
            names.update(a.asname or a.name for a in node.names)
        elif isinstance(node, ast.Import):
            names.update((a.asname or a.name).split(".")[0] for a in node.names
                         if a.name.split(".")[0] == "grammarkit")
    return names


def _private_uses(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] == "grammarkit":
            found += [f"{path.relative_to(ROOT)}:{node.lineno}: imports {a.name}"
                      for a in node.names if a.name.startswith("_")]
    gk = _grammarkit_names(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in gk:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: uses {ast.unparse(node)}")
    return found


def test_plugins_use_no_private_grammarkit_names():
    bad = [u for p in (ROOT / "plugins").rglob("*.py") for u in _private_uses(p)]
    assert not bad, "plugins use private grammarkit names:\n" + "\n".join(bad)


def test_the_check_finds_private_access(tmp_path, monkeypatch):
    sample = ROOT / "plugins" / "_probe_for_test.py"
    try:
        sample.write_text("from grammarkit import split\nfrom grammarkit.split import _mapping\n"
                          "x = split._cache\n", encoding="utf-8")
        found = _private_uses(sample)
    finally:
        sample.unlink()
    assert any("imports _mapping" in f for f in found) and any("split._cache" in f for f in found)
