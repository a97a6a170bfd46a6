"""Validation of an assembly against a tiling grammar (Kalojanov 2019 sections 3-4, Liu 2015).

The shape graph is recomputed from the geometry, so an interpenetrating part shows up as a
contact the rules do not allow (an unexpected type pair or neighbourhood), and a misplaced one
as a missing contact or a docking placement that matches none of the grammar's. Every violation
names the part (id and type), the rule broken, and what was observed versus allowed.

Checks, in report order (rule names as in reports):
- `unknown-type`: a part type the grammar never mentions;
- `pair`: two touching types no `dock` allows;
- `neighbors` / `neighbor-count`: neighbourhood rules;
- `orientation` / `mirrored`: a part not standing as its type may stand (orientation.py), or a
  mirror image of a chiral part whose type does not allow it;
- `dock`: a contact matching none of its type pair's docking configurations (placements, up to
  the parts' turn symmetries; one-sided site docks: the contact must be at that site);
- `site`: a `required` site of a part with nothing touching it;
- `constraint NAME`: a global constraint (connected, grounded, path, count, a plugin's).

Large models: contacts are checked on numpy arrays in chunks of `CHUNK` (bounded temporaries),
neighbourhoods once per distinct (type, neighbour counts) combination.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Callable

import networkx as nx
import numpy as np

from ..jsonable import to_jsonable
from .assembly import Assembly
from .sitegeom import contact_geometry
from .frames import local_frames, symmetry_classes
from .graph import drop_views, node_arrays, shape_graph
from .rules import DockConfig, Rules, format_multiset, rotation_matrix, rules_from_grammar

if TYPE_CHECKING:  # pragma: no cover
    from ..ir import Grammar

__all__ = ["CHUNK", "Report", "Violation", "validate"]

CHUNK = 8192  # contacts per vectorised step (temporaries stay a few MB however large the model)


@dataclass
class Violation:
    rule: str  # "neighbors", "neighbor-count", "pair", "dock", "orientation", "mirrored", "site",
    #            "unknown-type", "constraint NAME"
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


class _Full(Exception):
    """max_violations reached: stop checking."""


FRAME_CHUNK = 1024  # parts per local_frames call (bounded temporaries)
EDGE_CHUNK = 8192  # contacts per docking-placement pass (bounded temporaries)


class _Shape:
    """The graph as arrays: nodes in part order, edges as index pairs (both built once)."""

    def __init__(self, assembly: Assembly, graph: nx.Graph):
        self.assembly = assembly
        self.graph = graph
        # one pass over the node data (NodeView lookups cost ~1 us each: 10 per part on 100k
        # parts), read in place from `_node`, the node dict networkx documents for subclasses
        data = graph._node if isinstance(getattr(graph, "_node", None), dict) else dict(graph.nodes(data=True))
        nodes = list(data)
        if all("index" in d for d in data.values()):
            nodes.sort(key=lambda n: data[n]["index"])
        self.nodes = nodes
        self.types = [data[n]["type"] for n in nodes]
        # type codes: per-part loops over 100,000 parts become numpy operations
        self.type_names = sorted(set(self.types))
        code = {t: k for k, t in enumerate(self.type_names)}
        n = len(nodes)
        self.tid = np.fromiter((code[t] for t in self.types), dtype=np.int64, count=n)
        self.part_index = np.fromiter((data[m].get("index", i) for i, m in enumerate(nodes)), np.int64, n)
        arrays = node_arrays(graph)
        if arrays is not None:  # a shape_graph: its node arrays, rows by part index (read-only)
            if len(arrays["lo"]) == n and (self.part_index == np.arange(n)).all():
                self.lo, self.hi = arrays["lo"], arrays["hi"]  # nodes in part order: the rows as they are
            else:
                self.lo, self.hi = arrays["lo"][self.part_index], arrays["hi"][self.part_index]
        else:
            self.lo = np.array([data[m]["lo"] for m in nodes], dtype=np.float64).reshape(-1, 3)
            self.hi = np.array([data[m]["hi"] for m in nodes], dtype=np.float64).reshape(-1, 3)
        # edges as position pairs, without a tuple per contact (150,000 tuples were 18 MB)
        pos = {m: i for i, m in enumerate(nodes)}  # not kept (8 MB at 100k parts): `pos` makes it on use
        self.edges = np.fromiter((pos[x] for e in graph.edges() for x in e), dtype=np.int64,
                                 count=2 * graph.number_of_edges()).reshape(-1, 2)
        del pos
        self.diag = np.linalg.norm(self.hi - self.lo, axis=1)
        self._frames = np.tile(np.eye(4), (n, 1, 1))
        self._have = np.zeros(n, dtype=bool)
        self.frame_keys: Any = None  # optional: a key per part and a dict of known frames
        self.frame_cache: dict | None = None

    @cached_property
    def pos(self) -> dict | None:
        """Node -> its position in `nodes` (made on first use; None after `release`)."""
        return {m: i for i, m in enumerate(self.nodes)}

    def release(self) -> None:
        """Drop the per-part arrays; only `graph` and `assembly` stay usable."""
        for name in ("pos", "types", "tid", "lo", "hi", "edges", "diag", "_frames", "_have", "nodes"):
            setattr(self, name, None)

    def part(self, i: int):  # noqa: ANN201
        return self.assembly.parts[int(self.part_index[i])]

    def mesh(self, i: int):  # noqa: ANN201
        return self.part(i).mesh

    def frames(self, idx=None) -> np.ndarray:  # noqa: ANN001
        """(n, 4, 4) Kalojanov frames in world coordinates; rows of `idx` (default: all) are
        computed on first use (batched), the others may still be identity."""
        idx = np.arange(len(self.nodes)) if idx is None else np.asarray(idx, dtype=np.int64).ravel()
        missing = idx[~self._have[idx]]
        if len(missing):
            missing = np.unique(missing)
            if self.frame_keys is not None and self.frame_cache is not None:
                todo_list = []
                for i in missing.tolist():
                    key = self.frame_keys[int(self.part_index[i])]
                    known = self.frame_cache.get(key) if key is not None else None
                    if known is not None:
                        self._frames[i] = known
                    else:
                        todo_list.append(i)
                todo = np.array(todo_list, dtype=np.int64)
            else:  # no cache: every missing frame is computed (no Python int per part)
                todo = missing
            # in chunks: local_frames' per-vertex temporaries over 100,000 parts at once were
            # the peak of a validate (issue 33: <= 600 MB)
            for k in range(0, len(todo), FRAME_CHUNK):
                chunk = todo[k:k + FRAME_CHUNK]
                self._frames[chunk] = local_frames([self.mesh(i) for i in chunk.tolist()])
            if len(todo) and self.frame_keys is not None and self.frame_cache is not None:
                for i in todo.tolist():
                    self.frame_cache[self.frame_keys[int(self.part_index[i])]] = self._frames[i].copy()
            self._have[missing] = True
        return self._frames


def validate(grammar_or_rules: "Grammar | Rules", assembly: Assembly, *, tolerance: float | None = None,
             graph: nx.Graph | None = None, docks: bool = True, max_violations: int = 1000,
             registries: Any = None, orientation: bool = True,
             progress: Callable[[str], Any] | None = None,
             constraint_context: dict | None = None, rigid: bool = True) -> Report:
    """Check `assembly` against the grammar's rules; `graph` (if given) must be its shape graph.

    `docks=False` skips the docking-placement check (type pairs, neighbourhoods, orientation,
    required sites and constraints are still checked); `orientation=False` skips the
    orientation check, `rigid=False` the rigid-copy check (rigid.py). At most `max_violations` are listed (a broken 10,000-part model stays
    readable). `registries` (a grammarkit.registry.Registries) gives the global constraints;
    default: the installed plugins'. `progress(stage)` is called as each stage starts.
    `constraint_context`: extra entries for the global constraints' context (caches a caller
    keeps across shapes, e.g. `support_cache` and `keys` for `grounded`)."""
    from ..errors import GrammarError, ShapeError
    from ..ir.grammar import Grammar
    from .orientation import normalize_mirrored

    if not isinstance(grammar_or_rules, (Rules, Grammar)):
        raise GrammarError(f"validate: expected a tiling Grammar (grammarkit.dsl.load) or Rules, "
                           f"got {type(grammar_or_rules).__name__}", None, code="bad-argument")
    if not isinstance(assembly, Assembly):
        raise ShapeError(f"validate: expected an Assembly (see read_assembly), got {type(assembly).__name__}")
    say = progress or (lambda stage: None)
    if registries is None:
        from ..plugins import default_registries  # the public API edge

        registries = default_registries()
    if assembly.parts and (np.linalg.det(np.array([np.asarray(p.transform, dtype=np.float64)[:3, :3]
                                                    for p in assembly.parts])) < 0).any():
        assembly = Assembly([normalize_mirrored(p) for p in assembly.parts], assembly.name, assembly.meta)
    rules = grammar_or_rules if isinstance(grammar_or_rules, Rules) else rules_from_grammar(
        grammar_or_rules, registries=registries)
    own_graph = graph is None
    if own_graph:
        say("shape graph")
        graph = shape_graph(assembly, tolerance)
    report = Report(assembly.name, graph.number_of_nodes(), graph.number_of_edges(),
                    tolerance=float(graph.graph.get("tolerance", tolerance or 0.0)))
    out = report.violations

    def add(v: Violation) -> None:
        out.append(v)
        if len(out) >= max_violations:
            raise _Full

    shape = _Shape(assembly, graph)
    try:
        say("neighbourhoods")
        _type_violations(rules, shape, add)
        if orientation:
            say("orientation")
            for v in orientation_violations(rules, shape, range(len(shape.nodes))):
                add(v)
        if rigid:
            say("rigid parts")
            for v in rigid_violations(rules, shape, np.arange(len(shape.nodes))):
                add(v)
        if docks and (rules.configs or rules.docks):
            say("docking placements")
            # in chunks of contacts: the per-contact temporaries of 100k parts at once were the
            # peak of a validate (issue 33)
            for start in range(0, len(shape.edges), EDGE_CHUNK):
                for v in _dock_violations(rules, shape, np.arange(start, min(len(shape.edges), start + EDGE_CHUNK))):
                    add(v)
        say("required sites")
        for v in required_site_violations(rules, shape):
            add(v)
        if rules.constraints:
            say("global constraints")
            # the constraints read the graph and the assembly only: the per-part arrays (frames,
            # positions) go first, as the constraints build their own (peak memory on 100k parts)
            shape.release()
            _constraint_violations(rules, shape, registries, add, dict(constraint_context or {}))
    except _Full:
        pass
    finally:
        if own_graph:  # nobody else holds it: freed as validate returns, not at the next full gc
            drop_views(graph)
    return report


# --------------------------------------------------------------------------------------------
# types, pairs, neighbourhoods
# --------------------------------------------------------------------------------------------
def _type_violations(rules: Rules, shape: _Shape, add: Callable[[Violation], None]) -> None:
    types, nodes = shape.types, shape.nodes
    names, tid = shape.type_names, shape.tid
    if rules.types:
        unknown = np.array([t not in rules.types for t in names], dtype=bool)
        for i in np.flatnonzero(unknown[tid]).tolist():
            t = types[i]
            add(Violation("unknown-type", f"type {t!r} does not occur in the grammar", nodes[i], t, t,
                          sorted(rules.types)))
    if rules.pairs is not None and len(shape.edges):
        allowed = np.array([[rules.allows_pair(x, y) for y in names] for x in names], dtype=bool)
        bad = ~allowed[tid[shape.edges[:, 0]], tid[shape.edges[:, 1]]]
        for a, b in shape.edges[bad].tolist():
            tu, tv = types[a], types[b]
            add(Violation("pair", f"touches {nodes[b]} ({tv}), but no dock allows {tu} -- {tv}",
                          nodes[a], tu, f"{tu} -- {tv}", sorted(f"{x} -- {y}" for x, y in rules.pairs),
                          other_id=nodes[b]))
    if not (rules.neighbor_multisets or rules.neighbor_counts):
        return
    # one check per distinct (type, neighbour-type counts): a 100,000-part lattice has a handful
    counts = np.zeros((len(types), len(names) + 1), dtype=np.int64)
    counts[:, 0] = tid
    if len(shape.edges):
        a, b = shape.edges[:, 0], shape.edges[:, 1]
        np.add.at(counts, (a, tid[b] + 1), 1)
        np.add.at(counts, (b, tid[a] + 1), 1)
    rows, inverse = np.unique(counts, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    for r, row in enumerate(rows):
        t = names[int(row[0])]
        nbr = [names[k] for k in range(len(names)) for _ in range(int(row[k + 1]))]
        broken = rules.check_neighbors(t, nbr)
        if not broken:
            continue
        observed = format_multiset(tuple(sorted(nbr)))
        for i in np.flatnonzero(inverse == r):
            for rule, allowed in broken:
                add(Violation(rule, f"neighbours {observed} not allowed; allowed: {allowed}",
                              nodes[i], t, observed, allowed))


# --------------------------------------------------------------------------------------------
# poses: orientation and turn symmetries
# --------------------------------------------------------------------------------------------
def _up(rules: Rules) -> np.ndarray | None:
    from .orientation import up_vector

    return up_vector(rules.up)


@dataclass
class _Poses:
    """Per part: the index of its allowed up direction (-1: no `part` statement), and the id
    of its symmetry group; per group the (k, 3, 3) rotations in the part's Kalojanov frame."""

    up_index: np.ndarray
    group: np.ndarray
    groups: list[np.ndarray]
    skip: np.ndarray  # parts whose frames do not describe them (mirror images of chiral parts)


