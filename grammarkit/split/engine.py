"""The derivation engine: runs compiled rules on shapes and collects the building's solids.

One `Derivation` per model. Shapes wait on an explicit stack (no recursion limit for deep
grammars); each compiled step transforms the current shape or hands it on. What becomes
geometry (decided here, documented in docs/operations.md "Watertight output"):

- volumes that end as leaves, volumes decomposed by `comp(f)` (the *body*), roofs, extruded
  faces and inserted meshes are *added*;
- faces that went through `recess(d)` are *cut* out of the union (one batched subtraction);
- other faces have no volume: they tag (colour/material) the body surface they lie on.

Every solid gets a manifold3d original ID mapped to its semantic tags, so the triangles of the
final union can be traced back to the terminal (or body) they came from.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any

import manifold3d

from ..errors import DerivationError, LimitError
from ..geometry.footprints import cross_section
from ..geometry.solids import frame_matrix as frame
from .seeds import M64, label_of, mix  # noqa: F401 - label_of re-exported
from ..geometry.surfaces import SurfaceMesh
from .shape import FACE, Shape, fail  # noqa: F401 - fail re-exported
from .scope_solid import local_solid

Manifold = manifold3d.Manifold

# How far a recess cut reaches out of its face, so that the cut's opening never lies exactly
# in the facade plane (coplanar faces would make the boolean's result depend on round-off).
CUT_OUTSET = 0.25

# Every added solid is grown by this much on each side so touching solids fuse (see welded_frame).
WELD = 1e-3
# Recess cuts are grown sideways by this much (see add_cut): less than any solid's growth
# (WELD .. 1.5 WELD, see weld_of), so a cut's grown side never lies in a grown solid's face.
CUT_WELD = 0.5 * WELD
# The default mode: the reversed walls of a CGA opening are views of the solid's reveal
# (Derivation.leaf); off, they are slabs as before issue 27's second step (kept so that
# benchmarks/bench_prt.py --baseline measures that path in the same run).
REVEAL_VIEWS = True


# how a derivation treats faces and open meshes (Derivation(surfaces=...), derive(surfaces=...))
SURFACE_MODES = ("solid", "cga")

# print() messages kept per derivation (more are counted in Model.messages' last line)
MAX_MESSAGES = 10_000


@dataclass(frozen=True)
class Limits:
    """Resource guards; exceeding one ends the derivation with a LimitError naming the rule."""

    max_depth: int = 64  # rule applications along one derivation path
    max_shapes: int = 100_000  # shapes created in one derivation
    max_repeat: int = 2_000  # repetitions of one repeat group / pattern
    max_triangles: int = 2_000_000  # triangles of the final mesh
    # largest coordinate or size of any solid, in model units (metres): beyond ~1e5 the float32
    # vertices of GLB/STL files cannot hold the 1 mm weld between touching solids, and at 1e300
    # the solids' vertices overflow to inf/NaN
    max_extent: float = 100_000.0
    # solids fed to the final boolean (added volumes and recess cuts): the union's cost grows
    # faster than linearly (20,000 boxes take ~15 s), so this bounds the time of one building
    max_solids: int = 20_000

    def __post_init__(self) -> None:
        for name in ("max_depth", "max_shapes", "max_repeat", "max_triangles", "max_solids"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise DerivationError(f"Limits({name}=...) must be a positive integer, got {v!r}",
                                      None, code="bad-argument")
        v = self.max_extent
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < math.inf:
            raise DerivationError(f"Limits(max_extent=...) must be a positive finite number, got {v!r}",
                                  None, code="bad-argument")


class Tag:
    """Semantic tags of one solid or face terminal."""

    __slots__ = ("name", "rule", "object_type", "color", "material", "node", "role", "texturing")

    def __init__(self, name: str, rule: str, object_type: str | None, color: str | None,
                 material: str | None, node: int, role: str, texturing: Any = None):
        self.name, self.rule, self.object_type = name, rule, object_type
        self.color, self.material, self.node, self.role = color, material, node, role
        # CGA texturing state (grammarkit.split.ops.texturing.Texturing) or None
        self.texturing = texturing

    def to_dict(self) -> dict:
        return {"name": self.name, "rule": self.rule, "object_type": self.object_type,
                "color": self.color, "material": self.material, "node": self.node, "role": self.role}


class Derivation:
    """Mutable state of one derivation: everything one run needs lives here (and in its
    shapes), nothing in the compiled grammar, so derivations of one grammar may run at once.

    Operations never see this object: they get its `context` (an OperationContext)."""

    def __init__(self, compiled: Any, seed: int, limits: Limits, values: dict | None = None,
                 registries: Any = None, base_dir: str | None = None, surfaces: str = "solid"):
        self.compiled = compiled
        # "solid" (the default): every part is closed, one watertight solid per connected mass
        # (comp(f) keeps the volume it decomposes as the solid its faces are views of; faces
        # off every solid, open inserted meshes and flat volumes get THICKNESS); "cga":
        # CityEngine's open faces, the surface layer (docs/operations.md, "Watertight output")
        if surfaces not in SURFACE_MODES:
            raise DerivationError(f"surfaces= must be one of {', '.join(map(repr, SURFACE_MODES))}, "
                                  f"got {surfaces!r}", None, code="bad-argument")
        self.surfaces_mode = surfaces
        self.seed = int(seed) & M64
        self.limits = limits
        self.values = values if values is not None else {}
        self.registries = registries
        self.base_dir = base_dir
        self.stack: list[tuple[Shape, tuple]] = []
        # tree: (parent, rule name, kind, origin, axes, size, seed, span, via)
        self.nodes: list[tuple] = []
        self.tags: list[list] = []  # [name, rule, object type, colour, material, node, role, texturing]
        self.adds: list[Any] = []  # world-space solids to unite
        # recess cuts: (world-space solid, `on` of the face, tag, origin, axes, size, poly,
        # depth); subtracted when the face lies on an emitted solid, else shown as a reveal
        self.cuts: list[tuple] = []
        self.post_adds: list[Any] = []  # solids to add after the cuts (built inside a recess)
        # the default mode's openings: index in `adds` of a closing solid -> the solids cut out
        # of it alone (before the union), and the index of each closing solid by geometry id
        self.openings: dict[int, list] = {}
        self.add_of: dict[int, int] = {}
        # the closing solids (add_closing): (geometry id, tree node, index in `adds`, scope);
        # one that no surviving terminal spans is taken out again (drop_unspanned_closings)
        self.closings: list[tuple] = []
        self.holes: set[int] = set()  # tags of face terminals covering an opening
        self.reveal_tags: set[int] = set()  # tags of face terminals painting an opening's walls
        self.add_boxes: list[tuple] = []  # world bounding box of each of `adds`
        # index in `adds` -> (solid in scope coordinates, origin, axes, size, its local box), and
        # the box openings (index of the closing solid, corner, axes, size): parts lying inside
        # an opening, clear of every other part, skip the union (grammarkit/split/union.py)
        self.add_local: dict[int, tuple] = {}
        self.opening_boxes: list[tuple] = []
        self.id_tag: dict[int, int] = {}  # manifold original ID -> tag index
        self.faces: list[tuple] = []  # face terminals: (tag, origin, axes, size, poly, on)
        # geometry id of every volume emitted as a solid -> (scope when emitted, tag): a face
        # of that volume (its `on`) is a view of the solid's surface (see Shape.on)
        self.solid_of: dict[int, tuple] = {}
        # open surfaces: (tag, world vertices (n, 3), triangles (m, 3)), e.g. open inserts
        self.surfaces: list[tuple] = []
        self.leaves: list[tuple] = []  # (tag, origin, axes, size) of each terminal, in order
        self.warnings: list[str] = []
        self.warned: set[str] = set()
        # report(key, value) calls in derivation order: key -> values (CGA's reports)
        self.reports: dict[str, list] = {}
        # print(value) calls in derivation order (CGA's print: Model.messages, `grammarkit derive`)
        self.messages: list[str] = []
        self.messages_dropped = 0
        self.est_tris = 0
        # occluders for inside()/overlaps()/touches() (grammarkit/split/occlusion.py): kept only
        # when the grammar asks such queries (terminals are registered as they are made)
        self.occlusion: Any = None
        self.track_occlusion = bool(getattr(compiled, "uses_occlusion", False))
        self.context = OperationContext(self)

    # -- bookkeeping --------------------------------------------------------------------
    def _node(self, s: Shape, parent: int, via: str) -> None:
        nodes = self.nodes
        s.node = len(nodes)
        if s.node >= self.limits.max_shapes:
            raise LimitError(
                f"shape limit exceeded: more than {self.limits.max_shapes} shapes "
                f"(while applying rule {s.rule.name!r})", s.rule.span, code="limit-shapes",
                hint="a rule probably recurses without end, or a split makes far too many parts")
        nodes.append((parent, s.rule.name, s.kind, s.o, s.ax, s.sz, s.seed, s.rule.span, via))

    def start(self, rule: Any, shape: Shape) -> None:
        shape.values = self.values
        shape.rule = rule
        shape.seed = mix(self.seed, rule.label)
        shape.entry = (shape.o, shape.ax, shape.sz)
        self._node(shape, -1, "axiom")
        self.stack.append((shape, rule.steps))

    def enter(self, s: Shape, rule: Any, params: tuple) -> None:
        """Hand shape `s` (already a copy if needed) to `rule`: a new node of the tree."""
        parent = s.node
        depth = s.depth + 1
        if depth > self.limits.max_depth:
            raise LimitError(
                f"depth limit exceeded: more than {self.limits.max_depth} nested rule applications "
                f"(rule {rule.name!r} applied from {s.rule.name!r})", s.rule.span, code="limit-depth",
                hint="a rule probably calls itself without a terminating case")
        s.depth = depth
        s.seed = mix(s.seed, rule.label)
        s.rule = rule
        s.params = params
        s.entry = (s.o, s.ax, s.sz)
        s._rng = None
        self._node(s, parent, "rule")
        self.stack.append((s, rule.steps))

    def spawn(self, s: Shape, children: list, via: str) -> None:
        """Children of a block operation: each runs its slot's body on its own shape."""
        depth = s.depth + 1
        if depth > self.limits.max_depth:
            raise LimitError(f"depth limit exceeded in rule {s.rule.name!r}", s.rule.span,
                             code="limit-depth")
        if via == "comp" and self.surfaces_mode == "solid" and s.kind != FACE:
            self._keep_comp_volume(s, children)
        parent = s.node
        seed = s.seed
        pending = []
        total = len(children)
        for i, item in enumerate(children):
            c, slot = item[0], item[1]
            c.depth = depth
            c.seed = mix(seed, slot.label + i)
            if len(item) > 2:  # (child, slot, index, total): the operation numbers its parts
                c.si, c.st = item[2], item[3]
            else:
                c.si, c.st = i, total  # split.index / split.total of the child
            sel = slot.sel
            if sel is not None:  # comp.sel: the branch's selector ("front", "3", ...)
                c.csel = sel if type(sel) is str else str(sel)
            c._rng = None
            self._node(c, parent, via)
            pending.append((c, slot.body))
        pending.reverse()  # the stack pops the first child first
        self.stack.extend(pending)

    def _keep_comp_volume(self, s: Shape, children: list) -> None:
        """The default mode, one watertight solid: a volume that comp(f) consumes (CGA) stays
        as the solid its faces are views of, unless `volume:` keeps it (then it is emitted as
        written). Told by the children: faces of this volume, and no copy of it."""
        gid = s.gid
        if s.on is not None and self._open_into(s):
            top = s.sz[2]  # the cap in the plane of the face it was extruded from: the hole
            solid_on = (s.on[0], self.solid_of[s.on[0]][0])  # the solid it is cut out of
            for item in children:
                c = item[0]
                if c.kind != FACE or c.on is None or c.on[0] != gid:
                    continue
                if c.ax[2] == s.ax[2] and abs(sum((c.o[k] - s.o[k]) * s.ax[2][k] for k in range(3)) - top) < 1e-9:
                    c.hole = True
                else:  # a wall of the hole: the solid's reveal there (leaf)
                    c.reveal = (solid_on, c.o, c.ax, c.sz)
            return
        faces = False
        for item in children:
            c = item[0]
            if c.gid == gid:
                return  # `volume:` hands the volume on
            if c.kind == FACE and c.on is not None and c.on[0] == gid:
                faces = True
        if faces:
            self.add_closing(s)

    def _open_into(self, s: Shape) -> bool:
        """A volume extruded inwards from a face of a closing solid (CGA's window opening,
        `extrude(-d) comp(f) { side: Reveal | ... }`): CityEngine shows a hole there, so it is
        cut out of that solid (only: a window inserted in the opening stays), its walls tagged
        with the opening's rule. Whether `s` was one (Shape.on of such a volume is its face's)."""
        hit = self.solid_of.get(s.on[0])
        if hit is None or hit[0] != s.on[1] or self.tags[hit[1]][6] != "closing":
            return False
        index = self.add_of.get(s.on[0])
        if index is None:
            return False
        w = CUT_WELD
        h = s.sz[2] + CUT_OUTSET  # out through the face, so the opening is never coplanar
        if s.poly is None:
            solid = Manifold.cube((s.sz[0] + 2 * w, s.sz[1] + 2 * w, h))
            d = (-w, -w, 0.0)
        else:
            solid = Manifold.extrude(cross_section(s.poly).offset(w, manifold3d.JoinType.Miter, 2.0), h)
            d = (0.0, 0.0, 0.0)
        tag = self._tag(s, s.rule.name, "cut")
        self.id_tag[solid.original_id()] = tag
        x, y, z = s.ax
        o = tuple(s.o[k] + x[k] * d[0] + y[k] * d[1] + z[k] * d[2] for k in range(3))
        self.openings.setdefault(index, []).append(solid.transform(frame(o, s.ax)))
        if s.poly is None:
            self.opening_boxes.append((index, o, s.ax, (s.sz[0] + 2 * w, s.sz[1] + 2 * w, h)))
        self.est_tris += 12
        return True

    def push(self, s: Shape, steps: tuple) -> None:
        self.stack.append((s, steps))

    def run(self) -> None:
        from .occlusion import set_active

        previous = set_active(self)  # occlusion queries find their derivation through it
        try:
            self._run()
        finally:
            set_active(previous)

    def _run(self) -> None:
        stack = self.stack
        while stack:
            s, steps = stack.pop()
            for step in steps:
                s = step(self, s)
                if s is None:
                    break
            else:
                self.leaf(s, s.rule.name)

    def occluder(self, s: Shape, label: str | None) -> None:
        """Register `s`'s geometry for the occlusion queries of later shapes."""
        if self.occlusion is None:
            from .occlusion import Occlusion

            self.occlusion = Occlusion()
        self.occlusion.add(s, label)

    def run_inline(self, s: Shape, steps: tuple) -> Shape | None:
        """Run a nested sequence (a case arm, a choice) on `s`; returns what is left of it."""
        for step in steps:
            s = step(self, s)
            if s is None:
                return None
        return s

    # -- geometry collection ------------------------------------------------------------
    def _tag(self, s: Shape, name: str, role: str) -> int:
        # plain lists in the hot loop; Model turns them into Tag objects on demand
        rule = s.rule
        tags = self.tags
        tags.append([name, rule.name, rule.otype, s.color, s.material, s.node, role, s.tex])
        return len(tags) - 1

    def check_extent(self, s: Shape, box: tuple | None = None) -> None:
        """LimitError naming the rule if the scope of `s` (or `box`, its solid's bounds in scope
        coordinates) is not finite or exceeds Limits.max_extent."""
        lim = self.limits.max_extent
        o, sz = s.o, s.sz
        # written so that NaN fails too (every comparison with NaN is false)
        if (abs(o[0]) <= lim and abs(o[1]) <= lim and abs(o[2]) <= lim and sz[0] <= lim
                and sz[1] <= lim and sz[2] <= lim
                and (box is None or all(abs(v) <= lim for v in box))):
            return
        what = "a solid" if box is not None else "the scope"
        raise LimitError(
            f"extent limit exceeded: {what} of rule {s.rule.name!r} reaches beyond "
            f"{lim:g} model units (scope origin {tuple(float(f'{v:.4g}') for v in o)}, "
            f"size {tuple(float(f'{v:.4g}') for v in sz)})", s.rule.span, code="limit-extent",
            hint="a size or translation is far too large (or not a number)")

    def check_solids(self, s: Shape) -> None:
        if len(self.adds) + len(self.post_adds) + len(self.cuts) >= self.limits.max_solids:
            raise LimitError(
                f"solid limit exceeded: more than {self.limits.max_solids} solids to unite "
                f"(while applying rule {s.rule.name!r})", s.rule.span, code="limit-solids",
                hint="a split probably makes far too many volume parts; raise Limits(max_solids=...) "
                     "if the building really needs them")

    def _add(self, s: Shape, tag: int) -> None:
        self.check_extent(s)
        if type(s.solid) is SurfaceMesh:  # an open mesh (an inserted asset)
            if self.surfaces_mode == "cga":  # a surface, as CGA inserts it
                self.add_surface(tag, s.solid.world(s.o, s.ax), s.solid.F, s)
                return
            from ..geometry.closing import close_mesh

            closed = close_mesh(s.solid.V, s.solid.F)  # cached: one per asset and size
            if closed is None:
                return
            s = s.copy()
            s.solid = closed.as_original()  # a new original ID: its own tag, though cached
        self.check_solids(s)
        solid, oid, tris = local_solid(s)
        if solid is not None and s.solid is not None:
            self.check_extent(s, solid.bounding_box())
        if solid is None:
            # a volume without thickness (extrude(0), CGA's flat "volumes"): what CityEngine
            # shows is its footprint; it cannot be a solid, so it is that face in the surface
            # layer (only when the thin axis is z; a box thin along x or y is left out)
            flat = s.solid is None and s.sz[2] <= 1e-9 and s.sz[0] > 1e-9 and s.sz[1] > 1e-9
            if flat and self.surfaces_mode == "solid":  # its footprint, THICKNESS thick
                self.add_slab(tag, s.o, s.ax, s.sz, s.poly, s.rule.span)
                return
            message = (f"rule {s.rule.name!r}: a volume of size {tuple(round(v, 4) for v in s.sz)} "
                       "has no thickness: " + ("its footprint is emitted as a surface" if flat
                                               else "it was left out of the mesh"))
            if message not in self.warned:
                self.warned.add(message)
                self.warnings.append(message)
            if flat:
                from ..geometry.surfaces import face_triangles

                V, F = face_triangles(s.o, s.ax, s.sz, s.poly)
                self.add_surface(tag, V, F, s)
            return
        self.id_tag[oid] = tag
        self.solid_of[s.gid] = ((s.o, s.ax, s.sz), tag)
        # solids built inside a recess (a mullion) are added after the cuts, or the cut eats them
        n = len(self.adds) + len(self.post_adds)
        frame_m = welded_frame(s.o, s.ax, s.sz, weld_of(n))
        if s.cut >= 0:
            self.post_adds.append(solid.transform(frame_m))
        else:
            self.adds.append(solid.transform(frame_m))
            # its world bounding box, from the scope (cheaper than asking the transformed solid,
            # which would apply the transform now): the final boolean groups solids by them
            local = (0.0, 0.0, 0.0, *s.sz) if s.solid is None else solid.bounding_box()
            self.add_boxes.append(_box_of(frame_m, local))
            self.add_local[len(self.adds) - 1] = (solid, s.o, s.ax, s.sz, local)
        self.est_tris += tris
        if self.est_tris > self.limits.max_triangles:  # stop now, not after building them all
            raise LimitError(
                f"triangle limit exceeded: the solids so far have about {self.est_tris} triangles, "
                f"more than {self.limits.max_triangles} (while applying rule {s.rule.name!r})",
                s.rule.span, code="limit-triangles")

    def add_surface(self, tag: int, V: Any, F: Any, s: Shape) -> None:
        """Emit an open surface (world vertices, triangles) with the tags of `tag`."""
        n = len(F)
        if n == 0:
            return
        self.est_tris += n
        if self.est_tris > self.limits.max_triangles:
            raise LimitError(
                f"triangle limit exceeded: the model so far has about {self.est_tris} triangles, "
                f"more than {self.limits.max_triangles} (while applying rule {s.rule.name!r})",
                s.rule.span, code="limit-triangles")
        self.surfaces.append((tag, V, F))

    def leaf(self, s: Shape, name: str) -> None:
        """`s` becomes a terminal named `name`."""
        if s.kind == FACE:
            tag = self._tag(s, name, "face")
            on = s.on
            if self.surfaces_mode == "solid":
                if s.hole:
                    self.holes.add(tag)  # it covers an opening: no slab (compose)
                elif REVEAL_VIEWS and s.reveal is not None and on is None and _on_reveal(s):
                    on = s.reveal[0]  # a view of the reveal cut into the solid: paints it
                    self.reveal_tags.add(tag)
            self.faces.append((tag, s.o, s.ax, s.sz, s.poly, on))
            if s.cut >= 0:  # the recess this face came from takes the terminal's tags
                t = self.tags[s.cut]
                if t[6] == "cut-pending":
                    t[:] = [name, s.rule.name, s.rule.otype, s.color, s.material, s.node, "cut", s.tex]
        else:
            tag = self._tag(s, name, "volume")
            self._add(s, tag)
        self.leaves.append((tag, s.o, s.ax, s.sz))
        if self.track_occlusion:
            self.occluder(s, None)

    def add_body(self, s: Shape) -> None:
        """A volume decomposed by comp(f) stays as the solid body its faces decorate."""
        self._add(s, self._tag(s, s.rule.name, "body"))

    def add_closing(self, s: Shape) -> None:
        """The default (`surfaces="solid"`) for a volume comp(f) consumes: it stays as the
        solid its faces are views of. What no face terminal covers (faces CGA drops: not
        selected, NIL) keeps the tag role "closing", so viewers can hide it."""
        if s.solid is None and min(s.sz) <= 1e-9:
            return  # no volume (a flat "volume"): its face terminals are made slabs instead
        n = len(self.adds)
        self._add(s, self._tag(s, s.rule.name, "closing"))
        if len(self.adds) == n + 1:
            self.add_of[s.gid] = n  # openings are cut out of it (`_open_into`)
            self.closings.append((s.gid, s.node, n, (s.o, s.ax, s.sz)))

    def add_slab(self, tag: int, o: tuple, ax: tuple, sz: tuple, poly: Any, where: Any) -> None:
        """A face terminal off every solid, as a closed part (`surfaces="solid"`): the face
        extruded THICKNESS behind its front (against its normal), so its visible side stays."""
        from ..geometry.closing import THICKNESS

        if sz[0] <= 1e-9 or sz[1] <= 1e-9:
            return
        if len(self.adds) + len(self.post_adds) + len(self.cuts) >= self.limits.max_solids:
            raise LimitError(f"solid limit exceeded: more than {self.limits.max_solids} solids to unite",
                             where, code="limit-solids")
        if poly is None:
            solid, tris = Manifold.cube((sz[0], sz[1], THICKNESS)), 12
        else:
            solid, tris = Manifold.extrude(cross_section(poly), THICKNESS), 4 * sum(len(c) for c in poly)
        if solid.is_empty():
            return
        self.id_tag[solid.original_id()] = tag
        z = ax[2]
        back = (o[0] - z[0] * THICKNESS, o[1] - z[1] * THICKNESS, o[2] - z[2] * THICKNESS)
        size = (sz[0], sz[1], THICKNESS)
        frame_m = welded_frame(back, ax, size, weld_of(len(self.adds) + len(self.post_adds)))
        self.adds.append(solid.transform(frame_m))
        self.add_boxes.append(_box_of(frame_m, (0.0, 0.0, 0.0, *size)))
        self.est_tris += tris
        self.check_triangles(self.est_tris, where)

    def recess(self, s: Shape, depth: float) -> Shape:
        """Cut face `s` `depth` into the solid below it; the face moved to the recess bottom."""
        c = s.copy()
        c.cut = self.add_cut(s, depth)
        z = s.ax[2]
        c.o = (s.o[0] - z[0] * depth, s.o[1] - z[1] * depth, s.o[2] - z[2] * depth)
        return c

    def add_cut(self, s: Shape, depth: float) -> int:
        """Subtract the prism of face `s` from z = -depth to just above its plane."""
        self.check_extent(s)
        self.check_solids(s)
        if not depth <= self.limits.max_extent:
            self.check_extent(s, (depth,))
        tag = self._tag(s, s.rule.name, "cut-pending")
        h = depth + CUT_OUTSET
        # grown by CUT_WELD sideways, like added solids: cuts of neighbouring panes that share a
        # side face exactly would otherwise leave a zero-thickness sliver of wall between them,
        # whose pinched edges break watertightness once a reader welds vertices by position
        x, y, z = s.ax
        w = CUT_WELD
        if s.poly is None:
            solid = Manifold.cube((s.sz[0] + 2 * w, s.sz[1] + 2 * w, h))
            d = (-w, -w, -depth)  # the cube's corner in scope coordinates
        else:
            solid = Manifold.extrude(cross_section(s.poly).offset(w, manifold3d.JoinType.Miter, 2.0), h)
            d = (0.0, 0.0, -depth)
        self.id_tag[solid.original_id()] = tag
        o = tuple(s.o[k] + x[k] * d[0] + y[k] * d[1] + z[k] * d[2] for k in range(3))
        self.cuts.append((solid.transform(frame(o, s.ax)), s.on, tag, s.o, s.ax, s.sz, s.poly, depth))
        self.est_tris += 12
        return tag

    def is_on_solid(self, on: tuple | None) -> bool:
        """Whether a face made by comp(f) of a volume (`Shape.on`) lies on an emitted solid:
        that very volume, unmoved, ended as a solid (kept by `volume:` or a push)."""
        if on is None:
            return False
        hit = self.solid_of.get(on[0])
        return hit is not None and hit[0] == on[1]

    def check_triangles(self, n: int, where: Any) -> None:
        if n > self.limits.max_triangles:
            raise LimitError(f"triangle limit exceeded: {n} > {self.limits.max_triangles}", where,
                             code="limit-triangles")


