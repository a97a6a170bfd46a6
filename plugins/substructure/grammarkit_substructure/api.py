"""Python API: `enumerate(assembly, rules) -> list[Operation]`, `apply(assembly, op) -> Assembly`."""
from __future__ import annotations

import builtins
from typing import Any, Callable

from grammarkit.errors import ShapeError
from grammarkit.tiling import Assembly

from .operations import find_operations
from .search import Operation
from .shape import ORIGINS, Shape, embed


def _rules(rules: Any):
    """A grammarkit.tiling Rules from Rules, a Grammar, a path or None."""
    if rules is None:
        return None
    from grammarkit.ir import Grammar
    from grammarkit.tiling import rules_from_grammar

    if isinstance(rules, Grammar):
        return rules_from_grammar(rules)
    if isinstance(rules, str) or hasattr(rules, "__fspath__"):
        from pathlib import Path

        from grammarkit.dsl import load

        return rules_from_grammar(load(Path(rules)))
    return rules


def _shape(obj: Any, tolerance: float | None) -> Shape:
    if isinstance(obj, Shape):
        return obj
    if isinstance(obj, Assembly):
        return Shape.from_assembly(obj, tolerance)
    from grammarkit.tiling import read_assembly

    return Shape.from_assembly(read_assembly(obj), tolerance)


def enumerate(assembly: Any, rules: Any = None, *, donor: Any = None, q: int = 0,
              tolerance: float | None = None,
              progress: Callable[[int], None] | None = None) -> list[Operation]:
    """Every replaceable substructure of `assembly` (an Assembly or a model file), as normalised
    operations. With `donor`, the copied pieces come from the donor (another example), else
    from the assembly itself. With `rules` (a tiling grammar, its path or its Rules),
    operations whose reconnections the grammar's type pairs forbid are left out."""
    if not 0 <= q <= 4:
        raise ValueError(f"q must be 0..4, got {q}")
    host = _shape(assembly, tolerance)
    d = _shape(donor, tolerance) if donor is not None else host
    ops = find_operations(d.graph, host.graph if d is not host else None, q=q, progress=progress)
    rule_set = _rules(rules)
    if rule_set is not None and getattr(rule_set, "pairs", None) is not None:
        ops = [op for op in ops
               if builtins.all(rule_set.allows_pair(host.types[b], d.types[w]) for _, w, b, _ in op.pairs)]
    return ops


def apply(assembly: Any, op: Operation, *, donor: Any = None, rules: Any = None,
          embedding: str = "rigid", repair: bool = True, tolerance: float | None = None,
          frame_origin: str = "foot") -> Assembly:
    """The assembly after `op` (from `enumerate` on the same assembly and donor), embedded in 3D.

    With `rules`, the result is checked against the grammar (and repaired, if `repair`); a
    result that breaks a rule raises ShapeError naming the part and the rule."""
    host = _shape(assembly, tolerance)
    d = _shape(donor, tolerance) if donor is not None else host
    for v in op.removed:
        if v >= len(host):
            raise ShapeError(f"operation removes part {v}, but the assembly has {len(host)} parts")
    for v in op.copied:
        if v >= len(d):
            raise ShapeError(f"operation copies part {v}, but the donor has {len(d)} parts")
    if frame_origin not in ORIGINS:
        raise ValueError(f"frame_origin must be one of {', '.join(ORIGINS)}, got {frame_origin!r}")
    out = embed(d, host, op, _rules(rules), embedding=embedding, repair=repair, origin_at=frame_origin)
    if out.shape is None:
        raise ShapeError(f"{host.name}: the operation gives an invalid shape: " + "; ".join(out.problems))
    return out.shape.to_assembly(meta={"substructure": {"operation": op.to_json(host.ids, d.ids),
                                                        "repaired": out.repaired}})