def _poses(rules: Rules, shape: _Shape, idx: np.ndarray | None = None) -> _Poses:
    """Poses of all parts (or of `idx` only; others get group -1)."""
    from .orientation import turn_group

    n = len(shape.nodes)
    idx = np.arange(n) if idx is None else np.asarray(idx, dtype=np.int64)
    F = shape.frames(idx)
    up = _up(rules)
    up_index = np.full(n, -1, dtype=np.int64)
    group = np.full(n, -1, dtype=np.int64)
    skip = np.zeros(n, dtype=bool)
    groups: list[np.ndarray] = []
    gid: dict[tuple, int] = {}
    # the parts of each type (types in order of first appearance in idx), as index arrays: a
    # list of Python ints per type was 4 MB at 100k parts
    tids = shape.tid[idx]
    present, first = np.unique(tids, return_index=True)
    by_type = {shape.type_names[c]: idx[tids == c] for c in present[np.argsort(first)].tolist()}
    parts, pi = shape.assembly.parts, shape.part_index
    for start in range(0, len(idx), FRAME_CHUNK):  # a Python int per part, a chunk at a time
        chunk = idx[start:start + FRAME_CHUNK]
        skip[chunk] = [parts[p].meta.get("mirrored") is True for p in pi[chunk].tolist()]
    no_spec: list[int] = []
    for t, m in by_type.items():
        spec = rules.parts.get(t)
        if spec is None or up is None:
            no_spec.extend(m.tolist())
            continue
        k = np.empty(len(m), dtype=np.int64)
        for start in range(0, len(m), FRAME_CHUNK):  # bounded temporaries on 100k parts
            c = m[start:start + FRAME_CHUNK]
            # d = M^-1 up: the direction of the modelling frame that points up; M = F inv(F_proto)
            R = np.einsum("nij,kj->nik", F[c, :3, :3], spec.frame[:3, :3])  # (m, 3, 3) = R_F R_P^T
            d = np.einsum("nji,j->ni", R, up)
            k[start:start + len(c)] = np.argmax(d @ spec.ups.T, axis=1)
        up_index[m] = k
        for j in np.unique(k).tolist():
            key = (t, j)
            if key not in gid:
                axis = spec.frame[:3, :3].T @ spec.ups[j]  # the up direction in the proto's Kalojanov frame
                gid[key] = len(groups)
                groups.append(turn_group(axis, spec.orders[j]))
            group[m[k == j]] = gid[key]
    if no_spec:
        # no prototype: the geometry's own rotational symmetries, kept to those that leave the
        # part's up direction where it is (all of them when the grammar has no up axis)
        ns = np.array(no_spec)
        cls, syms = symmetry_classes([shape.mesh(i) for i in no_spec], F[ns])
        # a class per (geometry, type): up(any) types keep all of their geometry's turns
        free = np.array([shape.types[i] in rules.free for i in no_spec])
        cls = cls * 2 + free
        for c in np.unique(cls).tolist():
            members = ns[cls == c]
            c //= 2
            S = syms[c]
            if up is not None and shape.types[int(members[0])] not in rules.free:
                u_loc = F[members[0], :3, :3].T @ up
                keep = np.linalg.norm(np.einsum("kij,j->ki", S, u_loc) - u_loc, axis=1) < 1e-3
                S = S[keep]
            key = ("geometry", c, bool(free[ns.tolist().index(int(members[0]))]))
            gid[key] = len(groups)
            groups.append(S)
            group[members] = gid[key]
    return _Poses(up_index, group, groups, skip)


