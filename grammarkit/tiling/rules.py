"""The checkable content of a tiling grammar: `Rules`, compiled from the grammar's statements.

What each statement means for validation (see docs/tiling.md):
- `up +z` (default) / `up none`: the grammar's up axis. Every part with a `part` statement must
  stand as its type allows (`up(...)` directions; default: as modelled), placements and sites
  are compared only up to turns about this axis (the type's `symmetry(zN)`, declared or found
  from its geometry), and `grounded` carries parts along it.
- `neighbors T: {A, A, B} | {A}`: the multiset of neighbour types of every T part must be one
  of the listed ones exactly (Kalojanov's "exact neighbour-type count vectors").
- `neighbors T: A in 1..2, B in 0..1`: per-type count ranges; types not listed may not be
  neighbours of T (closed world). Several `neighbors T` statements: multisets are pooled,
  count ranges must all hold.
- `dock A -- B` (with or without sites): A and B may touch. As soon as a grammar has any dock
  statement, a contact between two types with no dock is a violation ("allowed type pairs").
  Each dock adds *docking configurations* for the pair; a contact must match one of them:
  `dock A -- B` alone matches any contact (it widens whatever else is allowed);
  `dock A -- B { at (x, y, z) rot (rx, ry, rz) | ... }` lists placements of a B part's local
  frame in an A part's (frames.py: Kalojanov's diagonal frame; degrees, extrinsic XYZ),
  matched within `position_tolerance` (times the larger part's diagonal) and `angle_tolerance`
  degrees, modulo the parts' turn symmetries; `dock A.s -- B.t` gives the placements where the
  two sites meet face to face (or, with `{ ... }`, the listed ones, tagged with the sites);
  `dock A.s -- B` (a site on one side) lets B touch A anywhere on B, but only at A's site s.
- `site A.s ... required`: every A part must touch something at (each image of) site s.
- `constraint NAME(args)`: a global constraint from the plugin registry (`connected`,
  `grounded`, `path(from=A, to=B)`, `count(T, lo, hi)` / `count(T) == n`, or a plugin's).

`Rules` is a plain picklable dataclass, so worker processes (the graph sampler) can share it.
Compiling reads every part's geometry once (one read per source file, however many `part`
and `dock` statements use it).

Expressions are evaluated by the language's one evaluator (`grammarkit.expr_eval`), so `%`,
`^`, division by zero and the power guard behave exactly as in split grammars and `check`.
Constraint arguments are bound by the binder `check` uses (`grammarkit.dsl.binding`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import GrammarError, GrammarkitError

if TYPE_CHECKING:  # pragma: no cover
    from ..ir import Grammar
    from ..ir.tiling import Placement

__all__ = [
    "DockConfig", "DockPlacement", "PartSpec", "Rules", "SiteSpec", "eval_number", "eval_value",
    "known_types", "placement_matrix", "rotation_matrix", "rules_from_grammar",
]


@dataclass(frozen=True)
class DockPlacement:
    """B's frame in A's frame: translation (x, y, z) and rotation (degrees, extrinsic XYZ)."""

    at: tuple[float, float, float]
    rot: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3] = rotation_matrix(self.rot)
        T[:3, 3] = self.at
        return T


@dataclass(frozen=True)
class PartSpec:
    """A part type's geometry facts, from its `part` statement's prototype (modelling frame)."""

    type: str
    frame: np.ndarray  # (4, 4) the prototype's Kalojanov frame in its modelling coordinates
    size: float  # the prototype's bounding-box diagonal
    ups: np.ndarray  # (k, 3) unit directions of the modelling frame that may point up
    orders: tuple[int, ...]  # per allowed up: turn symmetry order about it (1: none)
    declared: bool = False  # `symmetry(...)` given (else found from the geometry)
    mirror: bool = False  # its mirror image counts as the same part
    # the prototype's vertices (modelling coordinates), for the rigid-copy check (rigid.py)
    vertices: np.ndarray | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class SiteSpec:
    """`site T.name ...`: its frame(s) in T's modelling coordinates (mirror image included)."""

    part: str
    name: str
    frames: np.ndarray  # (k, 4, 4): origin at the site, x = facing
    required: bool = False


