"""The modules of grammarkit.split import each other without a cycle (issue 25), counting every
import: at module level, inside functions (a lazy import that closes a circle still makes one)
and the package's lazy geometry imports (`lazy_module("grammarkit....")`)."""
from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "grammarkit" / "split"
MAX_LINES = 700


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imported(module: str, path: Path, known: set[str]) -> set[str]:
    """The modules of `known` that `module` imports anywhere in its source."""
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else [])) if node.level else node.module
            names = [target] + [f"{target}.{a.name}" for a in node.names]
        elif (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "lazy_module" and node.args
              and isinstance(node.args[0], ast.Constant)):
            names = [node.args[0].value]
        out |= {n for n in names if n in known}
    return out - {module}


def import_graph() -> nx.DiGraph:
    modules = _modules()
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for module, path in modules.items():
        graph.add_edges_from((module, target) for target in _imported(module, path, set(modules)))
    return graph


def test_the_graph_sees_function_level_and_relative_imports():
    graph = import_graph()
    assert graph.has_edge("grammarkit.split.ops.comp", "grammarkit.split.ops.faces")  # module level
    assert graph.has_edge("grammarkit.split.ops.label", "grammarkit.split.occlusion")  # inside a function
    assert graph.has_edge("grammarkit.split.engine", "grammarkit.split.occlusion")  # inside a method
    assert graph.has_edge("grammarkit.split", "grammarkit.split.variation")  # from a package's __init__


def test_no_import_cycle_inside_split():
    cycles = [sorted(c) for c in nx.strongly_connected_components(import_graph()) if len(c) > 1]
    assert cycles == []


def test_the_helpers_import_no_operation():
    graph = import_graph()
    for bottom in ("grammarkit.split.ops.helpers", "grammarkit.split.ops.layout"):
        ops = {t for t in nx.descendants(graph, bottom) if t.startswith("grammarkit.split.ops.")}
        assert ops <= {"grammarkit.split.ops.helpers"}, (bottom, ops)


def test_no_module_over_700_lines():
    long = {str(p.relative_to(ROOT)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}
