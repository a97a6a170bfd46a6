"""The user-settable values of a compiled grammar: each attr's description (`AttrInfo`), the
environment attr and const expressions are evaluated on (`ValueEnv`), and the check of a user's
value against the attr's type, range or enum (`check_attr_value`)."""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import GrammarError
from ..ir import expr as E
from ..ir import split as S


@dataclass
class AttrInfo:
    """A user-settable parameter: a grammar attr or an attr of a bound snippet copy."""

    key: str  # "height" or "Roof.roof_deg"
    name: str
    attr: S.Attr
    scope: str | None  # anchor of the snippet copy, None for the grammar's own attrs
    snippet: str | None
    default: Callable = field(repr=False, default=None)  # type: ignore[assignment]
    lo: Callable | None = field(repr=False, default=None)
    hi: Callable | None = field(repr=False, default=None)
    choices: tuple[Callable, ...] | None = field(repr=False, default=None)


class ValueEnv:
    """What attr and const expressions are evaluated on: no scope, the derivation's values so
    far (`values`), and a generator seeded by the run seed (for `rand` in attr defaults)."""

    sz = (0.0, 0.0, 0.0)
    o = (0.0, 0.0, 0.0)
    params: tuple = ()
    si, st = 0, 1

    def __init__(self, seed: int, values: dict | None = None):
        self._rng = random.Random(seed ^ 0x5EED)
        self.values: dict[str, Any] = {} if values is None else values

    def rng(self) -> random.Random:
        return self._rng


# The key, in a derivation's values, of the attrs and consts still to be evaluated on the initial
# shape (not a name a grammar can spell): (keys in dependency order, run seed).
LOT_PENDING = " lot-values"

# names whose value depends on the shape an expression is evaluated on
_SHAPE_PREFIXES = ("scope.", "geometry.", "split.", "comp.", "occlusion:")


def _names(e: Any, refs: set, calls: set) -> None:
    if isinstance(e, E.Ref):
        refs.add(e.name)
    elif isinstance(e, E.Call):
        calls.add(e.func)
        for a in e.args:
            _names(a, refs, calls)
    elif isinstance(e, E.Unary):
        _names(e.operand, refs, calls)
    elif isinstance(e, E.Binary):
        _names(e.left, refs, calls)
        _names(e.right, refs, calls)
    elif isinstance(e, E.Vector):
        for a in e.items:
            _names(a, refs, calls)


def lot_order(exprs: dict[str, tuple[Any, str | None]], user: frozenset = frozenset()) -> tuple[str, ...]:
    """The attrs and consts (`exprs`: key -> (expression, anchor of its snippet copy or None))
    whose value reads the shape, directly (scope, geometry, ...; a user function, whose body may)
    or through another of them, in dependency order. CGA evaluates attrs and consts once, on
    the initial shape, before any rule is applied: these are evaluated on the lot."""
    deps: dict[str, set[str]] = {}
    direct: set[str] = set()
    for key, (e, anchor) in exprs.items():
        refs: set[str] = set()
        calls: set[str] = set()
        _names(e, refs, calls)
        if any(r.startswith(_SHAPE_PREFIXES) for r in refs) or calls & user:
            direct.add(key)
        found = set()
        for r in refs:
            local = f"{anchor}.{r}" if anchor else None
            if local is not None and local in exprs:
                found.add(local)
            elif r in exprs:
                found.add(r)
        deps[key] = found
    order: list[str] = []
    state: dict[str, int] = {}

    def visit(k: str) -> bool:  # True if k reads the shape
        if k in state:
            return state[k] == 2
        state[k] = 1  # visiting (a cycle reads as shape-free here; _evaluate reports it)
        reads = k in direct
        for d in sorted(deps[k]):
            reads = visit(d) or reads
        state[k] = 2 if reads else 3
        if reads:
            order.append(k)
        return reads

    for k in exprs:
        visit(k)
    return tuple(order)


class LotEnv:
    """The initial shape as attr and const values see it: its scope and geometry, the
    derivation's values, and a generator of its own (so the lot's own draws are unchanged)."""

    __slots__ = ("_shape", "_rng")

    def __init__(self, shape: Any, seed: int):
        self._shape = shape
        self._rng = random.Random(seed ^ 0x107)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._shape, name)

    def rng(self) -> random.Random:
        return self._rng


def lot_values_step(fns: dict[str, Callable]) -> Callable:
    """The first step of the start rule: on the derivation's first shape (the lot), evaluate
    the attrs and consts that read the shape (LOT_PENDING) into the derivation's values."""

    def lot_values(ctx: Any, s: Any) -> Any:
        values = s.values
        todo = values.pop(LOT_PENDING, None)
        if todo is not None:
            keys, seed = todo
            env = LotEnv(s, seed)
            for key in keys:
                values[key] = fns[key](env)
        return s
    return lot_values


def check_attr_value(info: AttrInfo, value: Any, env: Any = None) -> Any:
    """Convert and check a user value against the attr's type, range or enum (`env` holds the
    other values the attr's default and bounds may refer to)."""
    env = env or ValueEnv(0)
    default = info.default(env)
    if isinstance(value, str) and not isinstance(default, str):
        text = value.strip()
        if isinstance(default, bool):
            if text.lower() not in ("true", "false"):
                raise GrammarError(f"attr {info.key!r} is a boolean; got {value!r}", info.attr.span)
            value = text.lower() == "true"
        else:
            try:
                value = float(text)
            except ValueError:
                raise GrammarError(f"attr {info.key!r} is a number; got {value!r}", info.attr.span,
                                   code="bad-attr-value") from None
            if value.is_integer() and isinstance(default, int):
                value = int(value)
    # the value must have the default's type: a number (finite), a boolean or a string
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise GrammarError(f"attr {info.key!r} is a boolean; got {value!r}", info.attr.span,
                               code="bad-attr-value")
    elif isinstance(default, (int, float)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise GrammarError(f"attr {info.key!r} is a number; got {value!r}", info.attr.span,
                               code="bad-attr-value")
        if not math.isfinite(value):
            raise GrammarError(f"attr {info.key!r} must be a finite number; got {value!r}",
                               info.attr.span, code="bad-attr-value")
    elif isinstance(default, str) and not isinstance(value, str):
        raise GrammarError(f"attr {info.key!r} is a string; got {value!r}", info.attr.span,
                           code="bad-attr-value")
    if info.lo is not None:
        lo, hi = info.lo(env), info.hi(env)  # type: ignore[misc]
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not (lo <= value <= hi):
            raise GrammarError(f"attr {info.key!r} = {value!r} is outside its range [{lo:g}, {hi:g}]",
                               info.attr.span, code="attr-out-of-range")
    if info.choices is not None:
        options = [c(env) for c in info.choices]
        if value not in options:
            raise GrammarError(f"attr {info.key!r} = {value!r} is not one of {options}",
                               info.attr.span, code="attr-not-in-enum")
    return value
