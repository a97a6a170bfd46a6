"""What an expression or a rule body depends on, found before deriving (the compiler uses it to
evaluate shape-free values once and to cache split layouts)."""
from __future__ import annotations

from typing import Any

from ..ir import expr as E
from ..ir import split as S


def shape_free(e: Any, params: tuple[str, ...], mutable: frozenset = frozenset(),
                user: frozenset = frozenset()) -> bool:
    """True if an expression reads only attrs, consts and literals (no scope, split index, rule
    parameter, rand, or attr that `set()` changes): its value is the same for every shape of
    one derivation. A call of a user function (`user`: their names) counts as shape-dependent
    (its body may read the scope)."""
    if isinstance(e, E.Ref):
        return (e.name not in params and e.name not in mutable
                and not e.name.startswith(("scope.", "split.", "comp.", "geometry.", "occlusion:")))
    if isinstance(e, E.Call):
        return e.func != "rand" and e.func not in user and all(shape_free(a, params, mutable, user)
                                                               for a in e.args)
    if isinstance(e, E.Unary):
        return shape_free(e.operand, params, mutable, user)
    if isinstance(e, E.Binary):
        return shape_free(e.left, params, mutable, user) and shape_free(e.right, params, mutable, user)
    if isinstance(e, E.Vector):
        return all(shape_free(a, params, mutable, user) for a in e.items)
    return True


def set_targets(node: Any) -> set[str]:
    """Names of the attrs that `set(name, value)` calls anywhere in `node` change."""
    out: set[str] = set()
    if isinstance(node, S.OpCall) and node.name == "set" and node.args and isinstance(node.args[0].value, E.Ref):
        out.add(node.args[0].value.name)
    if isinstance(node, (list, tuple)):
        for x in node:
            out |= set_targets(x)
    elif hasattr(node, "__pydantic_fields__") or hasattr(type(node), "model_fields"):
        for name in type(node).model_fields:
            v = getattr(node, name, None)
            if isinstance(v, (list, tuple)) or hasattr(type(v), "model_fields"):
                out |= set_targets(v)
    return out
