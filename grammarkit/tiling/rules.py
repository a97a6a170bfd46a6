"""The checkable content of a tiling grammar: `Rules`, compiled from the grammar's statements.

What each statement means for validation (see docs/tiling.md):
- `neighbors T: {A, A, B} | {A}`: the multiset of neighbour types of every T part must be one
  of the listed ones exactly (Kalojanov's "exact neighbour-type count vectors").
- `neighbors T: A in 1..2, B in 0..1`: per-type count ranges; types not listed may not be
  neighbours of T (closed world). Several `neighbors T` statements: multisets are pooled,
  count ranges must all hold.
- `dock A -- B` (with or without sites): A and B may touch. As soon as a grammar has any dock
  statement, a contact between two types with no dock is a violation ("allowed type pairs").
- `dock A -- B { at (x, y, z) rot (rx, ry, rz) | ... }`: the allowed relative placements of a B
  part in an A part's local frame (frames.py: Kalojanov's diagonal frame; degrees, extrinsic
  XYZ). A touching A-B pair must match one within `position_tolerance` (times the larger
  part's diagonal) and `angle_tolerance` degrees, modulo the parts' own symmetries.
- `constraint NAME(args)`: a global constraint from the plugin registry (`connected`,
  `grounded`, `path(from=A, to=B)`, `count(T, lo, hi)`, or a plugin's).

`Rules` is a plain picklable dataclass, so worker processes (the graph sampler) can share it.

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
    "DockPlacement", "Rules", "eval_number", "eval_value", "known_types", "placement_matrix",
    "rotation_matrix", "rules_from_grammar",
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


def rules_from_grammar(grammar: "Grammar", *, resolve_constraints: bool = True,
                       site_placements: bool = True, registries: Any = None) -> Rules:
    """Compile a tiling grammar's statements into `Rules` (raises GrammarError with spans).

    `site_placements=False` skips turning `dock A.s -- B.t` into placements (which needs the
    parts' geometry). `registries` (a grammarkit.registry.Registries) gives the constraints
    and functions; default: the installed plugins' (without `resolve_constraints`, no plugin
    is consulted and the built-in functions are used)."""
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
    pairs: set[tuple[str, str]] = set()
    docks: dict[tuple[str, str], list[DockPlacement]] = {}
    for d in grammar.docks:
        types.update((d.a, d.b))
        pairs.add(tuple(sorted((d.a, d.b))))  # type: ignore[arg-type]
        for pl in d.placements:
            at = tuple(_num(e, env, functions) for e in pl.at)
            rot = tuple(_num(e, env, functions) for e in pl.rot) if pl.rot else (0.0, 0.0, 0.0)
            fwd = DockPlacement(at, rot)  # type: ignore[arg-type]
            docks.setdefault((d.a, d.b), []).append(fwd)
            # the same docking seen from B (for A == B both directions are allowed placements)
            inv = np.linalg.inv(fwd.matrix())
            back = DockPlacement(tuple(float(x) for x in inv[:3, 3]), euler_degrees(inv[:3, :3]))  # type: ignore[arg-type]
            docks.setdefault((d.b, d.a), []).append(back)
    for s in grammar.sites:
        types.add(s.part)
    for d in grammar.docks:
        if site_placements and d.a_site is not None and d.b_site is not None:
            for fwd in _site_placements(grammar, d, env, functions):
                docks.setdefault((d.a, d.b), []).append(fwd)
                inv = np.linalg.inv(fwd.matrix())
                back = DockPlacement(tuple(float(x) for x in inv[:3, 3]), euler_degrees(inv[:3, :3]))  # type: ignore[arg-type]
                docks.setdefault((d.b, d.a), []).append(back)
    rules.pairs = frozenset(pairs) if grammar.docks else None
    rules.docks = {k: tuple(v) for k, v in docks.items()}
    compiled = []
    for c in grammar.constraints:
        args = _constraint_args(c, env, functions, registries if resolve_constraints else None)
        for v in args.values():
            if isinstance(v, str) and c.name in ("path", "count"):
                types.add(v)
        compiled.append((c.name, args, str(c.span) if c.span else f"constraint {c.name}"))
    rules.constraints = tuple(compiled)
    for ex in grammar.examples:
        types.update(ip.type for ip in ex.parts)
    rules.types = frozenset(types)
    return rules


_AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}


def _site_frames(grammar: "Grammar", part: str, site: str, env: dict[str, Any], span,  # noqa: ANN001
                 functions: Any) -> list[np.ndarray]:
    """The site's frame(s) in the part's modelling frame: origin at the site, x = facing,
    z = up (+z, or +y for sites facing up or down); `mirror AXIS` adds the mirror image."""
    defs = [s for s in grammar.sites if s.part == part and s.name == site]
    if not defs:
        raise GrammarError(f"part '{part}' has no site '{site}'", span)
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
            up = np.array([0.0, 1.0, 0.0]) if abs(x[2]) > 0.5 else np.array([0.0, 0.0, 1.0])
            y = np.cross(up, x)
            F = np.eye(4)
            F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = x, y, np.cross(x, y), p
            out.append(F)
    return out


def _site_placements(grammar: "Grammar", d, env: dict[str, Any], functions: Any) -> list[DockPlacement]:  # noqa: ANN001
    """`dock A.s -- B.t`: B placed so that its site t meets A's site s face to face (t's facing
    opposite to s's, up kept), converted from the parts' modelling frames (the frames their
    `part` geometry is defined in) to their Kalojanov frames, in which validation compares."""
    from ..errors import ShapeError
    from .frames import local_frame
    from .io import part_prototype

    try:
        protos = {t: part_prototype(grammar, t) for t in {d.a, d.b}}
    except ShapeError as exc:
        raise GrammarError(f"dock {d.a}.{d.a_site} -- {d.b}.{d.b_site}: the sites' placement needs the "
                           f"parts' geometry: {exc}", d.span) from None
    Fa = local_frame(np.asarray(protos[d.a].vertices, dtype=np.float64), np.asarray(protos[d.a].faces))
    Fb = local_frame(np.asarray(protos[d.b].vertices, dtype=np.float64), np.asarray(protos[d.b].faces))
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])  # half a turn about the site's up axis: facings oppose
    out = []
    for Sa in _site_frames(grammar, d.a, d.a_site, env, d.span, functions):
        for Sb in _site_frames(grammar, d.b, d.b_site, env, d.span, functions):
            model = Sa @ turn @ np.linalg.inv(Sb)  # B's modelling frame in A's
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
