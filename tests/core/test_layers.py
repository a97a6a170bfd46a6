"""The layering table of docs/architecture.md, enforced: every import of every module of
grammarkit (function-level imports included; `if TYPE_CHECKING:` blocks excepted, they never
run) goes to a room the table allows, core never imports a plugin, and plugins never import
each other. Every violation is reported with file:line.

KNOWN lists the violations that other work in progress removes (the split, cga, dsl,
geometry, tiling and studio helpers of this session remove them in their own branches). The
lead empties it after merging: an entry that no longer occurs fails the test too, so the list
can only shrink.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "grammarkit"
PLUGINS = ROOT / "plugins"

# (file, imported room): violations known at the time of writing, owned by other helpers.
KNOWN: set[tuple[str, str]] = set()


def _table() -> dict[str, set[str]]:
    """room -> the rooms it may import, read from the table of docs/architecture.md (its rows
    run from the bottom floor up; "every room above" means the rows before it)."""
    import re

    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    allowed: dict[str, set[str]] = {}
    for line in doc.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].startswith("`grammarkit"):
            continue
        head = cells[0].split()[0].strip("`")
        room = "__init__" if head == "grammarkit" else head.split(".", 1)[1]
        above = set(allowed)
        names = {("__init__" if n == "grammarkit" else n) for n in re.findall(r"`([\w.]+)`", cells[1])}
        if cells[1].startswith("every room above"):
            names |= above
        elif cells[1].startswith("every room but"):
            names = above - names
        allowed[room] = names
    return allowed


ALLOWED = _table()


def _room(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "grammarkit":
        return None
    if len(parts) == 1 or not ((PACKAGE / parts[1]).is_dir() or (PACKAGE / f"{parts[1]}.py").exists()):
        return "__init__"  # `from grammarkit import derive` and the like
    return parts[1]


def _module_of(path: Path, root: Path) -> tuple[str, str]:
    rel = path.relative_to(root).with_suffix("")
    name = ".".join(rel.parts)
    if path.name == "__init__.py":
        name = name[: -len(".__init__")]
        return name, name
    return name, name.rsplit(".", 1)[0]


def _type_checking_lines(tree: ast.AST) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                for sub in ast.walk(child):
                    if hasattr(sub, "lineno"):
                        lines.add(sub.lineno)
    return lines


def imports(path: Path, root: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every import in the file, at any depth."""
    module, package = _module_of(path, root)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _type_checking_lines(tree)
    found = []
    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if node.module:
                found.append((node.lineno, target))
            else:  # from . import a, b: each name may be a module of its own
                found += [(node.lineno, f"{target}.{a.name}") for a in node.names]
    return found


def _core_files() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _source_room(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    if len(rel.parts) == 1:
        return rel.stem
    return rel.parts[0]


def core_violations() -> list[tuple[str, int, str, str]]:
    out = []
    for path in _core_files():
        src = _source_room(path)
        assert src in ALLOWED, f"{path}: room {src!r} has no row in the layering table"
        for line, target in imports(path, ROOT):
            if target.split(".")[0].startswith("grammarkit_"):
                out.append((str(path.relative_to(ROOT)), line, target, target.split(".")[0]))
                continue
            room = _room(target)
            if room is None or room == src or room in ALLOWED[src]:
                continue
            out.append((str(path.relative_to(ROOT)), line, target, room))
    return out


def plugin_violations() -> list[tuple[str, int, str, str]]:
    out = []
    packages = sorted(p for p in PLUGINS.glob("*/grammarkit_*") if p.is_dir())
    names = {p.name for p in packages}
    for pkg in packages:
        for path in sorted(pkg.rglob("*.py")):
            for line, target in imports(path, pkg.parent):
                top = target.split(".")[0]
                if top in names and top != pkg.name:
                    out.append((str(pkg.relative_to(ROOT)), line,
                                f"{path.relative_to(ROOT)} imports {target}", top))
    return out


def _report(violations: list[tuple[str, int, str, str]]) -> list[str]:
    return [f"{file}:{line}: imports {target} (room {room!r})" for file, line, target, room in violations
            if (file, room) not in KNOWN]


def test_every_room_of_grammarkit_has_a_row_in_the_table():
    rooms = {_source_room(p) for p in _core_files()}
    assert rooms == set(ALLOWED), f"rooms without a row, or rows without a room: {rooms ^ set(ALLOWED)}"


def test_the_table_has_floors_no_circles():
    # a room may import only rooms of rows above its own: the table is a stack of floors
    order = list(ALLOWED)
    for room, allowed in ALLOWED.items():
        higher = {r for r in allowed if order.index(r) > order.index(room)}
        assert not higher, f"{room} may import the higher rooms {higher}"


def test_the_table_says_what_the_issue_asks():
    assert ALLOWED["errors"] == ALLOWED["jsonable"] == ALLOWED["gcpause"] == set()
    assert "run" not in ALLOWED["registry"] and "split" not in ALLOWED["functions"]
    for low in ("ir", "registry", "fileio", "functions", "hookspecs", "dsl", "split", "tiling",
                "geometry", "cga"):
        assert not ALLOWED[low] & {"run", "cli"}, low
    for low in ("ir", "registry", "fileio", "functions", "hookspecs", "expr_eval"):
        assert "plugins" not in ALLOWED[low], low


def test_the_plugin_manager_is_read_only_inside_public_entry_functions():
    """Rooms below the run layer may ask the plugin manager for the default registries only
    inside a function (a public entry point called without `registries=`), never at import:
    importing the engine never loads plugins, and every internal path receives registries."""
    bad = []
    for path in _core_files():
        room = _source_room(path)
        if room in ("plugins", "run", "cli", "__init__", "__main__"):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:  # module level only
            if isinstance(node, ast.ImportFrom) and node.module and (
                    node.module == "plugins" and node.level or node.module == "grammarkit.plugins"):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not bad, "module-level imports of the plugin manager: " + ", ".join(bad)


def test_core_imports_follow_the_layering_table():
    bad = _report(core_violations())
    assert not bad, "imports against docs/architecture.md's table:\n" + "\n".join(bad)


def test_plugins_never_import_each_other():
    bad = _report(plugin_violations())
    assert not bad, "plugins importing each other:\n" + "\n".join(bad)


def test_the_known_list_only_shrinks():
    found = {(f, room) for f, _, _, room in core_violations() + plugin_violations()}
    stale = sorted(KNOWN - found)
    assert not stale, f"fixed: remove these from KNOWN in {__file__}: {stale}"


@pytest.mark.parametrize("text, room, expected", [
    ("from ..run.writer import write_files\n", "split", ["grammarkit.run.writer"]),
    ("def f():\n    from ..plugins import get_plugin_manager\n", "split", ["grammarkit.plugins"]),
    ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..run import x\n", "split", []),
])
def test_the_checker_sees_function_level_imports_and_skips_type_only_ones(tmp_path, text, room, expected):
    path = tmp_path / "grammarkit" / room / "mod.py"
    path.parent.mkdir(parents=True)
    path.write_text(text)
    got = [t for _, t in imports(path, tmp_path) if t.startswith("grammarkit")]
    assert got == expected
