"""Values and operators of the expression language: the limits, `NOT_CONSTANT`, the operator
implementations (with their located errors), compiled constants and the call of a built-in
function as the engines make it. Both the compiler and the constant folder use exactly these,
so the two agree (see grammarkit.expr_eval for the semantics).
"""
from __future__ import annotations

import math
import random
from typing import Any, Callable, Mapping

from ..errors import DerivationError, LimitError
from ..ir.base import Span

Compiled = Callable[[Any], Any]
Resolver = Callable[[str, "Span | None"], "Compiled | None"]

# Longest string an expression may compute (names, colours, paths, materials are far shorter).
MAX_STRING_LENGTH = 100_000
# Largest integer (in bits) an expression may compute exactly; floats take over up to ~1e308.
MAX_INT_BITS = 1024
_INT_LIMIT = 1 << MAX_INT_BITS


# User functions: nested calls (recursion depth) and calls per evaluation of one expression.
MAX_CALL_DEPTH = 500
MAX_CALLS = 1_000_000
# Calls the checker makes to fold one constant call (beyond: "not constant", derive decides).
FOLD_MAX_CALLS = 10_000
# Python frames the interpreter may stack: a function call nests a few closures per level of
# its body, so MAX_CALL_DEPTH calls need more than Python's default limit of 1000 frames.
# Raised (never lowered) at the first top-level user-function call; a RecursionError that still
# happens (a body nested very deeply) becomes the same located LimitError.
_STACK_FRAMES = 40 * MAX_CALL_DEPTH