def orientation_violations(rules: Rules, shape: _Shape, idx) -> list[Violation]:  # noqa: ANN001
    """Parts (of `idx`) that do not stand as their type allows, or are mirror images of chiral
    parts their type does not allow mirrored."""
    out: list[Violation] = []
    up = _up(rules)
    idx = np.asarray(list(idx), dtype=np.int64)
    if len(idx) == 0:
        return out
    mirrored = np.zeros(len(shape.nodes), dtype=bool)
    parts, pi = shape.assembly.parts, shape.part_index.tolist()
    mirrored[idx] = [parts[pi[i]].meta.get("mirrored") is True for i in idx.tolist()]
    for i in idx[mirrored[idx]].tolist():
        spec = rules.parts.get(shape.types[i])
        if not (spec is not None and spec.mirror):
            out.append(Violation("mirrored", "is a mirror image of its type's part (a negative-determinant "
                                 "transform), and the type is not mirror-symmetric; declare "
                                 f"`symmetry(..., mirror)` on part {shape.types[i]} if that is intended",
                                 shape.nodes[i], shape.types[i], "mirrored", "proper copies"))
    if up is None or not rules.parts:
        return out
    has_spec = np.array([t in rules.parts for t in shape.type_names], dtype=bool)
    typed = idx[has_spec[shape.tid[idx]] & ~mirrored[idx]]
    if len(typed) == 0:
        return out
    F = shape.frames(typed)
    cos_tol = math.cos(math.radians(rules.angle_tolerance))
    for code in np.unique(shape.tid[typed]).tolist():
        t = shape.type_names[code]
        spec = rules.parts[t]
        members = typed[shape.tid[typed] == code]
        for start in range(0, len(members), FRAME_CHUNK):  # bounded temporaries on 100k parts
            m = members[start:start + FRAME_CHUNK]
            R = np.einsum("nij,kj->nik", F[m, :3, :3], spec.frame[:3, :3])
            d = np.einsum("nji,j->ni", R, up)
            best = (d @ spec.ups.T).max(axis=1)
            out.extend(_orientation_problems(rules, shape, spec, t, m, d, best, cos_tol))
    return out


