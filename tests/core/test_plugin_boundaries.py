"""Dependency directions: plugins use grammarkit's public modules only; core never imports a plugin."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# What a third-party plugin may import: the package and its documented public modules.
PUBLIC = {"grammarkit", "grammarkit.tiling", "grammarkit.dsl", "grammarkit.registry", "grammarkit.errors",
          "grammarkit.ir", "grammarkit.hookspecs", "grammarkit.fileio", "grammarkit.jsonable", "grammarkit.gcpause", "grammarkit.plugins", "grammarkit.printer",
          "grammarkit.split", "grammarkit.run", "grammarkit.geometry.exporters", "grammarkit.geometry.render",
          "grammarkit.geometry.convert", "grammarkit.geometry.meshio"}


def _imports(path: Path) -> list[tuple[str, int]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, node.lineno))
    return found


def test_plugins_import_only_public_grammarkit_modules():
    bad = [f"{p.relative_to(ROOT)}:{line}: {mod}"
           for p in (ROOT / "plugins").rglob("*.py")
           for mod, line in _imports(p)
           if mod.startswith("grammarkit.") and mod not in PUBLIC]
    assert not bad, "plugins import private modules:\n" + "\n".join(bad)


def test_core_never_imports_a_plugin():
    plugin_packages = {p.name for p in (ROOT / "plugins").glob("*/*") if (p / "__init__.py").exists()}
    bad = [f"{p.relative_to(ROOT)}:{line}: {mod}"
           for p in (ROOT / "grammarkit").rglob("*.py")
           for mod, line in _imports(p)
           if mod.split(".")[0] in plugin_packages]
    assert plugin_packages and not bad, bad