class _NotConstant:
    """The value of an expression that depends on the derivation (see `fold_constant`)."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "NOT_CONSTANT"

    def __bool__(self) -> bool:
        return False


NOT_CONSTANT: Any = _NotConstant()


class SimpleEnv:
    """A minimal environment for `evaluate`: variables by name and an optional seeded generator."""

    def __init__(self, variables: Mapping[str, Any] | None = None, seed: int = 0):
        self.variables = dict(variables or {})
        self._rng: random.Random | None = None
        self._seed = seed

    def rng(self) -> random.Random:
        if self._rng is None:
            self._rng = random.Random(self._seed)
        return self._rng


# -- values and their names in messages -------------------------------------------------------
def value_kind(v: Any) -> str:
    """How a value is named in messages: 'a number', 'a string', ..."""
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, tuple):
        return "a tuple"
    return f"a {type(v).__name__}"


def _fail(message: str, span: Span | None, code: str) -> DerivationError:
    return DerivationError(message, span, code=code)


def _operands(op: str, x: Any, y: Any, span: Span | None) -> DerivationError:
    return _fail(f"'{op}' cannot be applied to {value_kind(x)} and {value_kind(y)}", span, "bad-operands")


def _too_large(span: Span | None, what: str = "") -> DerivationError:
    return _fail(f"number too large{what}", span, "number-too-large")


def _string_limit(n: int, span: Span | None) -> LimitError:
    return LimitError(f"string limit exceeded: the expression makes a string of {n:,} characters, "
                      f"more than {MAX_STRING_LENGTH:,}", span, code="limit-string")


def _is_number(v: Any) -> bool:
    t = type(v)
    return t is float or t is int or (t is not bool and isinstance(v, (int, float)))


# -- the operators --------------------------------------------------------------------------
def _add(x: Any, y: Any, span: Span | None) -> Any:
    try:
        r = x + y
    except TypeError:
        raise _operands("+", x, y, span) from None
    t = type(r)
    if t is str:
        if len(r) > MAX_STRING_LENGTH:
            raise _string_limit(len(r), span)
    elif t is tuple:
        raise _operands("+", x, y, span)
    return r


def _sub(x: Any, y: Any, span: Span | None) -> Any:
    try:
        return x - y
    except TypeError:
        raise _operands("-", x, y, span) from None


def _mul(x: Any, y: Any, span: Span | None) -> Any:
    tx, ty = type(x), type(y)
    if tx is float or ty is float:
        if tx is str or ty is str or tx is tuple or ty is tuple:
            raise _operands("*", x, y, span)
        try:
            return x * y
        except TypeError:
            raise _operands("*", x, y, span) from None
    if tx is str or ty is str:
        s, n = (x, y) if tx is str else (y, x)
        if type(n) is not int:
            raise _operands("*", x, y, span)
        if len(s) * n > MAX_STRING_LENGTH:  # refuse before Python builds the string
            raise _string_limit(len(s) * n, span)
        return s * n
    if tx is tuple or ty is tuple:
        raise _operands("*", x, y, span)
    try:
        r = x * y
    except TypeError:
        raise _operands("*", x, y, span) from None
    if type(r) is int and not -_INT_LIMIT < r < _INT_LIMIT:
        raise _too_large(span)
    return r


def _div(x: Any, y: Any, span: Span | None) -> Any:
    if not (_is_number(x) and _is_number(y)):
        raise _operands("/", x, y, span)
    if y == 0:
        raise _fail("division by zero", span, "division-by-zero")
    try:
        return x / y
    except OverflowError:
        raise _too_large(span) from None


def _mod(x: Any, y: Any, span: Span | None) -> Any:
    """Remainder with the sign of the dividend (math.fmod), as a float like fmod's; integers
    are reduced exactly first, so a remainder of huge integers does not overflow."""
    if not (_is_number(x) and _is_number(y)):
        raise _operands("%", x, y, span)
    if y == 0:
        raise _fail("modulo by zero", span, "division-by-zero")
    try:
        if type(x) is int and type(y) is int:
            r = abs(x) % abs(y)
            return float(-r if x < 0 else r)
        return math.fmod(x, y)
    except OverflowError:
        raise _too_large(span) from None
    except ValueError:  # fmod(inf, y)
        raise _fail(f"{x!r} % {y!r} is not a number", span, "not-real") from None


def _pow(x: Any, y: Any, span: Span | None) -> Any:
    """`x ^ y` as a real number. Integer powers are exact only while they stay small: Python
    would otherwise compute `9 ^ 9 ^ 9` as an integer of 370 million digits (minutes, GBs),
    so large ones go through floats, which overflow to a clear error instead."""
    if not (_is_number(x) and _is_number(y)):
        raise _operands("^", x, y, span)
    if type(x) is int and type(y) is int and (y < 0 or y * max(abs(x).bit_length(), 1) > 256):
        try:
            x = float(x)
        except OverflowError:
            raise _too_large(span) from None
    try:
        r = x ** y
    except OverflowError:
        raise _too_large(span, f": {_short(x)} ^ {_short(y)}") from None
    except ZeroDivisionError:
        raise _fail("0 cannot be raised to a negative power", span, "division-by-zero") from None
    if isinstance(r, complex):
        raise _fail(f"{_short(x)} ^ {_short(y)} is not a real number", span, "not-real")
    return r


def _negate(x: Any, span: Span | None) -> Any:
    if not _is_number(x):
        raise _fail(f"'-' cannot be applied to {value_kind(x)}", span, "bad-operands")
    return -x


def _short(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 24 else text[:21] + "..."


def _compare(fn: Callable[[Any, Any], Any], op: str) -> Callable[[Any, Any, Any], Any]:
    def compare(x: Any, y: Any, span: Span | None) -> Any:
        try:
            return fn(x, y)
        except TypeError:
            raise _operands(op, x, y, span) from None
    return compare


_BINARY: dict[str, Callable[[Any, Any, Any], Any]] = {
    "+": _add, "-": _sub, "*": _mul, "/": _div, "%": _mod, "^": _pow,
    "<": _compare(lambda a, b: a < b, "<"), "<=": _compare(lambda a, b: a <= b, "<="),
    ">": _compare(lambda a, b: a > b, ">"), ">=": _compare(lambda a, b: a >= b, ">="),
}


# -- constants -------------------------------------------------------------------------------
def is_constant(f: Compiled) -> bool:
    """True for a closure made by `constant` (or folded from constants at compile time)."""
    return getattr(f, "_const", False)


def constant(value: Any) -> Compiled:
    """A compiled closure that returns `value` (its `_value`), recognised by `is_constant`."""
    def f(env: Any, _v=value) -> Any:
        return _v
    # function attributes mark the closure as a constant and carry its value (cheaper than a
    # callable object in the hot loop); type checkers do not know function attributes
    f._const = True  # type: ignore[attr-defined]
    f._value = value  # type: ignore[attr-defined]
    return f


def _not_constant(env: Any) -> Any:  # a placeholder for derivation-dependent values (folding)
    raise AssertionError("a non-constant placeholder was evaluated")


def arity_problem(func: str, spec: Any, n: int) -> str | None:
    """The message for calling `func` (a FunctionSpec) with `n` arguments, or None if fine."""
    if n >= spec.min_args and (spec.max_args is None or n <= spec.max_args):
        return None
    if spec.max_args is None:
        want = f"at least {spec.min_args}"
    elif spec.max_args == spec.min_args:
        want = str(spec.min_args)
    else:
        want = f"{spec.min_args} to {spec.max_args}"
    return f"function '{func}' takes {want} argument(s), got {n}"



def _call(impl: Callable[..., Any], name: str, vals: list, span: Span | None) -> Any:
    """A function call as the engines make it: errors and over-long strings located."""
    try:
        r = impl(*vals)
    except (ValueError, TypeError, ZeroDivisionError, OverflowError) as exc:
        raise _fail(f"{name}(): {exc}", span, "function-error") from None
    if type(r) is str and len(r) > MAX_STRING_LENGTH:
        raise _string_limit(len(r), span)
    return r