def _orientation_problems(rules: Rules, shape: _Shape, spec, t: str, m: np.ndarray, d: np.ndarray,  # noqa: ANN001
                          best: np.ndarray, cos_tol: float) -> list[Violation]:
    """Orientation violations of the parts `m` of type `t` (d: their up directions in the
    part frame, best: the best cosine with an allowed one)."""
    out = []
    for j in np.flatnonzero(best < cos_tol).tolist():
        i = int(m[j])
        obs = tuple(round(float(x), 3) + 0.0 for x in d[j])
        allowed = [_direction_text(u) for u in spec.ups]
        what = "is upside down" if best[j] < -cos_tol else "is turned over"
        out.append(Violation("orientation", f"{what}: the direction {_direction_text(d[j])} of its "
                             f"part frame points up (allowed: {', '.join(allowed)}; "
                             f"{rules.angle_tolerance:g} degrees)", shape.nodes[i], t, obs, allowed))
    return out


def rigid_violations(rules: Rules, shape: _Shape, idx) -> list[Violation]:  # noqa: ANN001
    """Parts that are not rigid copies of their prototypes (rigid.py), unless `deformable`."""
    from .rigid import RIGID_TOLERANCE, rigid_errors

    idx = np.asarray(idx, dtype=np.int64)
    if not len(idx) or not any(getattr(p, "vertices", None) is not None for p in rules.parts.values()):
        return []
    out = []
    for i, err in rigid_errors(rules, shape, _poses(rules, shape, idx), idx):
        t = shape.types[i]
        out.append(Violation("rigid", f"is not a rigid copy of its prototype: a vertex is off by {100 * err:.3g}% "
                             f"of the part's diagonal after the best rigid placement (allowed "
                             f"{100 * RIGID_TOLERANCE:g}%; `constraint deformable({t})` allows deformed {t} parts)",
                             shape.nodes[i], t, f"{100 * err:.3g}%", f"<= {100 * RIGID_TOLERANCE:g}%"))
    return out


