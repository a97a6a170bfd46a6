"""Operations see a small public protocol (issue 8): `OperationContext`, `ShapeView` and
`BlockSlot` in grammarkit.hookspecs. The built-in operations and the fixture plugin use
nothing else (checked on their source), and the engine hands operations the context, never
the Derivation."""
from __future__ import annotations

import ast
from pathlib import Path

from grammarkit import hookspecs

ROOT = Path(__file__).resolve().parents[2]
OPS = ROOT / "grammarkit" / "split" / "ops"
SOURCES = [OPS / f"{name}.py" for name in ("helpers", "layout", "create", "splitting", "roofs", "transforms",
                                           "insert", "tags", "comp", "faces")]
SOURCES.append(ROOT / "tests" / "fixtures" / "split_op_plugin" / "split_op_plugin.py")

# how the sources name the objects of each protocol
SHAPES = {"s", "shape", "c", "face", "top", "bottom", "inside", "raised", "post", "piece", "b", "f"}
SLOTS = {"slot", "it"}
CONTEXTS = {"ctx"}


def _members(protocol: type) -> set[str]:
    names = set(getattr(protocol, "__annotations__", {}))
    names |= {n for n in vars(protocol) if not n.startswith("_")}
    return names


def _uses(path: Path) -> list[tuple[int, str, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [(n.lineno, n.value.id, n.attr) for n in ast.walk(tree)
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)]


def test_protocols_list_what_operations_need():
    ctx = _members(hookspecs.OperationContext)
    assert {"limits", "registries", "base_dir", "seed", "cache", "attr", "add_solid", "add_body",
            "recess", "terminal", "warn"} <= ctx
    shape = _members(hookspecs.ShapeView)
    assert {"o", "ax", "sz", "kind", "poly", "solid", "rng", "copy", "derived", "world", "contours",
            "rule_name", "index", "total"} <= shape


def test_builtin_operations_and_the_fixture_use_only_the_protocols():
    allowed = {"shape": _members(hookspecs.ShapeView), "slot": _members(hookspecs.BlockSlot),
               "ctx": _members(hookspecs.OperationContext)}
    bad = []
    for path in SOURCES:
        for line, name, attr in _uses(path):
            kind = "shape" if name in SHAPES else "slot" if name in SLOTS else "ctx" if name in CONTEXTS else None
            if kind is not None and attr not in allowed[kind]:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {name}.{attr} is not in the {kind} protocol")
    assert not bad, "\n".join(bad)


def test_the_engine_implements_the_protocols():
    from grammarkit.split.compile import Slot
    from grammarkit.split.engine import Derivation, Limits, OperationContext
    from grammarkit.split.shape import Shape

    for cls, protocol in ((Shape, hookspecs.ShapeView), (Slot, hookspecs.BlockSlot),
                          (OperationContext, hookspecs.OperationContext)):
        have = set(dir(cls)) | set(getattr(cls, "__slots__", ()))
        missing = _members(protocol) - have
        assert not missing, f"{cls.__name__} lacks {missing}"
    # an operation gets the context, which does not expose the derivation's state
    d = Derivation(None, 0, Limits(), {"h": 3})
    ctx = d.context
    assert ctx.attr("h") == 3 and ctx.limits is d.limits
    assert not hasattr(ctx, "stack") and not hasattr(ctx, "nodes") and not hasattr(ctx, "adds")


def test_operations_receive_the_context(G):
    from grammarkit import hookimpl
    from grammarkit.plugins import get_plugin_manager
    from grammarkit.registry import OperationSpec, Param
    from grammarkit.split import derive

    seen = []

    def probe(ctx, shape, args, block):
        seen.append((type(ctx).__name__, ctx.attr("w"), shape.rule_name, ctx.seed))
        ctx.warn("probe was here")
        return shape

    class Probe:
        @hookimpl
        def grammarkit_operations(self):
            return [OperationSpec("probe", (Param("x"),), apply=probe)]

    pm = get_plugin_manager()
    pm.register(Probe(), "probe-fixture")
    try:
        m = derive(G("attr w = 4\nLot --> footprint(rect(w, 2)) probe(1) extrude(1) X.\n"), seed=5)
    finally:
        pm.unregister("probe-fixture")
    assert seen == [("OperationContext", 4, "Lot", 5)]
    assert "probe was here" in m.warnings