class OperationContext:
    """What an operation's `apply(ctx, shape, args, block)` receives as `ctx`: the small,
    documented part of a derivation operations may use (grammarkit.hookspecs.OperationContext
    lists it; docs/plugins.md shows it in use). One per derivation."""

    __slots__ = ("_derivation", "limits", "registries", "base_dir", "seed", "cache")

    def __init__(self, derivation: Derivation):
        # a weak reference: the derivation holds its context, and a reference cycle would keep
        # every finished derivation (its solids, tags, tree) alive until the cycle collector runs
        self._derivation = weakref.proxy(derivation)
        self.limits: Limits = derivation.limits
        self.registries = derivation.registries
        self.base_dir: str | None = derivation.base_dir
        self.seed: int = derivation.seed
        # per-derivation memo for operations (the split op keeps layouts of fixed blocks here)
        self.cache: dict = {}

    def attr(self, name: str) -> Any:
        """The value of attr or const `name` in this derivation (KeyError if there is none)."""
        return self._derivation.values[name]

    @property
    def attrs(self) -> dict:
        """Every attr and const value of this derivation (a copy)."""
        return dict(self._derivation.values)

    def add_solid(self, shape: Shape, name: str | None = None) -> None:
        """Add a volume shape's solid to the model as a terminal named `name` (default: the
        rule's name), without ending the shape."""
        d = self._derivation
        d._add(shape, d._tag(shape, name or shape.rule.name, "volume"))

    def add_body(self, shape: Shape) -> None:
        """Keep a volume decomposed into faces as the body solid its faces decorate."""
        self._derivation.add_body(shape)

    def recess(self, face: Shape, depth: float) -> Shape:
        """Cut face `face` `depth` into the solid below it; returns the face moved to the
        bottom of the recess, whose terminal colours the cut."""
        return self._derivation.recess(face, depth)

    def terminal(self, shape: Shape, name: str) -> None:
        """Make `shape` (a face or a volume) a terminal named `name`, as `Name.` does."""
        self._derivation.leaf(shape, name)

    def report(self, key: str, value: Any) -> None:
        """Record a value under a report key (CGA's report(); summed up in `Model.reports`)."""
        self._derivation.reports.setdefault(key, []).append(value)

    def message(self, text: str) -> None:
        """A message of the derivation (CGA's print()): kept in order on `Model.messages`; past
        MAX_MESSAGES they are counted, not kept (a print in a loop over thousands of shapes)."""
        d = self._derivation
        if len(d.messages) < MAX_MESSAGES:
            d.messages.append(text)
        else:
            d.messages_dropped += 1

    def warn(self, message: str) -> None:
        """A warning of the derivation (listed on the model and by the CLI); a message already
        given is not repeated (a split in a facade runs for every floor)."""
        d = self._derivation
        if message not in d.warned:
            d.warned.add(message)
            d.warnings.append(message)