@dataclass(frozen=True)
class DockConfig:
    """One allowed way for a B part to touch an A part: B's placement in A's frame (None: any)
    and the sites involved (None: anywhere on that part)."""

    a_site: str | None = None
    b_site: str | None = None
    placement: DockPlacement | None = None

    @property
    def wildcard(self) -> bool:
        return self.placement is None and self.a_site is None and self.b_site is None


@dataclass
class Rules:
    name: str = ""
    # every type the grammar mentions (parts, rules, docks, constraint arguments)
    types: frozenset[str] = frozenset()
    # type -> allowed neighbour-type multisets (sorted tuples)
    neighbor_multisets: dict[str, frozenset[tuple[str, ...]]] = field(default_factory=dict)
    # type -> list of {neighbour type: (lo, hi or None)}; each dict must hold (closed world)
    neighbor_counts: dict[str, list[dict[str, tuple[int, int | None]]]] = field(default_factory=dict)
    # allowed unordered type pairs (sorted); None: no dock statements, any pair may touch
    pairs: frozenset[tuple[str, str]] | None = None
    # (A, B) -> placements of B in A's frame (both orders are stored, the reverse one inverted)
    docks: dict[tuple[str, str], tuple[DockPlacement, ...]] = field(default_factory=dict)
    # (A, B) -> every docking configuration of the pair (both orders; see DockConfig)
    configs: dict[tuple[str, str], tuple[DockConfig, ...]] = field(default_factory=dict)
    # the grammar's up axis ("+z", ...; None: `up none`, no orientation checks)
    up: str | None = "+z"
    # type -> geometry facts of its `part` statement (empty when compiled without geometry)
    parts: dict[str, PartSpec] = field(default_factory=dict)
    # types declared `up(any)`: no orientation check, turns from each part's own geometry
    free: frozenset[str] = frozenset()
    # type -> its sites
    sites: dict[str, tuple[SiteSpec, ...]] = field(default_factory=dict)
    # the examples' ground level along the up axis (None: no examples); `grounded` uses it
    ground: float | None = None
    # (constraint name, evaluated arguments by parameter name, source span text)
    constraints: tuple[tuple[str, dict[str, Any], str], ...] = ()
    position_tolerance: float = 0.05  # fraction of the larger part's bounding-box diagonal
    angle_tolerance: float = 20.0  # degrees

    def allows_pair(self, a: str, b: str) -> bool:
        return self.pairs is None or tuple(sorted((a, b))) in self.pairs

    def check_neighbors(self, ptype: str, neighbor_types: list[str]) -> list[tuple[str, str]]:
        """[(rule, allowed-description)] for every neighbour rule the observed list breaks."""
        out = []
        observed = tuple(sorted(neighbor_types))
        multisets = self.neighbor_multisets.get(ptype)
        if multisets is not None and observed not in multisets:
            out.append(("neighbors", " | ".join(format_multiset(m) for m in sorted(multisets))))
        for ranges in self.neighbor_counts.get(ptype, ()):
            counts: dict[str, int] = {}
            for t in observed:
                counts[t] = counts.get(t, 0) + 1
            bad = [t for t in counts if t not in ranges]
            bad += [t for t, (lo, hi) in ranges.items()
                    if counts.get(t, 0) < lo or (hi is not None and counts.get(t, 0) > hi)]
            if bad:
                out.append(("neighbor-count", format_ranges(ranges)))
        return out

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "types": sorted(self.types),
            "neighbor_multisets": {t: [list(m) for m in sorted(ms)]
                                   for t, ms in sorted(self.neighbor_multisets.items())},
            "neighbor_counts": {t: [{k: [lo, hi] for k, (lo, hi) in r.items()} for r in rs]
                                for t, rs in sorted(self.neighbor_counts.items())},
            "pairs": None if self.pairs is None else [list(p) for p in sorted(self.pairs)],
            "docks": {f"{a}--{b}": [{"at": list(p.at), "rot": list(p.rot)} for p in ps]
                      for (a, b), ps in sorted(self.docks.items())},
            "configs": {f"{a}--{b}": [{"a_site": c.a_site, "b_site": c.b_site,
                                       "at": None if c.placement is None else list(c.placement.at),
                                       "rot": None if c.placement is None else list(c.placement.rot)}
                                      for c in cs]
                        for (a, b), cs in sorted(self.configs.items())},
            "up": self.up,
            "parts": {t: {"ups": np.round(sp.ups, 6).tolist(), "symmetry": list(sp.orders),
                          "mirror": sp.mirror} for t, sp in sorted(self.parts.items())},
            "sites": {t: [{"name": st.name, "required": st.required,
                           "at": np.round(st.frames[:, :3, 3], 6).tolist()} for st in sts]
                      for t, sts in sorted(self.sites.items())},
            "ground": self.ground,
            "constraints": [{"name": n, "args": a} for n, a, _ in self.constraints],
        }


