"""Validation of an assembly against a tiling grammar (Kalojanov 2019 sections 3-4).

The shape graph is recomputed from the geometry, so an interpenetrating part shows up as a
contact the rules do not allow (an unexpected type pair or neighbourhood), and a misplaced one
as a missing contact or a docking placement that matches none of the grammar's. Every violation
names the part (id and type), the rule broken, and what was observed versus allowed.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np

from ..jsonable import to_jsonable
from .assembly import Assembly
from .frames import local_frames, symmetry_classes
from .graph import shape_graph
from .rules import Rules, format_multiset, rotation_matrix, rules_from_grammar

if TYPE_CHECKING:  # pragma: no cover
    from ..ir import Grammar

__all__ = ["Report", "Violation", "validate"]


@dataclass
class Violation:
    rule: str  # "neighbors", "neighbor-count", "pair", "dock", "unknown-type", "constraint NAME"
    message: str
    part_id: str | None = None
    part_type: str | None = None
    observed: Any = None
    allowed: Any = None
    other_id: str | None = None  # the neighbour involved (pair, dock)

    def format(self) -> str:
        who = f"part {self.part_id} ({self.part_type}): " if self.part_id else ""
        return f"{who}[{self.rule}] {self.message}"


@dataclass
class Report:
    assembly: str
    parts: int
    contacts: int
    violations: list[Violation] = field(default_factory=list)
    tolerance: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.violations

    def format(self) -> str:
        name = self.assembly or "<assembly>"
        if self.ok:
            return f"OK: {name}: {self.parts} parts, {self.contacts} contacts"
        head = f"{name}: {len(self.violations)} violation(s) ({self.parts} parts, {self.contacts} contacts)"
        return "\n".join([head, *("  " + v.format() for v in self.violations)])

    __str__ = format

    def to_json(self) -> dict:
        return {"assembly": self.assembly, "ok": self.ok, "parts": self.parts, "contacts": self.contacts,
                "tolerance": self.tolerance, "violations": [to_jsonable(asdict(v)) for v in self.violations]}

    def to_json_text(self) -> str:
        return json.dumps(self.to_json(), indent=2)


def validate(grammar_or_rules: "Grammar | Rules", assembly: Assembly, *, tolerance: float | None = None,
             graph: nx.Graph | None = None, docks: bool = True, max_violations: int = 1000,
             registries: Any = None) -> Report:
    """Check `assembly` against the grammar's rules; `graph` (if given) must be its shape graph.

    `docks=False` skips the docking-placement check (type pairs and neighbourhoods are still
    checked). At most `max_violations` are listed (a broken 10,000-part model stays readable).
    `registries` (a grammarkit.registry.Registries) gives the global constraints; default: the
    installed plugins'."""
    from ..errors import GrammarError, ShapeError
    from ..ir.grammar import Grammar

    if not isinstance(grammar_or_rules, (Rules, Grammar)):
        raise GrammarError(f"validate: expected a tiling Grammar (grammarkit.dsl.load) or Rules, "
                           f"got {type(grammar_or_rules).__name__}", None, code="bad-argument")
    if not isinstance(assembly, Assembly):
        raise ShapeError(f"validate: expected an Assembly (see read_assembly), got {type(assembly).__name__}")
    if registries is None:
        from ..plugins import default_registries  # the public API edge

        registries = default_registries()
    rules = grammar_or_rules if isinstance(grammar_or_rules, Rules) else rules_from_grammar(
        grammar_or_rules, registries=registries)
    if graph is None:
        graph = shape_graph(assembly, tolerance)
    report = Report(assembly.name, graph.number_of_nodes(), graph.number_of_edges(),
                    tolerance=float(graph.graph.get("tolerance", tolerance or 0.0)))
    out = report.violations
    types: dict[str, str] = nx.get_node_attributes(graph, "type")

    def add(v: Violation) -> bool:
        out.append(v)
        return len(out) < max_violations

    for node, t in types.items():
        if rules.types and t not in rules.types:
            if not add(Violation("unknown-type", f"type {t!r} does not occur in the grammar",
                                 node, t, t, sorted(rules.types))):
                return report
    for u, v in graph.edges():
        tu, tv = types[u], types[v]
        if not rules.allows_pair(tu, tv):
            if not add(Violation("pair", f"touches {v} ({tv}), but no dock allows {tu} -- {tv}",
                                 u, tu, f"{tu} -- {tv}", sorted(f"{a} -- {b}" for a, b in rules.pairs or ()),
                                 other_id=v)):
                return report
    for node, t in types.items():
        nbr_types = [types[n] for n in graph.neighbors(node)]
        for rule, allowed in rules.check_neighbors(t, nbr_types):
            observed = format_multiset(tuple(sorted(nbr_types)))
            if not add(Violation(rule, f"neighbours {observed} not allowed; allowed: {allowed}",
                                 node, t, observed, allowed)):
                return report
    if docks and rules.docks:
        for v in _dock_violations(rules, assembly, graph, types):
            if not add(v):
                return report
    if rules.constraints:
        specs = registries.constraints
        for name, args, where in rules.constraints:
            spec = specs.get(name)
            if spec is None or spec.check is None:
                add(Violation(f"constraint {name}", f"unknown constraint {name!r} ({where})"))
                continue
            for msg in spec.check(graph, args, {"assembly": assembly, "rules": rules}):
                if not add(Violation(f"constraint {name}", msg)):
                    return report
    return report