def _box_of(m: list, local: tuple) -> tuple:
    """The world bounding box of the local box `local` (x0, y0, z0, x1, y1, z1) under the
    affine map `m` (3 x 4 rows)."""
    lo, hi = [], []
    for r in range(3):
        row = m[r]
        a = b = row[3]
        for k in range(3):
            u, v = row[k] * local[k], row[k] * local[k + 3]
            a += min(u, v)
            b += max(u, v)
        lo.append(a)
        hi.append(b)
    return (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2])


def weld_of(n: int) -> float:
    """How much the n-th solid is grown: WELD to 1.5 x WELD, a different amount for each solid
    (golden-ratio sequence, deterministic). With one amount for all, two solids whose faces were
    coplanar (a ledge as deep as the roof's overhang) stay coplanar after growing and meet along
    an edge only, which the union keeps as pinched, non-manifold vertices."""
    return WELD * (1.0 + 0.5 * ((n * 0.6180339887498949) % 1.0))


def welded_frame(o: tuple, ax: tuple, sz: tuple, weld: float = WELD) -> list[list[float]]:
    """The scope frame of an added solid, grown by WELD on every side about the scope centre.

    Solids that merely touch (a ledge on a wall, a railing on a slab, a tower on its podium)
    share a face exactly; manifold3d's symbolic perturbation may then keep them as separate
    shells in the union. Growing every added solid by a millimetre makes touching solids
    overlap, so the union is one connected solid; nobody sees a millimetre on a building.
    """
    # a size near zero (a flat insert's float noise, 1e-9 m) is not grown: scaled by
    # (size + 2 WELD) / size, the solid closed about it (a slab 1 cm thick) would reach km away
    f = [(sz[i] + 2 * weld) / sz[i] if sz[i] > 1e-6 else 1.0 for i in range(3)]
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = ax
    # world = o + R * (c + F * (p - c)),  c = scope centre  ->  o + R*(c - F*c) + (R*F) p
    sh = [sz[i] / 2 * (1 - f[i]) for i in range(3)]
    ox = o[0] + a0 * sh[0] + b0 * sh[1] + c0 * sh[2]
    oy = o[1] + a1 * sh[0] + b1 * sh[1] + c1 * sh[2]
    oz = o[2] + a2 * sh[0] + b2 * sh[1] + c2 * sh[2]
    return [[a0 * f[0], b0 * f[1], c0 * f[2], ox], [a1 * f[0], b1 * f[1], c1 * f[2], oy],
            [a2 * f[0], b2 * f[1], c2 * f[2], oz]]


