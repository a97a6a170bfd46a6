"""The grammarkit IR: one set of immutable pydantic models for both grammar families.

The DSL parses text into these models, the printer turns them back into text, and the
engines and back ends consume them. Nothing here knows about Lark or geometry.
"""
from .base import Node, Span
from .expr import PRECEDENCE, UNARY_PRECEDENCE, Binary, Bool, Call, Expr, Num, Ref, Str, Unary, Vector
from .grammar import SPLIT_KINDS, TILING_KINDS, Grammar, Statement
from .split import (
    Arg, AssetDir, Attr, BlockItem, Branch, Case, CaseArm, Choice, ChoiceArm, Const, Default, Function, Import, Item,
    Nil, OpCall, Pattern, Push, Repeat, Rule, Seq, Snippet, Successor, Terminal, Use, Variants,
    VariantOption,
)
from .walk import block_branches, block_seqs, child_seqs, successor_names, walk, walk_seqs
from .tiling import (
    ConstraintDef, CountRange, DockDef, ExampleDef, InlinePart, NeighborRule, PartDef, Placement,
    SiteDef, UpDef,
)

__all__ = [name for name in dir() if not name.startswith("_")]