def format_multiset(m: tuple[str, ...]) -> str:
    return "{" + ", ".join(m) + "}"


def format_ranges(ranges: dict[str, tuple[int, int | None]]) -> str:
    return ", ".join(f"{t} in {lo}..{'' if hi is None else hi}" for t, (lo, hi) in sorted(ranges.items()))


# --------------------------------------------------------------------------------------------
# values (tiling statements need numbers, names and vectors)
# --------------------------------------------------------------------------------------------
def builtin_functions() -> dict[str, Any]:
    """The built-in expression functions, for callers that have no registries (reading an
    assembly's part sizes needs `sqrt`, never a plugin's function)."""
    from ..functions import BUILTIN_FUNCTIONS

    return {f.name: f for f in BUILTIN_FUNCTIONS}


class _Failed:
    """An attr or const whose value could not be computed: its error, raised where it is used
    (an unused one, e.g. a split grammar's `scope.sx` in a mixed file, does no harm)."""

    __slots__ = ("error",)

    def __init__(self, error: GrammarError):
        self.error = error


def _env(grammar: "Grammar | None", functions: Any = None) -> dict[str, Any]:
    env: dict[str, Any] = {}
    if grammar is None:
        return env
    functions = functions if functions is not None else builtin_functions()
    for st in (*grammar.attrs, *grammar.consts):
        try:
            env[st.name] = eval_value(st.value, env, functions)
        except GrammarError as exc:
            env[st.name] = _Failed(exc)
    return env


def eval_value(expr, env: dict[str, Any] | None = None, functions: Any = None) -> Any:  # noqa: ANN001
    """Value of a constant expression; a bare name not in `env` is a type name (a str).
    Errors are GrammarErrors located at the failing operator or call."""
    from ..expr_eval import evaluate

    env = env or {}
    variables = {k: v for k, v in env.items() if not isinstance(v, _Failed)}

    def names(name: str) -> Any:
        failed = env.get(name)
        if isinstance(failed, _Failed):
            raise failed.error
        return name if "." not in name else None
    try:
        return evaluate(expr, variables, functions=functions if functions is not None else builtin_functions(),
                        names=names)
    except GrammarError:
        raise
    except GrammarkitError as exc:  # a DerivationError/LimitError of the evaluator: the grammar's fault here
        d = exc.diagnostics[0]
        raise GrammarError(d.message, d.span, hint=d.hint, code=d.code) from None


def _need_number(v: Any, expr) -> None:  # noqa: ANN001
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise GrammarError(f"expected a number, got {v!r}", getattr(expr, "span", None))


