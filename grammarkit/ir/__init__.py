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

# the IR models, the operator tables and the walker (the submodules stay importable by name)
__all__ = [
    "Arg", "AssetDir", "Attr", "Binary", "BlockItem", "Bool", "Branch", "Call", "Case", "CaseArm",
    "Choice", "ChoiceArm", "Const", "ConstraintDef", "CountRange", "Default", "DockDef",
    "ExampleDef", "Expr", "Function", "Grammar", "Import", "InlinePart", "Item", "NeighborRule",
    "Nil", "Node", "Num", "OpCall", "PRECEDENCE", "PartDef", "Pattern", "Placement", "Push", "Ref",
    "Repeat", "Rule", "SPLIT_KINDS", "Seq", "SiteDef", "Snippet", "Span", "Statement", "Str",
    "Successor", "TILING_KINDS", "Terminal", "UNARY_PRECEDENCE", "Unary", "UpDef", "Use",
    "VariantOption", "Variants", "Vector", "block_branches", "block_seqs", "child_seqs",
    "successor_names", "walk", "walk_seqs",
]
