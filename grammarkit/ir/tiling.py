"""IR of tiling grammars (Liu 2015, Kalojanov 2019): parts, sites, docks, rules, examples.

Syntax (see docs/language.md):

    up +z
    part Tower = mesh("parts/tower.glb") symmetry(z8)
    part Wall  = box(4, 0.8, 3) symmetry(z2, mirror) up(+z)
    site Wall.end at (2, 0, 0) facing +x mirror x required
    dock Tower.side -- Wall.end
    dock Tower -- Wall { at (2.4, 0, 0) rot (0, 0, 90) | at (-2.4, 0, 0) rot (0, 0, -90) }
    neighbors Tower: {Wall, Wall} | {Wall, Wall, Gate}
    neighbors Wall: Tower in 1..2, Gate in 0..1
    constraint connected
    constraint path(from=Gate, to=Tower)
    constraint count(Gate) == 1
    example small = assembly("examples/castle_small.glb")
    example tiny { Tower at (0, 0, 0); Wall at (2.4, 0, 0) rot (0, 0, 90) }
"""
from __future__ import annotations

from typing import Literal

from .base import Node
from .expr import Call, Expr
from .split import Arg


Vec3 = tuple[Expr, Expr, Expr]


class PartDef(Node):
    """`part NAME = geometry [symmetry(GROUP[, mirror])] [up(DIR, ...)]`.

    geometry: a call such as `mesh("f.glb")` or `box(w, d, h)`. `symmetry`: the rotations about
    the up axis under which the part looks the same ("none", "z2", "z4", ... "zN"; None: found
    from the geometry), `mirror`: its mirror image counts as the same part. `up`: the directions
    of the part's modelling frame that may point up in a shape (empty: the grammar's up axis);
    `up(any)` (`up_any`): the part may lie any way up (no orientation check; placements are
    compared up to all of its geometry's rotations)."""

    kind: Literal["part"] = "part"
    name: str
    geometry: Call
    symmetry: str | None = None
    mirror: bool = False
    up: tuple[Vec3, ...] = ()
    up_any: bool = False
    comments: tuple[str, ...] = ()


class SiteDef(Node):
    """`site Part.name at (x, y, z) facing +x [mirror x] [required]`: a docking frame on a part
    type; `required`: every part of the type must have a neighbour there."""

    kind: Literal["site"] = "site"
    part: str
    name: str
    position: tuple[Expr, Expr, Expr]
    facing: Literal["+x", "-x", "+y", "-y", "+z", "-z"] = "+x"
    mirror: Literal["x", "y", "z"] | None = None
    required: bool = False
    comments: tuple[str, ...] = ()


class UpDef(Node):
    """`up +z`: the grammar's up axis (gravity points the other way); `up none`: no up axis,
    parts may be turned any way (the behaviour before orientation was checked)."""

    kind: Literal["up"] = "up"
    axis: Literal["+x", "-x", "+y", "-y", "+z", "-z", "none"] = "+z"
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


for _cls in (PartDef, SiteDef, UpDef, Placement, DockDef, NeighborRule, ConstraintDef, InlinePart, ExampleDef):
    _cls.model_rebuild()
