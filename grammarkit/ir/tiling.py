"""IR of tiling grammars (Liu 2015, Kalojanov 2019): parts, sites, docks, rules, examples.

Syntax (see docs/language.md):

    part Tower = mesh("parts/tower.glb")
    part Wall  = box(4, 0.8, 3)
    site Wall.end at (2, 0, 0) facing +x
    dock Tower.side -- Wall.end
    dock Tower -- Wall { at (2.4, 0, 0) rot (0, 0, 90) | at (-2.4, 0, 0) rot (0, 0, -90) }
    neighbors Tower: {Wall, Wall} | {Wall, Wall, Gate}
    neighbors Wall: Tower in 1..2, Gate in 0..1
    constraint connected
    constraint path(from=Gate, to=Tower)
    example small = assembly("examples/castle_small.glb")
    example tiny { Tower at (0, 0, 0); Wall at (2.4, 0, 0) rot (0, 0, 90) }
"""
from __future__ import annotations

from typing import Literal

from .base import Node
from .expr import Call, Expr
from .split import Arg


class PartDef(Node):
    """`part NAME = geometry`; geometry is a call such as `mesh("f.glb")` or `box(w, d, h)`."""

    kind: Literal["part"] = "part"
    name: str
    geometry: Call
    comments: tuple[str, ...] = ()


class SiteDef(Node):
    """`site Part.name at (x, y, z) facing +x [mirror x]`: a docking frame on a part type."""

    kind: Literal["site"] = "site"
    part: str
    name: str
    position: tuple[Expr, Expr, Expr]
    facing: Literal["+x", "-x", "+y", "-y", "+z", "-z"] = "+x"
    mirror: Literal["x", "y", "z"] | None = None
    comments: tuple[str, ...] = ()


class Placement(Node):
    """A relative placement of the second part in the first part's frame (degrees, XYZ Euler)."""

    at: tuple[Expr, Expr, Expr]
    rot: tuple[Expr, Expr, Expr] | None = None


class DockDef(Node):
    """`dock A[.site] -- B[.site] { at (...) rot (...) | ... }`: parts that may touch, and how."""

    kind: Literal["dock"] = "dock"
    a: str
    a_site: str | None = None
    b: str
    b_site: str | None = None
    placements: tuple[Placement, ...] = ()
    comments: tuple[str, ...] = ()


class CountRange(Node):
    """`Type in lo..hi` (hi None: unbounded)."""

    type: str
    lo: int
    hi: int | None


class NeighborRule(Node):
    """Allowed neighbourhoods of a part type: exact multisets (`{A, A, B} | {A}`) or count ranges."""

    kind: Literal["neighbors"] = "neighbors"
    part: str
    multisets: tuple[tuple[str, ...], ...] = ()
    counts: tuple[CountRange, ...] = ()
    comments: tuple[str, ...] = ()


class ConstraintDef(Node):
    """`constraint NAME` or `constraint NAME(args)`: a global constraint from the constraint registry."""

    kind: Literal["constraint"] = "constraint"
    name: str
    args: tuple[Arg, ...] = ()
    comments: tuple[str, ...] = ()


class InlinePart(Node):
    """One part of an inline example: its type and placement."""

    type: str
    placement: Placement


class ExampleDef(Node):
    """`example NAME = assembly("file.glb")` or `example NAME { Type at (...) rot (...); ... }`."""

    kind: Literal["example"] = "example"
    name: str
    source: str | None = None
    parts: tuple[InlinePart, ...] = ()
    comments: tuple[str, ...] = ()


for _cls in (PartDef, SiteDef, Placement, DockDef, NeighborRule, ConstraintDef, InlinePart, ExampleDef):
    _cls.model_rebuild()