def eval_number(expr, grammar: "Grammar | None" = None, functions: Any = None) -> float:  # noqa: ANN001
    v = eval_value(expr, _env(grammar, functions), functions)
    _need_number(v, expr)
    return float(v)


def rotation_matrix(rot_deg) -> np.ndarray:  # noqa: ANN001
    """Extrinsic XYZ Euler angles in degrees: R = Rz @ Ry @ Rx."""
    rx, ry, rz = (math.radians(float(a)) for a in rot_deg)
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def euler_degrees(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of `rotation_matrix` (extrinsic XYZ, degrees)."""
    sy = -R[2, 0]
    sy = max(-1.0, min(1.0, sy))
    ry = math.asin(sy)
    if abs(sy) < 1 - 1e-9:
        rx = math.atan2(R[2, 1], R[2, 2])
        rz = math.atan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: put everything in rz
        rx = 0.0
        rz = math.atan2(-R[0, 1], R[1, 1])
    return tuple(math.degrees(a) for a in (rx, ry, rz))  # type: ignore[return-value]


def placement_matrix(placement: "Placement", grammar: "Grammar | None" = None,
                     functions: Any = None) -> np.ndarray:
    env = _env(grammar, functions)
    at = [_num(e, env, functions) for e in placement.at]
    rot = [_num(e, env, functions) for e in placement.rot] if placement.rot else [0.0, 0.0, 0.0]
    T = np.eye(4)
    T[:3, :3] = rotation_matrix(rot)
    T[:3, 3] = at
    return T


# --------------------------------------------------------------------------------------------
# grammar -> rules
# --------------------------------------------------------------------------------------------
def known_types(grammar: "Grammar") -> frozenset[str]:
    """Every part type the grammar mentions (no geometry is loaded, no plugin consulted)."""
    return rules_from_grammar(grammar, resolve_constraints=False, site_placements=False).types


# long: one pass over the grammar's statements (parts, neighbours, sites, docks, constraints)
# filling one Rules object; each statement kind's details are in helpers
def rules_from_grammar(grammar: "Grammar", *, resolve_constraints: bool = True,
                       site_placements: bool = True, registries: Any = None) -> Rules:
    """Compile a tiling grammar's statements into `Rules` (raises GrammarError with spans).

    `site_placements=False` compiles without geometry: no part's file is read, so orientation,
    turn symmetries and the placements of `dock A.s -- B.t` are left out (`known_types`).
    `registries` (a grammarkit.registry.Registries) gives the constraints and functions;
    default: the installed plugins' (without `resolve_constraints`, no plugin is consulted and
    the built-in functions are used)."""
    from ..ir.grammar import Grammar

    if registries is None and resolve_constraints:
        from ..plugins import default_registries  # the public API edge

        registries = default_registries()
    functions = registries.functions if registries is not None else builtin_functions()

    if not isinstance(grammar, Grammar):
        raise GrammarError(f"expected a tiling Grammar (grammarkit.dsl.load), got {type(grammar).__name__}",
                           None, code="bad-argument")
    if grammar.family != "tiling":
        where = grammar.source_path or grammar.name or "the grammar"
        what = "a split grammar (rules, snippets)" if grammar.family == "split" else "a grammar without tiling statements"
        raise GrammarError(f"{where}: this is {what}; tiling rules come from "
                           "`part`, `dock`, `neighbors` and `constraint` statements", None,
                           code="not-tiling")
    env = _env(grammar, functions)
    rules = Rules(name=grammar.name)
    rules.up = grammar.ups[0].axis if grammar.ups else "+z"
    if rules.up == "none":
        rules.up = None
    types: set[str] = {p.name for p in grammar.parts}
    for nr in grammar.neighbor_rules:
        types.add(nr.part)
        if nr.multisets:
            prev = rules.neighbor_multisets.get(nr.part, frozenset())
            rules.neighbor_multisets[nr.part] = prev | {tuple(sorted(m)) for m in nr.multisets}
            for m in nr.multisets:
                types.update(m)
        if nr.counts:
            ranges = {}
            for c in nr.counts:
                if c.hi is not None and c.hi < c.lo:
                    raise GrammarError(f"neighbors {nr.part}: empty range {c.type} in {c.lo}..{c.hi}", c.span or nr.span)
                ranges[c.type] = (c.lo, c.hi)
                types.add(c.type)
            rules.neighbor_counts.setdefault(nr.part, []).append(ranges)
    for s in grammar.sites:
        types.add(s.part)
    rules.free = frozenset(p.name for p in grammar.parts if p.up_any)
    if site_placements:
        sources: dict = {}  # every part source file read once for the whole grammar
        rules.parts = _part_specs(grammar, rules.up, env, functions, sources)
        rules.sites = _site_specs(grammar, rules.up, env, functions)
    pairs: set[tuple[str, str]] = set()
    configs: dict[tuple[str, str], list[DockConfig]] = {}

    def add(a: str, b: str, config: DockConfig) -> None:
        configs.setdefault((a, b), []).append(config)
        back = None
        if config.placement is not None:  # the same docking seen from B
            inv = np.linalg.inv(config.placement.matrix())
            back = DockPlacement(tuple(float(x) for x in inv[:3, 3]), euler_degrees(inv[:3, :3]))  # type: ignore[arg-type]
        configs.setdefault((b, a), []).append(DockConfig(config.b_site, config.a_site, back))

    for d in grammar.docks:
        types.update((d.a, d.b))
        pairs.add(tuple(sorted((d.a, d.b))))  # type: ignore[arg-type]
        for side, site in ((d.a, d.a_site), (d.b, d.b_site)):
            if site is not None and not any(x.part == side and x.name == site for x in grammar.sites):
                raise GrammarError(f"part '{side}' has no site '{site}'", d.span, code="unknown-site")
        for pl in d.placements:
            at = tuple(_num(e, env, functions) for e in pl.at)
            rot = tuple(_num(e, env, functions) for e in pl.rot) if pl.rot else (0.0, 0.0, 0.0)
            add(d.a, d.b, DockConfig(d.a_site, d.b_site, DockPlacement(at, rot)))  # type: ignore[arg-type]
        if d.placements:
            continue
        if d.a_site is not None and d.b_site is not None:
            if site_placements:
                for fwd in _site_placements(grammar, d, rules):
                    add(d.a, d.b, DockConfig(d.a_site, d.b_site, fwd))
            else:
                add(d.a, d.b, DockConfig(d.a_site, d.b_site, None))
        else:
            # no placement: anywhere (a plain dock widens whatever else the pair allows), or,
            # with a site on one side, anywhere on the other part but at that site
            add(d.a, d.b, DockConfig(d.a_site, d.b_site, None))
    rules.pairs = frozenset(pairs) if grammar.docks else None
    rules.configs = {k: tuple(v) for k, v in configs.items()}
    rules.docks = {k: tuple(c.placement for c in v if c.placement is not None)
                   for k, v in configs.items() if any(c.placement is not None for c in v)}
    compiled = []
    grounded_without_level = False
    for c in grammar.constraints:
        args = _constraint_args(c, env, functions, registries if resolve_constraints else None)
        for v in args.values():
            if isinstance(v, str) and c.name in ("path", "count"):
                types.add(v)
        if c.name == "grounded" and args.get("ground") is None:
            grounded_without_level = True
        compiled.append((c.name, args, str(c.span) if c.span else f"constraint {c.name}"))
    rules.constraints = tuple(compiled)
    if site_placements and grounded_without_level and grammar.examples:
        rules.ground = _examples_ground(grammar, rules.up, sources)
    for ex in grammar.examples:
        types.update(ip.type for ip in ex.parts)
    rules.types = frozenset(types)
    return rules


def _up(axis: str | None) -> np.ndarray:
    from .orientation import up_vector

    v = up_vector(axis)
    return v if v is not None else np.array([0.0, 0.0, 1.0])


def _examples_ground(grammar: "Grammar", up: str | None, sources: dict | None = None) -> float | None:
    """The examples' lowest point along the up axis: where `grounded` puts the ground when the
    grammar does not say (`grounded(ground=...)`). `sources`: files the parts were read from
    (not read again)."""
    from ..errors import ShapeError
    from .io import load_examples

    try:
        examples = load_examples(grammar, check_types=False, cache=sources)
    except ShapeError:
        return None  # reported where the examples are used; the shape's own minimum applies
    u = _up(up)
    k, sign = int(np.argmax(np.abs(u))), float(np.sign(u[int(np.argmax(np.abs(u)))]))
    lows = [float(a.bounds[0 if sign > 0 else 1][k]) for a in examples if a.parts]
    return (min(lows) if sign > 0 else max(lows)) if lows else None


def _part_specs(grammar: "Grammar", up: str | None, env: dict[str, Any], functions: Any,
                sources: dict) -> dict[str, PartSpec]:
    """Each `part` statement's prototype, read once: its Kalojanov frame, size, allowed up
    directions and turn symmetry (declared, or the geometry's: orientation.turn_order)."""
    from ..errors import ShapeError
    from .frames import local_frame
    from .io import part_prototype
    from .orientation import turn_order

    upv = _up(up)
    out: dict[str, PartSpec] = {}
    for pd in grammar.parts:
        if pd.name in out or pd.up_any:
            continue  # up(any): no pose to check; turns come from each part's own geometry
        try:
            mesh = part_prototype(grammar, pd.name, cache=sources)
        except ShapeError as exc:
            raise GrammarError(f"part {pd.name}: {exc}", pd.span, code="bad-part") from None
        V = np.asarray(mesh.vertices, dtype=np.float64)
        F = local_frame(V, np.asarray(mesh.faces))
        size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 0.0
        ups = []
        for d in pd.up:
            v = np.array([_num(e, env, functions) for e in d])
            if not np.isfinite(v).all() or np.linalg.norm(v) <= 1e-12:
                raise GrammarError(f"part {pd.name}: up(...) direction {tuple(v)} has no length", pd.span,
                                   code="bad-up")
            ups.append(v / np.linalg.norm(v))
        if not ups:
            ups = [upv]
        if pd.symmetry is not None:
            n = 1 if pd.symmetry == "none" else int(pd.symmetry[1:])
            orders = tuple(n for _ in ups)
        elif up is None:
            orders = tuple(1 for _ in ups)  # no up axis: the geometry's full symmetry is used instead
        else:
            orders = tuple(turn_order(V, F[:3, 3], u) for u in ups)
        out[pd.name] = PartSpec(pd.name, F, size, np.array(ups), orders, pd.symmetry is not None, pd.mirror, V)
    return out


def _site_specs(grammar: "Grammar", up: str | None, env: dict[str, Any], functions: Any
                ) -> dict[str, tuple[SiteSpec, ...]]:
    out: dict[str, list[SiteSpec]] = {}
    done: set[tuple[str, str]] = set()
    for sd in grammar.sites:
        if (sd.part, sd.name) in done:
            continue
        done.add((sd.part, sd.name))
        frames = np.array(_site_frames(grammar, sd.part, sd.name, env, sd.span, functions, up))
        required = any(x.required for x in grammar.sites if x.part == sd.part and x.name == sd.name)
        out.setdefault(sd.part, []).append(SiteSpec(sd.part, sd.name, frames, required))
    return {k: tuple(v) for k, v in out.items()}


_AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}


