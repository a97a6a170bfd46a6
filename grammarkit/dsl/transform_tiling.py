"""Lark parse tree -> IR for the statements of tiling grammars (parts, sites, docks, neighbour
rules, constraints, examples, the up axis): a mixin of transform.ToIR, whose helpers (span,
tspan, name, string_value) it uses."""
from __future__ import annotations

import re
from typing import Any

from lark import Token, Tree

from ..ir import (
    Arg, Call, ConstraintDef, CountRange, DockDef, ExampleDef, InlinePart, NeighborRule, Num, PartDef,
    Placement, Ref, SiteDef, Unary, UpDef, Vector,
)

from .parser import KEYWORDS


class TilingToIR:
    # -- tiling ----------------------------------------------------------------------------
    def part(self, meta, c):
        span = self.span(meta)
        geometry = c[1]
        if not isinstance(geometry, Call):
            self.bag.error("a part's geometry must be a call such as mesh(\"file.glb\") or box(w, d, h)",
                           getattr(geometry, "span", None) or span, code="bad-part")
            geometry = Call(func="box", args=(), span=span)
        opts: dict[str, Any] = {}
        for name, value, ospan in c[2:]:
            if name in opts:
                self.bag.error(f"part option {name}(...) given twice", ospan, code="bad-part")
            opts[name] = value
        symmetry, mirror = opts.get("symmetry", (None, False))
        up = opts.get("up", ())
        return PartDef(name=self.name(c[0]), geometry=geometry, symmetry=symmetry, mirror=mirror,
                       up=() if up == "any" else up, up_any=up == "any", span=span)

    _AXIS_VECTORS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}

    def part_option(self, meta, c):
        """`symmetry(z4[, mirror])` or `up(+z, (0, 1, 0), ...)` after a part's geometry."""
        span = self.span(meta)
        name = str(c[0])
        args = [a for a in c[1:] if isinstance(a, list)]
        args = args[0] if args else []
        mirror = any(isinstance(a, Tree) or a == "mirror" for a in c[1:] if not isinstance(a, list))
        if name == "symmetry":
            if any(a.name is not None for a in args) or len(args) > 1:
                self.bag.error("symmetry(...) takes one group (none, z2, z4, ... zN) and optionally "
                               "`mirror`", span, code="bad-symmetry")
                return ("symmetry", (None, mirror), span)
            group = None
            if args:
                v = args[0].value
                text = v.name if isinstance(v, Ref) else None
                if text == "none" or (text and re.fullmatch(r"z([1-9][0-9]{0,2})", text)):
                    group = "none" if text in ("none", "z1") else text
                else:
                    self.bag.error("a symmetry group is none, z2, z3, z4, ... (turns about the up axis "
                                   "that leave the part looking the same)", getattr(v, "span", None) or span,
                                   code="bad-symmetry")
            elif not mirror:
                self.bag.error("symmetry() needs a group (none, z2, z4, ...) or `mirror`", span,
                               code="bad-symmetry")
            return ("symmetry", (group if args else "none", mirror), span)
        if name == "up":
            if mirror or not args:
                self.bag.error("up(...) lists directions of the part's frame that may point up, "
                               "e.g. up(+z, +x) or up((0, 0, 1)), or is up(any)", span, code="bad-up")
                return ("up", (), span)
            if len(args) == 1 and isinstance(args[0].value, Ref) and args[0].value.name == "any":
                return ("up", "any", span)
            dirs = []
            for a in args:
                d = self._direction(a.value)
                if d is None or a.name is not None:
                    self.bag.error("a direction is +x, -x, +y, -y, +z, -z or a vector (x, y, z)",
                                   a.span or span, code="bad-up")
                    continue
                dirs.append(d)
            return ("up", tuple(dirs), span)
        self.bag.error(f"unknown part option '{name}(...)'; part options are symmetry(...) and up(...)",
                       self.tspan(c[0]), code="bad-part")
        return (name, None, span)

    def part_mirror(self, meta, c):
        return "mirror"

    def _direction(self, v):
        """`+x`/`-z` (a signed axis name) or a 3-vector expression, as three expressions."""
        sign, inner = 1.0, v
        if isinstance(v, Unary) and v.op in "+-" and isinstance(v.operand, Ref):
            sign, inner = (-1.0 if v.op == "-" else 1.0), v.operand
        if isinstance(inner, Ref) and inner.name in self._AXIS_VECTORS:
            span = getattr(v, "span", None)
            return tuple(Num(value=sign * x + 0.0, span=span) for x in self._AXIS_VECTORS[inner.name])
        if isinstance(v, Vector) and len(v.items) == 3:
            return tuple(v.items)
        return None

    def up_axis(self, meta, c):
        span = self.span(meta)
        head, value = str(c[0]), str(c[1])
        if head != "up":
            self.bag.error(f"unknown statement '{head} {value}' (did you mean `up +z`?)", span,
                           code="syntax")
            return UpDef(span=span)
        if value not in ("+x", "-x", "+y", "-y", "+z", "-z", "none"):
            self.bag.error(f"`up` takes an axis (+x, -x, +y, -y, +z, -z) or `none`, not '{value}'",
                           self.tspan(c[1]), code="bad-up")
            value = "+z"
        return UpDef(axis=value, span=span)

    def vec3(self, meta, c):
        return tuple(c)

    def facing(self, meta, c):
        return ("facing", str(c[0]))

    def mirror(self, meta, c):
        axis = str(c[0])
        if axis not in ("x", "y", "z"):
            self.bag.error(f"mirror axis must be x, y or z, not '{axis}'", self.tspan(c[0]),
                           code="bad-axis")
            axis = "x"
        return ("mirror", axis)

    def rot(self, meta, c):
        return ("rot", c[0])

    def site(self, meta, c):
        span = self.span(meta)
        dotted = str(c[0]).split(".")
        if len(dotted) != 2:
            self.bag.error("a site is named Part.site (exactly one dot)", self.tspan(c[0]),
                           code="bad-site")
            dotted = [dotted[0], dotted[-1]]
        for piece in dotted:
            if piece in KEYWORDS:
                self.bag.error(f"'{piece}' is a reserved word and cannot be used as a name",
                               self.tspan(c[0]), code="reserved-word")
        opts = dict(x for x in c[2:] if x is not None)
        return SiteDef(part=dotted[0], name=dotted[1], position=c[1],
                       facing=opts.get("facing", "+x"), mirror=opts.get("mirror"),
                       required=bool(opts.get("required")), span=span)

    def site_flag(self, meta, c):
        if str(c[0]) != "required":
            self.bag.error(f"unknown site flag '{c[0]}' (the only flag is `required`)", self.tspan(c[0]),
                           code="bad-site")
            return None
        return ("required", True)

    def endpoint(self, meta, c):
        pieces = str(c[0]).split(".")
        if len(pieces) > 2:
            self.bag.error("a dock end is Part or Part.site", self.tspan(c[0]), code="bad-dock")
        for piece in pieces:
            if piece in KEYWORDS:
                self.bag.error(f"'{piece}' is a reserved word and cannot be used as a name",
                               self.tspan(c[0]), code="reserved-word")
        return (pieces[0], pieces[1] if len(pieces) > 1 else None)

    def dock(self, meta, c):
        (a, a_site), (b, b_site) = c[0], c[1]
        placements = c[2] if len(c) > 2 else ()
        return DockDef(a=a, a_site=a_site, b=b, b_site=b_site, placements=placements,
                       span=self.span(meta))

    def placements(self, meta, c):
        return tuple(c)

    def placement(self, meta, c):
        rot = c[1][1] if len(c) > 1 else None
        return Placement(at=c[0], rot=rot, span=self.span(meta))

    def neighbors(self, meta, c):
        multisets: tuple = ()
        counts = []
        for x in c[1:]:
            if isinstance(x, CountRange):
                counts.append(x)
            else:
                multisets = x
        return NeighborRule(part=self.name(c[0]), multisets=multisets, counts=tuple(counts),
                            span=self.span(meta))

    def multisets(self, meta, c):
        return tuple(c)

    def multiset(self, meta, c):
        return tuple(self.name(t) for t in c)

    def _int(self, tok: Token) -> int:
        digits = str(tok).lstrip("0") or "0"
        # compared as text first: Python refuses to convert more than 4,300 digits (a ValueError)
        if len(digits) > 10 or int(digits) > 10**9:
            self.bag.error(f"count is too large (the limit is {10**9:,})", self.tspan(tok),
                           code="bad-number")
            return 10**9
        return int(digits)

    def count_between(self, meta, c):
        lo = self._int(c[1])
        hi = self._int(c[2]) if len(c) > 2 else None
        return CountRange(type=self.name(c[0]), lo=lo, hi=hi, span=self.span(meta))

    def count_exact(self, meta, c):
        n = self._int(c[1])
        return CountRange(type=self.name(c[0]), lo=n, hi=n, span=self.span(meta))

    def constraint(self, meta, c):
        span = self.span(meta)
        cmp = c[-1] if len(c) > 1 and isinstance(c[-1], tuple) else None
        rest = c[1:-1] if cmp is not None else c[1:]
        args = tuple(rest[0]) if rest and rest[0] is not None else ()
        name = self.name(c[0])
        if cmp is not None:
            op, value = cmp
            if name != "count" or len(args) != 1 or args[0].name not in (None, "type"):
                self.bag.error(f"a comparison `{op} n` follows only count(Type): "
                               "`constraint count(Entry) == 1`", span, code="bad-constraint")
            else:
                bounds = {"==": ("lo", "hi"), ">=": ("lo",), "<=": ("hi",)}[op]
                args = args + tuple(Arg(name=b, value=value, span=getattr(value, "span", span)) for b in bounds)
        return ConstraintDef(name=name, args=args, span=span)

    def count_eq(self, meta, c):
        return ("==", c[0])

    def count_ge(self, meta, c):
        return (">=", c[0])

    def count_le(self, meta, c):
        return ("<=", c[0])

    def example_file(self, meta, c):
        span = self.span(meta)
        if str(c[1]) != "assembly":
            self.bag.error(f"an example file is given as assembly(\"file\"), not {c[1]}(...)",
                           self.tspan(c[1]), code="bad-example")
        return ExampleDef(name=self.name(c[0]), source=self.string_value(c[2]), span=span)

    def example_inline(self, meta, c):
        return ExampleDef(name=self.name(c[0]), parts=tuple(c[1:]), span=self.span(meta))

    def inline_part(self, meta, c):
        span = self.span(meta)
        rot = c[2][1] if len(c) > 2 else None
        return InlinePart(type=self.name(c[0]), placement=Placement(at=c[1], rot=rot, span=span),
                          span=span)
