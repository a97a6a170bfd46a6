"""A shape of the split engine: a scope (oriented box) carrying a geometry.

The scope is an origin `o`, three orthonormal axes `ax` (world directions of the scope's
x, y, z) and a size `sz`, all plain tuples: shapes are created by the thousand per building
and pure-Python tuples are much cheaper than numpy for 3-vectors. The geometry is one of

- a face (`kind == "F"`): a planar region in the scope's xy plane; `poly is None` means the
  full rectangle [0,sx] x [0,sy], else `poly` is a tuple of contours in scope coordinates
  (counter-clockwise outer contours, clockwise holes);
- a volume (`kind == "V"`): `solid is None` and `poly is None` is the scope box, `poly` set is
  that footprint extruded over [0, sz], and `solid` set is a general manifold3d solid in scope
  coordinates (roofs, tapers, inserted meshes).

Operations (built-in and plugins') receive and return Shapes, through the members listed in
`grammarkit.hookspecs.ShapeView` only. A shape also carries its derivation's attr/const
values (`values`), so one compiled grammar serves many derivations at once: compiled
expressions read attrs from the shape they are evaluated on, never from shared state.
"""
from __future__ import annotations

import itertools
import random
from typing import Any

from ..errors import DerivationError

Vec = tuple[float, float, float]

FACE = "F"
VOLUME = "V"

# Geometry ids: every new geometry (a derived shape) gets a fresh one, copies keep it. A face
# made by comp(f) remembers the id (and scope) of the volume it came from (`on`), so that the
# engine can tell at the end whether that very volume was emitted as a solid (then the face is
# a view of the solid's surface) or consumed (then the face is emitted as a surface).
_GIDS = itertools.count(1)


