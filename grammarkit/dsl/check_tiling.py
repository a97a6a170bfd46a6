"""The checker's tiling-grammar half: parts, sites, docks, neighbour rules, constraints and
examples. A mixin of `Checker`, whose definitions and expression checks it uses."""
from __future__ import annotations

from ..ir import Ref, SiteDef
from ..ir.base import Span
from .binding import bind_operation
from .check_common import BUILTIN_CONSTRAINTS, _Scope
from .suggest import known_hint as _known_hint


class TilingChecks:
    # -- tiling ----------------------------------------------------------------------------
    def _part_ref(self, name: str, span: Span | None, what: str) -> None:
        if name not in self.parts:
            self._unknown_part_uses.setdefault(name, []).append((span, what))

    def _report_unknown_parts(self) -> None:
        """One error per unknown part type, at its first use in the file: a missing `part` line
        would otherwise repeat in every neighbour set, dock and example."""
        def position(use):
            span = use[0]
            return (span.line, span.column) if span is not None else (1 << 30, 0)

        for name, uses in self._unknown_part_uses.items():
            span, what = min(uses, key=position)
            more = len(uses) - 1
            also = f" (and {more} more use{'s' if more > 1 else ''})" if more else ""
            self.bag.error(f"unknown part type '{name}' in {what}{also}", span,
                           hint=_known_hint("part types", name, self.parts) if self.parts
                           else f"declare it with `part {name} = box(w, d, h)` or "
                                f"`part {name} = mesh(\"file.glb\")`", code="unknown-part")

    def check_tiling(self) -> None:
        g = self.g
        values = _Scope(set(self._values), {})
        for p in g.parts:
            # the geometry constructor (mesh, box, ...) belongs to the tiling engine; check its args
            for a in p.geometry.args:
                self.check_expr(a, values)
        sites = self._check_sites(values)
        self._check_docks(values, sites)
        ups = g.ups
        for extra in ups[1:]:
            self.bag.error("the grammar's up axis is given twice", extra.span,
                           hint=f"the first `up` is at {ups[0].span}", code="duplicate")
        for p in g.parts:
            for d in p.up:
                for x in d:
                    self.check_expr(x, values)
        self._check_neighbor_rules()
        self._check_constraints(values)
        for e in g.examples:
            for ip in e.parts:
                self._part_ref(ip.type, ip.span or e.span, f"example {e.name}")
                for x in ip.placement.at + (ip.placement.rot or ()):
                    self.check_expr(x, values)

    def _check_sites(self, values: _Scope) -> dict[tuple[str, str], SiteDef]:
        """Sites: their parts, duplicates, positions; returns them by (part, name)."""
        sites: dict[tuple[str, str], SiteDef] = {}
        for s in self.g.sites:
            self._part_ref(s.part, s.span, "site")
            key = (s.part, s.name)
            if key in sites:
                self._dup("site", f"{s.part}.{s.name}", s, sites[key])
            sites[key] = s
            for x in s.position:
                self.check_expr(x, values)
        return sites

    def _check_docks(self, values: _Scope, sites: dict[tuple[str, str], SiteDef]) -> None:
        """Docks: their parts and sites, placements; then the sites no dock names."""
        used_sites: set[tuple[str, str]] = set()
        for d in self.g.docks:
            for part, site in ((d.a, d.a_site), (d.b, d.b_site)):
                if site is not None:
                    used_sites.add((part, site))
                self._part_ref(part, d.span, "dock")
                if site is not None and part in self.parts and (part, site) not in sites:
                    known = [n for (p, n) in sites if p == part]
                    self.bag.error(f"part '{part}' has no site '{site}'", d.span,
                                   hint=_known_hint("sites", site, known) if known
                                   else f"declare it with `site {part}.{site} at (x, y, z)`",
                                   code="unknown-site")
            for pl in d.placements:
                for x in pl.at + (pl.rot or ()):
                    self.check_expr(x, values)
        for key, s in sites.items():
            # a site no dock names constrains nothing (unless it is required); say so
            if key not in used_sites and not s.required:
                self.bag.warning(f"site {s.part}.{s.name} is not used by any dock (it allows and "
                                 "requires nothing)", s.span, hint=f"dock it: `dock {s.part}.{s.name} -- Other`"
                                 f" or mark it `required`", code="unused-site")

    def _check_neighbor_rules(self) -> None:
        for n in self.g.neighbor_rules:
            self._part_ref(n.part, n.span, "neighbors")
            for m in n.multisets:
                for t in m:
                    self._part_ref(t, n.span, "neighbors")
            for c in n.counts:
                self._part_ref(c.type, c.span or n.span, "neighbors")
                if c.hi is not None and c.lo > c.hi:
                    self.bag.error(f"count range {c.lo}..{c.hi} is empty", c.span or n.span,
                                   code="bad-range")

    def _check_constraints(self, values: _Scope) -> None:
        """Constraints: known names, arguments bound to the constraint's spec; bare names in
        the other arguments name part types (or values)."""
        known = set(self.reg.constraints) | BUILTIN_CONSTRAINTS
        for c in self.g.constraints:
            if c.name not in known:
                self.bag.error(f"unknown constraint '{c.name}'", c.span,
                               hint=_known_hint("constraints", c.name, known),
                               code="unknown-constraint")
            spec = self.reg.constraints.get(c.name)
            axis_args: set[int] = set()  # arguments bound to axis/selector parameters
            if spec is not None:
                binding = bind_operation(c, spec, fold=lambda e: self.const_value(e, values),
                                         label=f"constraint {c.name}")
                self.bag.items.extend(binding.problems)
                axis_args = {id(b.value) for b in binding.arguments
                             if b.value is not None and b.param.type in ("axis", "selector")}
            for a in c.args:
                v = a.value
                if id(v) in axis_args:
                    continue
                if isinstance(v, Ref) and "." not in v.name:
                    if v.name not in self.parts and v.name not in self._values:
                        self._part_ref(v.name, v.span or c.span, f"constraint {c.name}")
                else:
                    self.check_expr(v, values)