def _direction_text(v: np.ndarray) -> str:
    names = {0: "x", 1: "y", 2: "z"}
    k = int(np.argmax(np.abs(v)))
    if abs(abs(float(v[k])) - 1.0) < 1e-3:
        return ("+" if v[k] > 0 else "-") + names[k]
    return "(" + ", ".join(f"{float(x):.3g}" for x in v) + ")"


# --------------------------------------------------------------------------------------------
# docking configurations
# --------------------------------------------------------------------------------------------
def _configs(rules: Rules) -> dict[tuple[str, str], tuple[DockConfig, ...]]:
    if rules.configs:
        return rules.configs
    # Rules built by hand with placements only (before configurations existed)
    return {k: tuple(DockConfig(None, None, p) for p in v) for k, v in rules.docks.items()}


def _site_points(rules: Rules, t: str, name: str) -> np.ndarray:
    """(k, 3) the site's positions (mirror images too) in the type prototype's Kalojanov frame."""
    spec = rules.parts[t]
    site = next(s for s in rules.sites.get(t, ()) if s.name == name)
    inv = np.linalg.inv(spec.frame)
    return site.frames[:, :3, 3] @ inv[:3, :3].T + inv[:3, 3]


def _local(F: np.ndarray, points: np.ndarray) -> np.ndarray:
    """World points (m, 3) in the frames F (m, 4, 4)."""
    return np.einsum("mji,mj->mi", F[:, :3, :3], points - F[:, :3, 3])


