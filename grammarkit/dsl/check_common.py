"""What the checker's parts share: the built-in names, the scope of a rule body, formatting."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from ..ir import Attr, Rule
from ..ir.base import Span

# Dotted names the engines provide while deriving (see docs/language.md).
BUILTIN_REFS = frozenset({
    "scope.sx", "scope.sy", "scope.sz", "scope.tx", "scope.ty", "scope.tz",
    "split.index", "split.total", "comp.index", "comp.total", "comp.sel",
    # the shape's geometry (split grammars; grammarkit/split/geometry_queries.py)
    "geometry.area", "geometry.volume", "geometry.nVertices", "geometry.isRectangular",
    "geometry.isConcave",
})
# Global constraints of tiling grammars that are always known, even before their plugin loads.
BUILTIN_CONSTRAINTS = frozenset({"connected", "grounded", "path", "count", "filled", "deformable"})
START = "Start"


def _where(span: Span | None) -> str:
    return f" (at {span})" if span is not None and span.line else ""


@dataclass
class _Scope:
    values: set[str]
    rules: dict[str, Rule]
    outer_rules: dict[str, Rule] = field(default_factory=dict)
    params: frozenset[str] = frozenset()  # rule parameters: never constant
    local_attrs: Mapping[str, Attr] = field(default_factory=dict)  # a snippet's own attrs


def _num(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else repr(float(v))


def _show(v: Any) -> str:
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, bool):
        return "true" if v else "false"
    return _num(v)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    return a == b
