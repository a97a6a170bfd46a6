"""The core receives registries; only the CLI/API edge reads the process-wide plugin manager
(issue 8). A read is a reference to `get_plugin_manager` or `default_registries`."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "grammarkit"
EDGE_NAMES = {"get_plugin_manager", "default_registries"}

# Whole modules that are the edge.
EDGE_MODULES = {
    "grammarkit/plugins.py",  # defines them
    "grammarkit/__init__.py",  # the top-level API (lazy names)
    "grammarkit/run/api.py",  # run_backend / iter_results
}
EDGE_PACKAGES = ("grammarkit/cli/",)
# Public API functions that may default to the installed plugins when given no registries.
EDGE_FUNCTIONS = {
    "grammarkit/dsl/__init__.py": {"_check"},  # behind parse/check/load/check_text
    "grammarkit/split/__init__.py": {"_registries"},  # behind derive/compile/variations/check_attrs
    "grammarkit/tiling/rules.py": {"rules_from_grammar"},
    "grammarkit/tiling/validate.py": {"validate"},
    "grammarkit/cga/importer.py": {"_operation_names"},  # behind import_cga / translate_cga
    "grammarkit/geometry/exporters.py": {"_all_specs"},  # behind exporter_for / known_formats
}


def _reads(path: Path) -> list[tuple[int, str | None]]:
    """(line, enclosing top-level function) of every reference to an edge name."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []

    def visit(node: ast.AST, func: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            f = func
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) and func is None:
                f = child.name
            if isinstance(child, ast.Name) and child.id in EDGE_NAMES:
                found.append((child.lineno, func))
            elif isinstance(child, ast.Attribute) and child.attr in EDGE_NAMES:
                found.append((child.lineno, func))
            elif isinstance(child, ast.alias) and child.name in EDGE_NAMES:
                found.append((getattr(child, "lineno", getattr(node, "lineno", 0)), func))
            visit(child, f)
    visit(tree, None)
    return found


def test_only_the_edge_reads_the_plugin_manager():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in EDGE_MODULES or rel.startswith(EDGE_PACKAGES):
            continue
        allowed = EDGE_FUNCTIONS.get(rel, set())
        bad += [f"{rel}:{line} (in {func or 'module level'})" for line, func in _reads(path)
                if func not in allowed]
    assert not bad, "the core reads the global plugin manager:\n" + "\n".join(bad)


def test_the_allowed_list_only_shrinks():
    """Every allowed edge function still reads the plugin manager: one that no longer does
    (its registries now flow from the caller) leaves the list."""
    stale = [f"{rel}: {func}" for rel, funcs in EDGE_FUNCTIONS.items()
             for func in sorted(funcs - {f for _, f in _reads(ROOT / rel)})]
    assert not stale, f"no longer read the plugin manager: remove from EDGE_FUNCTIONS: {stale}"


def test_the_check_finds_a_read():
    probe = PACKAGE / "split" / "_probe_for_test.py"
    try:
        probe.write_text("def f():\n    from ..plugins import get_plugin_manager\n"
                         "    return get_plugin_manager().operations()\n", encoding="utf-8")
        assert [func for _, func in _reads(probe)] == ["f", "f"]
    finally:
        probe.unlink()


def test_core_functions_require_registries():
    import pytest

    from grammarkit.dsl import parse
    from grammarkit.dsl.checker import Checker
    from grammarkit.split.compile import compile_grammar

    g = parse("Lot --> footprint(rect(1, 1)) extrude(1) X.\n")
    with pytest.raises(TypeError, match="registries"):
        compile_grammar(g, None)
    with pytest.raises(TypeError, match="registries"):
        Checker(g, None)  # type: ignore[arg-type]  # the missing registries are the point


def test_explicit_registries_are_what_the_core_uses():
    """A derivation with hand-made registries uses exactly them (no plugin manager needed)."""
    import pytest

    from grammarkit.errors import GrammarError
    from grammarkit.functions import BUILTIN_FUNCTIONS
    from grammarkit.registry import OperationSpec, Param, Registries
    from grammarkit.split import derive
    from grammarkit.split.operations import FITS, SPECS

    ops = {s.name: s for s in SPECS}

    def tall(ctx, shape, args, block):
        return shape.derived(shape.o, (shape.sz[0], shape.sz[1], 2 * float(args[0])), None, "V")
    ops["tall"] = OperationSpec("tall", (Param("h"),), apply=tall)
    reg = Registries(operations=ops, functions={f.name: f for f in BUILTIN_FUNCTIONS},
                     fits={f.name: f for f in FITS})
    m = derive("Lot --> footprint(rect(2, 2)) tall(3) X.\n", registries=reg)
    assert m.parts[0].size[2] == pytest.approx(6.0)
    with pytest.raises(GrammarError, match="unknown operation 'tall'"):
        derive("Lot --> footprint(rect(2, 2)) tall(3) X.\n")  # the installed plugins have no `tall`
