"""Expressions: numbers, strings, references, operators and function calls.

Expressions are pure syntax here. Evaluating them (attribute values, `scope.sx`,
`split.index`, `rand(...)`) is the engines' business; see `grammarkit.expr_eval`.
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from .base import Node


class Num(Node):
    kind: Literal["num"] = "num"
    value: float


class Str(Node):
    kind: Literal["str"] = "str"
    value: str


class Bool(Node):
    kind: Literal["bool"] = "bool"
    value: bool


class Ref(Node):
    """A name: an attr, const, rule parameter, or a dotted built-in such as `scope.sx`."""

    kind: Literal["ref"] = "ref"
    name: str


class Unary(Node):
    kind: Literal["unary"] = "unary"
    op: Literal["-", "+", "!"]
    operand: "Expr"


class Binary(Node):
    kind: Literal["binary"] = "binary"
    op: Literal["+", "-", "*", "/", "%", "^", "==", "!=", "<", "<=", ">", ">=", "&&", "||"]
    left: "Expr"
    right: "Expr"


class Call(Node):
    """A call of a built-in expression function (`rand(1, 2)`, `min(a, b)`, `rect(20, 12)`)."""

    kind: Literal["call"] = "call"
    func: str
    args: tuple["Expr", ...] = ()


class Vector(Node):
    """A literal tuple `(x, y, z)`, used for positions and rotations in tiling grammars."""

    kind: Literal["vector"] = "vector"
    items: tuple["Expr", ...]


Expr = Annotated[
    Union[Num, Str, Bool, Ref, Unary, Binary, Call, Vector],
    Field(discriminator="kind"),
]

for _cls in (Unary, Binary, Call, Vector):
    _cls.model_rebuild()

# Operator precedence, loosest first; shared by the parser's grammar and the printer.
PRECEDENCE: dict[str, int] = {
    "||": 1,
    "&&": 2,
    "==": 3, "!=": 3,
    "<": 4, "<=": 4, ">": 4, ">=": 4,
    "+": 5, "-": 5,
    "*": 6, "/": 6, "%": 6,
    "^": 8,  # right-associative, binds tighter than unary minus (-2^2 == -4)
}
UNARY_PRECEDENCE = 7