def _dock_violations(rules: Rules, assembly: Assembly, graph: nx.Graph, types: dict[str, str]):  # noqa: ANN202
    """Touching pairs whose relative placement matches none of the grammar's for their types.

    Symmetric parts have several equally valid local frames (frames.symmetry_offsets). With
    rel = inv(F_u) @ F_v in the canonical frames and symmetry rotations S_k (of u) and S'_l
    (of v), an allowed placement (t_p, P_p) matches when |rel.t - S_k t_p| <= tol and
    angle(rel.R, S_k P_p S'_l^T) <= angle tolerance for some k, l, p. The allowed set is built
    once per (type pair, symmetry class of u, symmetry class of v) and compared with all edges of
    that group in one vectorised step."""
    parts = assembly.parts
    placements = {k: (np.array([p.at for p in ps], dtype=np.float64),
                      np.array([rotation_matrix(p.rot) for p in ps]))
                  for k, ps in rules.docks.items()}
    edges = [(u, v) for u, v in graph.edges() if (types[u], types[v]) in placements]
    if not edges:
        return
    nodes = sorted({n for e in edges for n in e}, key=lambda n: graph.nodes[n]["index"])
    F0 = dict(zip(nodes, local_frames([parts[graph.nodes[n]["index"]].mesh for n in nodes])))
    cls, sym_list = symmetry_classes([parts[graph.nodes[n]["index"]].mesh for n in nodes],
                                     np.array([F0[n] for n in nodes]))
    sym_of = dict(zip(nodes, cls.tolist()))

    def diag_of(ns) -> np.ndarray:  # noqa: ANN001
        ns = list(ns)
        lo = np.array([graph.nodes[n]["lo"] for n in ns])
        hi = np.array([graph.nodes[n]["hi"] for n in ns])
        return np.linalg.norm(hi - lo, axis=1)

    groups: dict[tuple, list[tuple[str, str]]] = {}
    for u, v in edges:
        groups.setdefault((types[u], types[v], sym_of[u], sym_of[v]), []).append((u, v))
    cos_tol = np.cos(np.radians(rules.angle_tolerance)) - 1e-9
    for (tu, tv, su, sv), group in groups.items():
        at, rots = placements[(tu, tv)]
        Sk, Sl = sym_list[su], sym_list[sv]
        # allowed (translation, rotation) in canonical frames, m = (k, p, l), deduplicated
        t_allowed = np.einsum("kij,pj->kpi", Sk, at)  # (k, p, 3)
        Q = np.einsum("kij,pjm,lnm->kplin", Sk, rots, Sl)  # S_k P_p S_l^T: (k, p, l, 3, 3)
        k_, p_, l_ = Q.shape[:3]
        T_all = np.broadcast_to(t_allowed[:, :, None, :], (k_, p_, l_, 3)).reshape(-1, 3)
        Q_all = Q.reshape(-1, 3, 3)
        _, uniq = np.unique(np.round(np.concatenate([T_all, Q_all.reshape(-1, 9)], axis=1), 5),
                            axis=0, return_index=True)
        T_all, Q_all = T_all[np.sort(uniq)], Q_all[np.sort(uniq)]
        Fu = np.array([F0[u] for u, _ in group])
        Fv = np.array([F0[v] for _, v in group])
        rel_t = np.einsum("eji,ej->ei", Fu[:, :3, :3], Fv[:, :3, 3] - Fu[:, :3, 3])  # (e, 3)
        rel_R = np.einsum("eji,ejk->eik", Fu[:, :3, :3], Fv[:, :3, :3])  # (e, 3, 3)
        size = np.maximum(diag_of(u for u, _ in group), diag_of(v for _, v in group))
        pos_tol = rules.position_tolerance * size
        dist = np.linalg.norm(rel_t[:, None, :] - T_all[None, :, :], axis=2)  # (e, m)
        cos = (np.einsum("eij,mij->em", rel_R, Q_all) - 1.0) / 2.0
        ok = ((dist <= pos_tol[:, None]) & (cos >= cos_tol)).any(axis=1)
        for e in np.flatnonzero(~ok):
            u, v = group[e]
            obs = tuple(round(float(x), 3) for x in rel_t[e])
            near = float(dist[e].min())
            yield Violation(
                "dock",
                f"touches {v} ({tv}) at a placement no `dock {tu} -- {tv}` allows: {v} sits at "
                f"({', '.join(f'{x:.3g}' for x in obs)}) in {u}'s frame; nearest allowed position is "
                f"{near:.3g} away (tolerance {pos_tol[e]:.3g}, {rules.angle_tolerance:g} degrees)",
                u, tu, {"at": obs, "neighbour": v}, [{"at": list(map(float, a))} for a in at], other_id=v)