# one vectorised pass over all contacts (frames, site points, every dock configuration of the
# pair's types, the best match per contact); split, its arrays would travel through many signatures
# long: one vectorised pass over all contacts
def _dock_violations(rules: Rules, shape: _Shape, edge_idx: np.ndarray, poses: _Poses | None = None):  # noqa: ANN202
    """Contacts (of `edge_idx`) that match none of their type pair's docking configurations.

    With rel = inv(F_u) @ F_v in the parts' frames and turn symmetries S_k (of u) and S'_l (of
    v), an allowed placement (t_p, P_p) matches when |rel.t - S_k t_p| <= tol and
    angle(rel.R, S_k P_p S'_l^T) <= angle tolerance for some k, l, p. The allowed set is built
    once per (type pair, symmetry group of u, of v) and compared with that group's contacts in
    chunks of CHUNK. A one-sided site configuration (`dock A.s -- B`) matches when the contact
    point lies at one of the turned images of A's site s (within the position tolerance x the
    smaller part's diagonal)."""
    configs = _configs(rules)
    types = shape.types
    nodes = shape.nodes
    edge_idx = np.asarray(edge_idx, dtype=np.int64)
    if len(edge_idx) == 0:
        return
    tnames, tid = shape.type_names, shape.tid  # codes of the sorted type names
    E = shape.edges[edge_idx]
    wanted = np.array([(tnames[x], tnames[y]) in configs or (tnames[y], tnames[x]) in configs
                       for x, y in zip(tid[E[:, 0]].tolist(), tid[E[:, 1]].tolist())], dtype=bool) \
        if len(E) else np.zeros(0, bool)
    edge_idx, E = edge_idx[wanted], E[wanted]
    if len(edge_idx) == 0:
        return
    involved = np.unique(E)
    if poses is None:
        poses = _poses(rules, shape, involved)
    F = shape.frames(involved)
    ok_all = np.zeros(len(edge_idx), dtype=bool)
    skip = poses.skip[E[:, 0]] | poses.skip[E[:, 1]]
    ok_all |= skip
    # group contacts by (type of u, type of v, group of u, group of v)
    key = np.stack([tid[E[:, 0]], tid[E[:, 1]], poses.group[E[:, 0]], poses.group[E[:, 1]]], axis=1)
    ukeys, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    cos_tol = math.cos(math.radians(rules.angle_tolerance)) - 1e-9
    allowed_text: dict[tuple[str, str], list] = {}
    for g, (x, y, gu, gv) in enumerate(ukeys.tolist()):
        members = np.flatnonzero((inverse == g) & ~skip)
        if len(members) == 0:
            continue
        tu, tv = tnames[x], tnames[y]
        cs = configs.get((tu, tv), ())
        if any(c.wildcard for c in cs):
            ok_all[members] = True
            continue
        placed = [c.placement for c in cs if c.placement is not None]
        Sk = poses.groups[gu] if gu >= 0 else np.eye(3)[None]
        Sl = poses.groups[gv] if gv >= 0 else np.eye(3)[None]
        allowed_text[(tu, tv)] = [{"at": list(map(float, p.at)), "rot": list(map(float, p.rot))} for p in placed] + \
            [{"site": f"{tu}.{c.a_site}" if c.a_site else f"{tv}.{c.b_site}"} for c in cs if c.placement is None]
        T_all = Q_all = None
        if placed:
            at = np.array([p.at for p in placed], dtype=np.float64)
            rots = np.array([rotation_matrix(p.rot) for p in placed])
            t_allowed = np.einsum("kij,pj->kpi", Sk, at)  # (k, p, 3)
            Q = np.einsum("kij,pjm,lnm->kplin", Sk, rots, Sl)  # S_k P_p S_l^T: (k, p, l, 3, 3)
            k_, p_, l_ = Q.shape[:3]
            T_all = np.broadcast_to(t_allowed[:, :, None, :], (k_, p_, l_, 3)).reshape(-1, 3)
            Q_all = Q.reshape(-1, 3, 3)
            _, uniq = np.unique(np.round(np.concatenate([T_all, Q_all.reshape(-1, 9)], axis=1), 5),
                                axis=0, return_index=True)
            T_all, Q_all = T_all[np.sort(uniq)], Q_all[np.sort(uniq)]
        one_sided = [c for c in cs if c.placement is None and (c.a_site or c.b_site)]
        for start in range(0, len(members), CHUNK):
            chunk = members[start:start + CHUNK]
            u, v = E[chunk, 0], E[chunk, 1]
            Fu, Fv = F[u], F[v]
            ok = np.zeros(len(chunk), dtype=bool)
            if T_all is not None:
                rel_t = _local(Fu, Fv[:, :3, 3])
                rel_R = np.einsum("eji,ejk->eik", Fu[:, :3, :3], Fv[:, :3, :3])
                pos_tol = rules.position_tolerance * np.maximum(shape.diag[u], shape.diag[v])
                d2 = ((rel_t[:, None, :] - T_all[None, :, :]) ** 2).sum(axis=2)  # (e, m)
                cos = (np.einsum("eij,mij->em", rel_R, Q_all) - 1.0) / 2.0
                ok |= ((d2 <= (pos_tol ** 2)[:, None]) & (cos >= cos_tol)).any(axis=1)
            if one_sided:
                c_world = contact_geometry(rules, shape, edge_idx[chunk])[0]
                tol = rules.position_tolerance * np.minimum(shape.diag[u], shape.diag[v])
                for c in one_sided:
                    side, frames, tname, grp = ((u, Fu, tu, Sk) if c.a_site else (v, Fv, tv, Sl))
                    site = c.a_site or c.b_site
                    if tname not in rules.parts:
                        continue
                    pts = _site_points(rules, tname, site)
                    images = np.einsum("kij,pj->kpi", grp, pts).reshape(-1, 3)
                    loc = _local(frames, c_world)
                    dist = np.linalg.norm(loc[:, None, :] - images[None, :, :], axis=2).min(axis=1)
                    ok |= dist <= tol
            ok_all[chunk] = ok
    for j in np.flatnonzero(~ok_all).tolist():
        a, b = int(E[j, 0]), int(E[j, 1])
        tu, tv = types[a], types[b]
        rel = np.linalg.inv(F[a]) @ F[b]
        obs = tuple(round(float(x), 3) + 0.0 for x in rel[:3, 3])
        yield Violation(
            "dock",
            f"touches {nodes[b]} ({tv}) at a placement no `dock {tu} -- {tv}` allows: {nodes[b]} sits at "
            f"({', '.join(f'{x:.3g}' for x in obs)}) in {nodes[a]}'s frame (tolerance "
            f"{rules.position_tolerance * max(shape.diag[a], shape.diag[b]):.3g}, {rules.angle_tolerance:g} degrees)",
            nodes[a], tu, {"at": obs, "neighbour": nodes[b]}, allowed_text.get((tu, tv), []), other_id=nodes[b])