class Shape:
    __slots__ = (
        "o", "ax", "sz", "kind", "poly", "solid", "color", "material", "rule", "params",
        "seed", "node", "depth", "si", "st", "entry", "cut", "values", "_rng", "gid", "on",
        "trims", "trim_on", "tex", "csel", "hole", "reveal",
    )

    def __init__(self, o: Vec, ax: tuple[Vec, Vec, Vec], sz: Vec, kind: str = FACE,
                 poly: Any = None, solid: Any = None):
        self.o = o
        self.ax = ax
        self.sz = sz
        self.kind = kind
        self.poly = poly
        self.solid = solid
        self.color: str | None = None
        self.material: str | None = None
        self.rule: Any = None  # the compiled rule being applied (name, object type, span)
        self.params: tuple = ()
        self.seed = 0
        self.node = -1  # index in the derivation tree
        self.depth = 0
        self.si = 0  # split.index / comp index given by the parent's block operation
        self.st = 1  # split.total
        self.entry: tuple | None = None  # scope when the current rule was entered (for center)
        self.cut = -1  # tag id of a recess cut made from this face, coloured by its terminal
        self.values: dict | None = None  # the derivation's attr/const values (set by the engine)
        self._rng: random.Random | None = None
        self.gid = next(_GIDS)  # geometry id (see _GIDS)
        # a face made by comp(f): (volume gid, volume origin, axes, size) of the volume it is a
        # face of; None for other shapes
        self.on: tuple | None = None
        self.trims: tuple = ()  # CGA trim planes (world point, world normal) for inserts
        self.trim_on = True  # CGA's trim.vertical: whether i() clips by the trim planes
        # CGA texturing state (grammarkit.split.ops.texturing.Texturing): projections, baked UVs,
        # material attributes; None until a texturing operation runs
        self.tex: Any = None
        self.csel = ""  # comp.sel: the selector of the block branch that made the shape
        # a face (or a piece of one) covering an opening cut into a solid, in the plane of the
        # face the opening was extruded from: in the default mode it is the hole, no geometry
        self.hole = False
        # a side or back face of such an opening: (`on` of the solid the opening is cut out of,
        # the face's origin, axes and size when comp(f) made it). In the default mode a leaf
        # still in that rectangle and facing into the opening is a view of the solid's reveal
        # (Derivation.leaf), not a slab of its own
        self.reveal: tuple | None = None

    def copy(self) -> "Shape":
        c = Shape.__new__(Shape)
        c.o, c.ax, c.sz, c.kind, c.poly, c.solid = self.o, self.ax, self.sz, self.kind, self.poly, self.solid
        c.color, c.material, c.rule, c.params = self.color, self.material, self.rule, self.params
        c.seed, c.node, c.depth, c.si, c.st = self.seed, self.node, self.depth, self.si, self.st
        c.entry, c.cut, c.values, c._rng = self.entry, self.cut, self.values, None
        c.gid, c.on, c.trims, c.trim_on = self.gid, self.on, self.trims, self.trim_on
        c.tex, c.csel, c.hole, c.reveal = self.tex, self.csel, self.hole, self.reveal
        return c

    def derived(self, o: Vec, sz: Vec, poly: Any = None, kind: str | None = None,
                ax: tuple[Vec, Vec, Vec] | None = None, solid: Any = None) -> "Shape":
        """A new shape with a new scope/geometry that inherits the tags of this one."""
        c = Shape.__new__(Shape)
        c.o, c.ax, c.sz = o, (ax if ax is not None else self.ax), sz
        c.kind = kind if kind is not None else self.kind
        c.poly, c.solid = poly, solid
        c.color, c.material, c.rule, c.params = self.color, self.material, self.rule, self.params
        c.seed, c.node, c.depth, c.si, c.st = self.seed, self.node, self.depth, self.si, self.st
        c.entry, c.cut, c.values, c._rng = self.entry, self.cut, self.values, None
        c.gid = next(_GIDS)
        c.on = self.on if c.kind == FACE else None
        c.trims, c.trim_on = self.trims, self.trim_on
        c.tex, c.csel, c.hole = self.tex, self.csel, self.hole and c.kind == FACE
        c.reveal = self.reveal if c.kind == FACE else None
        return c

    def rng(self) -> random.Random:
        """The shape's own generator, seeded from the run seed and its derivation path."""
        if self._rng is None:
            self._rng = random.Random(self.seed)
        return self._rng

    # Convenience for plugins and debugging; the engine reads the tuples directly.
    @property
    def size(self) -> Vec:
        return self.sz

    @property
    def is_face(self) -> bool:
        return self.kind == FACE

    @property
    def rule_name(self) -> str:
        """The rule being applied to the shape (for messages)."""
        return getattr(self.rule, "name", "?")

    @property
    def rule_span(self) -> Any:
        """Where the rule being applied is written (a Span, or None), for located warnings."""
        return getattr(self.rule, "span", None)

    @property
    def index(self) -> int:
        """`split.index`: this shape's position among its parent block's children."""
        return self.si

    @property
    def total(self) -> int:
        """`split.total`: how many children its parent block made."""
        return self.st

    def contours(self) -> tuple:
        """The face/footprint contours in scope coordinates (the rectangle if `poly` is None)."""
        if self.poly is not None:
            return self.poly
        sx, sy = self.sz[0], self.sz[1]
        return (((0.0, 0.0), (sx, 0.0), (sx, sy), (0.0, sy)),)

    def world(self, x: float, y: float, z: float) -> Vec:
        """A point given in scope coordinates, in world coordinates."""
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = self.ax
        ox, oy, oz = self.o
        return (ox + ax * x + bx * y + cx * z, oy + ay * x + by * y + cy * z, oz + az * x + bz * y + cz * z)

    def __repr__(self) -> str:
        name = getattr(self.rule, "name", "?")
        return f"Shape({name}, kind={self.kind}, o={self.o}, size={self.sz})"


def fail(s: Shape, message: str, span: Any = None, **kw: Any) -> DerivationError:
    """A DerivationError naming the shape's rule and node, located at `span` (or the rule)."""
    rule = getattr(s.rule, "name", "?")
    return DerivationError(f"in rule {rule!r} (shape #{s.node}): {message}", span or getattr(s.rule, "span", None), **kw)
