"""IR of split grammars (CGA-style rules, snippets, attributes).

A rule body is a `Seq` of items executed left to right on the current shape:
operation calls transform it, a `Successor` hands it to another rule, `Terminal`
makes it a leaf, `Nil` deletes it, `Push` runs a nested sequence on a copy,
`Case` and `Choice` select one sequence, and `Pattern` is the repetition sugar
`(A)*` / `(A B)* A` of Nishida 2016 consumed by the preceding `repeat` operation.
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from .base import Node
from .expr import Expr, Str


class Arg(Node):
    """An operation argument, positional (`name is None`) or named (`name=value`)."""

    name: str | None = None
    value: Expr


class Branch(Node):
    """One entry of an operation block: `key: body`.

    For `split` the key is a size: `mode="abs"` (`3`), `"rel"` (`'0.3`) or
    `"float"` (`~1`). For `comp`/`offset` the key is a selector name written as a
    plain reference (`top`, `side`, `inside`), i.e. `mode="abs"` with a `Ref` key.
    """

    kind: Literal["branch"] = "branch"
    mode: Literal["abs", "rel", "float"] = "abs"
    key: Expr
    body: "Seq"


class Repeat(Node):
    """A repeat group `{ ... }*` inside a split block; may nest."""

    kind: Literal["repeat"] = "repeat"
    items: tuple["BlockItem", ...]


BlockItem = Annotated[Union[Branch, Repeat], Field(discriminator="kind")]


class OpCall(Node):
    kind: Literal["op"] = "op"
    name: str
    args: tuple[Arg, ...] = ()
    block: tuple[BlockItem, ...] | None = None  # None: no `{ }` written


class Successor(Node):
    """Hand the shape to rule `name` (with optional arguments)."""

    kind: Literal["successor"] = "successor"
    name: str
    args: tuple[Expr, ...] = ()


class Terminal(Node):
    """`Name.`: the shape becomes a leaf tagged `name`."""

    kind: Literal["terminal"] = "terminal"
    name: str


class Nil(Node):
    """`NIL`: the shape is deleted."""

    kind: Literal["nil"] = "nil"


class Push(Node):
    """`[ ... ]`: run the nested sequence on a copy of the current shape."""

    kind: Literal["push"] = "push"
    body: "Seq"


class CaseArm(Node):
    cond: Expr
    body: "Seq"


class Case(Node):
    """`case c1: S1 case c2: S2 else: S3` (nestable: write nested cases in parentheses)."""

    kind: Literal["case"] = "case"
    arms: tuple[CaseArm, ...]
    otherwise: "Seq | None" = None


class ChoiceArm(Node):
    percent: Expr
    body: "Seq"


class Choice(Node):
    """`30%: A | 20%: B | else: C`, drawn with the shape's own seed."""

    kind: Literal["choice"] = "choice"
    arms: tuple[ChoiceArm, ...]
    otherwise: "Seq | None" = None


class Pattern(Node):
    """Repetition sugar `(A)*` or `(A B)* C` (Nishida 2016): `group` repeated, then `tail`."""

    kind: Literal["pattern"] = "pattern"
    group: tuple[str, ...]
    tail: str | None = None


Item = Annotated[
    Union[OpCall, Successor, Terminal, Nil, Push, Case, Choice, Pattern],
    Field(discriminator="kind"),
]


class Seq(Node):
    items: tuple[Item, ...] = ()


class Rule(Node):
    kind: Literal["rule"] = "rule"
    name: str
    params: tuple[str, ...] = ()
    body: Seq
    comments: tuple[str, ...] = ()


class Attr(Node):
    """`attr NAME = expr @range(lo, hi)` or `@enum(v1, v2, ...)`: a user-settable parameter."""

    kind: Literal["attr"] = "attr"
    name: str
    value: Expr
    range: tuple[Expr, Expr] | None = None
    enum: tuple[Expr, ...] | None = None
    comments: tuple[str, ...] = ()


class Const(Node):
    kind: Literal["const"] = "const"
    name: str
    value: Expr
    comments: tuple[str, ...] = ()


class Function(Node):
    """`func name(a, b) = expr`: a user function, called in expressions as `name(x, y)`.

    Functions are overloaded by arity (one definition per name and parameter count), may call
    themselves and each other, and see their parameters, the grammar's attrs and consts and the
    built-in values (`scope.sx`, ...); a parameter shadows an attr or const of the same name."""

    kind: Literal["func"] = "func"
    name: str
    params: tuple[str, ...] = ()
    value: Expr
    comments: tuple[str, ...] = ()


class Snippet(Node):
    """`snippet NAME : ObjectType { rules }` with optional attrs inside; axiom is `Start`."""

    kind: Literal["snippet"] = "snippet"
    name: str
    object_type: str
    attrs: tuple[Attr, ...] = ()
    rules: tuple[Rule, ...] = ()
    comments: tuple[str, ...] = ()


class Use(Node):
    """`use SNIPPET as Anchor`: a copy of the snippet with `Start` renamed to `Anchor`."""

    kind: Literal["use"] = "use"
    snippet: str
    anchor: str
    comments: tuple[str, ...] = ()


class Default(Node):
    """`default SNIPPET for ObjectType`: fills anchors of that type that no `use` binds."""

    kind: Literal["default"] = "default"
    snippet: str
    object_type: str
    comments: tuple[str, ...] = ()


class VariantOption(Node):
    snippet: str
    weight: Expr


class Variants(Node):
    """`variants Roof { gable: 50% | hip: 30% | pyramid: 20% }`: swap table for `--variations`."""

    kind: Literal["variants"] = "variants"
    object_type: str
    options: tuple[VariantOption, ...]
    comments: tuple[str, ...] = ()


class Import(Node):
    """`import "other.grammar"`: its definitions become visible here."""

    kind: Literal["import"] = "import"
    path: str
    comments: tuple[str, ...] = ()


class AssetDir(Node):
    """`asset_dir "path"`: a folder where relative asset names (i(), texture(), fileRandom, ...)
    are looked up, after the grammar file's own folder. `value` is what was written (the
    checker refuses anything but a non-empty string); `path` is that string."""

    kind: Literal["asset_dir"] = "asset_dir"
    value: Expr
    comments: tuple[str, ...] = ()

    @property
    def path(self) -> str | None:
        """The folder as written (None when the value is not a string literal)."""
        return self.value.value if isinstance(self.value, Str) else None

    @classmethod
    def of(cls, path: str, **kw) -> "AssetDir":
        return cls(value=Str(value=path), **kw)


for _cls in (Branch, Repeat, OpCall, Push, CaseArm, Case, ChoiceArm, Choice, Seq, Rule, Snippet):
    _cls.model_rebuild()