def _on_reveal(s: Shape) -> bool:
    """Whether face `s` (with `Shape.reveal`) still lies in the wall of the opening it was made
    as (same plane, inside that face's rectangle) and faces into the opening (reversed, as
    CGA's `comp(f) { side: reverseNormals() Reveal }` does): then it is a view of the solid's
    reveal there. A face moved off it or facing into the wall stays a slab of its own."""
    _solid_on, o0, (x0, y0, n0), (sx0, sy0, _sz0) = s.reveal  # type: ignore[misc]
    ex, ey, ez = s.ax
    if ez[0] * n0[0] + ez[1] * n0[1] + ez[2] * n0[2] > -0.999999:
        return False
    tol = 1e-6
    sx, sy = s.sz[0], s.sz[1]
    for u, v in ((0.0, 0.0), (sx, 0.0), (0.0, sy), (sx, sy)):
        p = [s.o[k] + ex[k] * u + ey[k] * v - o0[k] for k in range(3)]
        if abs(p[0] * n0[0] + p[1] * n0[1] + p[2] * n0[2]) > tol:
            return False
        a = p[0] * x0[0] + p[1] * x0[1] + p[2] * x0[2]
        b = p[0] * y0[0] + p[1] * y0[1] + p[2] * y0[2]
        if not (-tol <= a <= sx0 + tol and -tol <= b <= sy0 + tol):
            return False
    return True