# --------------------------------------------------------------------------------------------
# required sites
# --------------------------------------------------------------------------------------------
def required_site_violations(rules: Rules, shape: _Shape, poses: _Poses | None = None,
                             idx: np.ndarray | None = None) -> list[Violation]:
    """Parts (of `idx`, default all) with a `required` site (any of its turned and mirrored
    images) that nothing touches (no contact point within the position tolerance x the smaller
    part's diagonal)."""
    req = {t: [s.name for s in sts if s.required] for t, sts in rules.sites.items()}
    out: list[Violation] = []
    for i, t, name, _, _, filled in site_occupancy(rules, shape, req, poses, idx):
        if not filled.all():
            empty = int((~filled).sum())
            out.append(Violation("site", f"required site {t}.{name} has nothing docked "
                                 f"({empty} of its {len(filled)} position(s) empty)",
                                 shape.nodes[i], t, f"{len(filled) - empty}/{len(filled)} filled",
                                 f"{t}.{name}"))
    return out


def site_occupancy(rules: Rules, shape: _Shape, wanted: dict[str, list[str]], poses: _Poses | None = None,
                   idx: np.ndarray | None = None):  # noqa: ANN201
    """For every part (of `idx`, default all) of a type in `wanted` (type -> site names) and each of those sites:
    (part index, type, site, image positions (k, 3) and facing directions (k, 3) in world
    coordinates, filled mask (k,)): the site's turned and mirrored images, and whether a
    contact point lies within the position tolerance x the smaller part's diagonal of each."""
    wanted = {t: v for t, v in wanted.items() if v and t in rules.parts}
    if not wanted:
        return
    members = np.array([i for i, t in enumerate(shape.types) if t in wanted], dtype=np.int64)
    if idx is not None:
        members = np.intersect1d(members, np.asarray(idx, dtype=np.int64))
    if len(members) == 0:
        return
    if poses is None:
        poses = _poses(rules, shape, members)
    F = shape.frames(members)
    # every contact, seen from both of its parts
    E = shape.edges
    ends = np.concatenate([E[:, 0], E[:, 1]]) if len(E) else np.zeros(0, dtype=np.int64)
    others = np.concatenate([E[:, 1], E[:, 0]]) if len(E) else np.zeros(0, dtype=np.int64)
    points = np.concatenate([contact_geometry(rules, shape, np.arange(len(E)))[0]] * 2) if len(E) else np.zeros((0, 3))
    tol = rules.position_tolerance * np.minimum(shape.diag[ends], shape.diag[others]) if len(E) else np.zeros(0)
    order = np.argsort(ends, kind="stable")
    ends, others, points, tol = ends[order], others[order], points[order], tol[order]
    starts = np.searchsorted(ends, np.arange(len(shape.nodes) + 1))
    local_sites = {(t, name): _site_points_and_dirs(rules, t, name) for t, names in wanted.items() for name in names}
    for i in members.tolist():
        if poses.skip[i]:
            continue
        t = shape.types[i]
        grp = poses.groups[poses.group[i]] if poses.group[i] >= 0 else np.eye(3)[None]
        lo, hi = starts[i], starts[i + 1]
        loc = _local(np.repeat(F[i][None], hi - lo, axis=0), points[lo:hi]) if hi > lo else np.zeros((0, 3))
        for name in wanted[t]:
            pts, dirs = local_sites[(t, name)]
            images = np.einsum("kij,pj->kpi", grp, pts).reshape(-1, 3)
            facing = np.einsum("kij,pj->kpi", grp, dirs).reshape(-1, 3)
            keep = np.unique(np.round(images, 6), axis=0, return_index=True)[1]
            images, facing = images[keep], facing[keep]
            if hi > lo:
                dist = np.linalg.norm(loc[:, None, :] - images[None, :, :], axis=2)  # (contacts, images)
                filled = (dist <= tol[lo:hi, None]).any(axis=0)
            else:
                filled = np.zeros(len(images), dtype=bool)
            R, o = F[i][:3, :3], F[i][:3, 3]
            yield i, t, name, images @ R.T + o, facing @ R.T, filled


def _site_points_and_dirs(rules: Rules, t: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The site's positions and facing directions (mirror images too), in the type
    prototype's Kalojanov frame."""
    spec = rules.parts[t]
    site = next(s for s in rules.sites.get(t, ()) if s.name == name)
    inv = np.linalg.inv(spec.frame)
    return _site_points(rules, t, name), site.frames[:, :3, 0] @ inv[:3, :3].T


# --------------------------------------------------------------------------------------------
# global constraints
# --------------------------------------------------------------------------------------------
def _constraint_violations(rules: Rules, shape: _Shape, registries: Any, add: Callable[[Violation], None],
                           extra: dict) -> None:
    specs = registries.constraints
    context = {"assembly": shape.assembly, "rules": rules, **extra}
    for name, args, where in rules.constraints:
        spec = specs.get(name)
        if spec is None or spec.check is None:
            add(Violation(f"constraint {name}", f"unknown constraint {name!r} ({where})"))
            continue
        for msg in spec.check(shape.graph, args, context):
            add(Violation(f"constraint {name}", msg))
