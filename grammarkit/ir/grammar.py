"""The root of the IR: a grammar file as an ordered list of statements.

Statements keep source order (so `grammarkit fmt` does not reshuffle a file); the
properties below give typed views for the engines.
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from .base import Node
from .split import AssetDir, Attr, Const, Default, Function, Import, Rule, Snippet, Use, Variants
from .tiling import ConstraintDef, DockDef, ExampleDef, NeighborRule, PartDef, SiteDef, UpDef

Statement = Annotated[
    Union[
        Attr, Const, Function, Rule, Snippet, Use, Default, Variants, Import, AssetDir,
        PartDef, SiteDef, DockDef, NeighborRule, ConstraintDef, ExampleDef, UpDef,
    ],
    Field(discriminator="kind"),
]

SPLIT_KINDS = frozenset({"rule", "snippet", "use", "default", "variants"})
TILING_KINDS = frozenset({"part", "site", "dock", "neighbors", "constraint", "example", "up"})


class Grammar(Node):
    """`grammar NAME` followed by statements."""

    name: str
    statements: tuple[Statement, ...] = ()
    comments: tuple[str, ...] = ()  # full-line comments before the `grammar` header
    # Comments after the last statement (kept by `grammarkit fmt`; not part of equality).
    trailing_comments: tuple[str, ...] = ()
    # Path the grammar was read from (not part of equality; used to resolve relative files).
    source_path: str | None = Field(default=None)

    @property
    def family(self) -> Literal["split", "tiling", "empty"]:
        kinds = {s.kind for s in self.statements}
        if kinds & TILING_KINDS:
            return "tiling"
        if kinds & SPLIT_KINDS:
            return "split"
        return "empty"

    @property
    def asset_dirs(self) -> tuple[str, ...]:
        """The `asset_dir` folders in declaration order, as written (an imported file's are
        absolute: the import inliner resolves them against that file's folder)."""
        return tuple(a.path for a in self._of(AssetDir) if a.path)

    def _of(self, cls):  # noqa: ANN001 - small typed filter
        return tuple(s for s in self.statements if isinstance(s, cls))

    attrs = property(lambda self: self._of(Attr))
    consts = property(lambda self: self._of(Const))
    functions = property(lambda self: self._of(Function))
    rules = property(lambda self: self._of(Rule))
    snippets = property(lambda self: self._of(Snippet))
    uses = property(lambda self: self._of(Use))
    defaults = property(lambda self: self._of(Default))
    variants = property(lambda self: self._of(Variants))
    imports = property(lambda self: self._of(Import))
    asset_dir_statements = property(lambda self: self._of(AssetDir))
    parts = property(lambda self: self._of(PartDef))
    sites = property(lambda self: self._of(SiteDef))
    docks = property(lambda self: self._of(DockDef))
    neighbor_rules = property(lambda self: self._of(NeighborRule))
    constraints = property(lambda self: self._of(ConstraintDef))
    examples = property(lambda self: self._of(ExampleDef))
    ups = property(lambda self: self._of(UpDef))


Grammar._ignored_in_eq = Node._ignored_in_eq | {"source_path", "trailing_comments"}
