"""The translator's records of declarations, and small helpers on CGA parse trees."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from lark import Token, Tree

from ...ir import Bool, Num, Str
from ...ir.base import Span

HEAD = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_.]*)\s*(?:\(([^()]*)\))?\s*(?:-->|=)\s*\Z", re.S)

# UI annotations of attrs and rules: no geometric meaning (listed as ignored in the report).
UI_ANNOTATIONS = {"@Order", "@Group", "@Description", "@Hidden", "@Color", "@Distance",
                   "@File", "@Directory", "@Angle", "@Percent", "@Handle", "@InPlace",
                   "@Enabled", "@Location", "@ValueRange", "@Macro"}

# CGA operations grammarkit has no counterpart for yet. They are dropped with a warning whose
# feature is `op:<name>`; listed here only to word the message.
TEXTURING = {"copyUV", "insertAlongUV", "setNormals", "softenNormals"}
METADATA: set[str] = set()  # (print is translated: grammarkit has print())


@dataclass
class RuleDef:
    name: str
    params: tuple[str, ...]
    body: Tree
    span: Span | None
    start: bool = False
    annotations: list = field(default_factory=list)
    imported: bool = False  # from an imported file (counted in that file's own report)


@dataclass
class ValueDef:
    kind: str            # "attr" | "const"
    name: str
    value: Any
    span: Span | None
    annotations: list
    imported: bool = False  # declared in an imported file (counted in that file's own report)


def params_of(text: str | None) -> tuple[str, ...]:
    if not text or not text.strip():
        return ()
    return tuple(p.strip().split()[-1] for p in text.split(",") if p.strip())


def looks_like_string(tree: Any) -> bool:
    return isinstance(tree, Tree) and any(
        isinstance(t, Token) and t.type == "STRING" for t in tree.scan_values(lambda v: True))


def literal(value: Any) -> Any:
    if isinstance(value, bool):
        return Bool(value=value)
    if isinstance(value, (int, float)):
        return Num(value=float(value))
    return Str(value=str(value))


def hoist_size(tree: Any) -> tuple[str, Any]:
    """`~a / n` parses as `(~a) / n`; CGA means `~(a / n)`: move the mark to the whole key."""
    if isinstance(tree, Tree):
        if tree.data == "rel":
            return "rel", tree.children[-1]
        if tree.data == "floating":
            return "float", tree.children[-1]
        if tree.data in ("binop", "or_op", "and_op"):
            mode, left = hoist_size(tree.children[0])
            if mode != "abs":
                return mode, Tree(tree.data, [left, *tree.children[1:]], meta=tree.meta)
    return "abs", tree



