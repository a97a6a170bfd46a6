"""Tags and side effects: color, material, set, trim, report, print."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import Shape
from ..strings import cga_str
from .helpers import hex_color, operation
from .texturing import set_material


@operation("color", (Param("value", "color"),), doc="Tag the shape with a colour (#rrggbb).")
def op_color(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    c = s
    c.color = hex_color(args[0])
    return c


@operation("material", (Param("name", "string"),), doc="Tag the shape with a material name.")
def op_material(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    c = s
    c.material = str(args[0])
    return c


@operation("set", (Param("attr", "name"), Param("value", "any")),
           doc="Change an attr for this shape and everything derived from it (CGA's set); "
               "`set(material.opacity, 0.5)` and the other CGA material attributes too.")
def op_set(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `set(attr, value)`: the shape and its descendants see the new value; other shapes
    keep theirs (each shape carries its values, shared until one is changed)."""
    key, value = str(args[0]), args[1]
    if key.startswith("material."):
        return set_material(ctx, s, key, value)
    if isinstance(value, tuple):
        raise ValueError(f"set({key}, ...): the value must be a number, a string or a boolean")
    c = s
    c.values = {**s.values, key: value}
    return c


@operation("trim", (Param("enabled", "any"),),
           doc="Whether i() clips inserts by the trim planes of comp(f) side faces (CGA's trim.vertical).")
def op_trim(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`trim(false)` / `trim(true)`: whether `i()` clips inserts by the trim planes (CGA's
    `set(trim.vertical, ...)`), for this shape and what is derived from it."""
    c = s
    c.trim_on = bool(args[0])
    return c


@operation("report", (Param("key", "string"), Param("value", "any")),
           doc="Collect a value under a report key (Model.reports; the model's metadata).")
def op_report(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `report(key, value)`: the value is collected under the key (Model.reports: count,
    sum, mean, min, max of numbers; counts of strings)."""
    key, value = args[0], args[1]
    if not isinstance(key, str) or not key:
        raise ValueError(f"report(): the key must be a non-empty string, got {key!r}")
    if isinstance(value, tuple):
        raise ValueError(f"report({key!r}, ...): the value must be a number, a string or a boolean")
    ctx.report(key, value)
    return s


@operation("print", (Param("value", "any"),),
           doc="A message of the derivation (CGA's print): `Rule: value` on Model.messages, "
               "printed by `grammarkit derive`; the shape is unchanged.")
def op_print(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """CGA's `print(value)`: a message of the derivation (Model.messages, printed by `grammarkit
    derive`), `Rule: value` with the value as CGA's str() writes it; the shape is unchanged."""
    value = args[0]
    if isinstance(value, tuple):
        raise ValueError("print(): the value must be a number, a string or a boolean")
    ctx.message(f"{s.rule_name}: {cga_str(value)}")
    return s