def _site_frames(grammar: "Grammar", part: str, site: str, env: dict[str, Any], span,  # noqa: ANN001
                 functions: Any, up: str | None = "+z") -> list[np.ndarray]:
    """The site's frame(s) in the part's modelling frame: origin at the site, x = facing,
    z = the grammar's up axis (or, for a site facing along it, the next axis: +y for +z);
    `mirror AXIS` adds the mirror image."""
    defs = [s for s in grammar.sites if s.part == part and s.name == site]
    if not defs:
        raise GrammarError(f"part '{part}' has no site '{site}'", span)
    upv = _up(up)
    alt = np.roll(upv, 1)  # +z -> +y (the convention before up axes), +y -> +x, +x -> +z
    out = []
    for sd in defs:
        pos = np.array([_num(e, env, functions) for e in sd.position])
        facing = np.array(_AXES[sd.facing], dtype=np.float64)
        variants = [(pos, facing)]
        if sd.mirror is not None:
            k = "xyz".index(sd.mirror)
            flip = np.ones(3)
            flip[k] = -1.0
            variants.append((pos * flip, facing * flip))
        for p, x in variants:
            z = alt if abs(x @ upv) > 0.5 else upv
            y = np.cross(z, x)
            F = np.eye(4)
            F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = x, y, np.cross(x, y), p
            out.append(F)
    return out


