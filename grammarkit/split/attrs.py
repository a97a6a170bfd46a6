"""The user-settable values of a compiled grammar: each attr's description (`AttrInfo`), the
environment attr and const expressions are evaluated on (`ValueEnv`), and the check of a user's
value against the attr's type, range or enum (`check_attr_value`)."""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import GrammarError
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