def _site_placements(grammar: "Grammar", d, rules: Rules) -> list[DockPlacement]:  # noqa: ANN001
    """`dock A.s -- B.t`: B placed so that its site t meets A's site s face to face (t's facing
    opposite to s's, up kept), converted from the parts' modelling frames (the frames their
    `part` geometry is defined in) to their Kalojanov frames, in which validation compares."""
    missing = [t for t in (d.a, d.b) if t not in rules.parts]
    if missing:
        raise GrammarError(f"dock {d.a}.{d.a_site} -- {d.b}.{d.b_site}: the sites' placement needs the "
                           f"parts' geometry: no `part {missing[0]} = ...` statement", d.span)
    Fa, Fb = rules.parts[d.a].frame, rules.parts[d.b].frame
    site_a = next(x for x in rules.sites[d.a] if x.name == d.a_site)
    site_b = next(x for x in rules.sites[d.b] if x.name == d.b_site)
    out = []
    for Sa in site_a.frames:
        for Sb in site_b.frames:
            # half a turn about the site's own up (its z axis): in site coordinates diag(-1,-1,1)
            model = Sa @ np.diag([-1.0, -1.0, 1.0, 1.0]) @ np.linalg.inv(Sb)  # B's modelling frame in A's
            rel = np.linalg.inv(Fa) @ model @ Fb  # B's Kalojanov frame in A's
            out.append(DockPlacement(tuple(float(x) for x in rel[:3, 3]), euler_degrees(rel[:3, :3])))  # type: ignore[arg-type]
    return out


def _num(expr, env, functions: Any = None) -> float:  # noqa: ANN001
    v = eval_value(expr, env, functions)
    _need_number(v, expr)
    return float(v)


def _constraint_args(c, env: dict[str, Any], functions: Any, registries: Any) -> dict[str, Any]:  # noqa: ANN001
    """Bind positional and named arguments to the constraint's declared parameters (the
    binder `check` uses), then evaluate them. Without registries: by position or name."""
    if registries is None:
        return {(a.name if a.name else str(i)): eval_value(a.value, env, functions)
                for i, a in enumerate(c.args)}
    from ..dsl.binding import bind_operation

    specs = registries.constraints
    spec = specs.get(c.name)
    if spec is None:
        raise GrammarError(f"unknown constraint '{c.name}'", c.span, code="unknown-constraint",
                           hint=f"known constraints: {', '.join(sorted(specs)) or 'none'}")
    binding = bind_operation(c, spec, label=f"constraint {c.name}")
    if binding.problems:
        d = binding.problems[0]
        raise GrammarError(d.message, d.span, hint=d.hint, code=d.code)
    return {b.param.name: (b.param.default if b.value is None else eval_value(b.value, env, functions))
            for b in binding.arguments}
