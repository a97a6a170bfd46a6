"""The one expression evaluator of the language: split grammars, tiling grammars and `check`.

The split engine evaluates the same expressions thousands of times per building, so an
expression is compiled once into a closure `f(env)` (no tree walking, no pydantic access in
the hot loop). Names are resolved at compile time by a `resolve(name, span)` callback that
returns a closure or None; this keeps the evaluator free of any knowledge of shapes, rules or
geometry. `env` is whatever the caller passes at run time; resolvers decide which of its
attributes they read (the split engine passes a shape; `rand` draws from `env.rng()`).

Three ways in, one semantics:

- `compile_expr(expr, resolve, functions)`: the engines (split rules, attrs, consts);
- `fold_constant(expr, lookup, functions, errors)`: the checker's constant-folding mode, the
  value of an expression whose inputs are all known constants, or `NOT_CONSTANT`;
- `evaluate(expr, variables, functions=...)`: one-off evaluation (tiling statements, tools).

The semantics (docs/language.md "Expressions", pinned by tests/core/test_expressions.py):

- `a % b` is the remainder with the sign of the dividend (C, Java and CGA: `-7 % 3 == -1`),
  exact for integers of any size; `a / 0` and `a % 0` are errors ("division by zero",
  "modulo by zero").
- `a ^ b` is exact for small integers and goes through floats beyond (so `9 ^ 9 ^ 9` is a
  "number too large" error at once, not an integer of 370 million digits); a negative base
  with a fractional exponent is "not a real number".
- Integer products beyond MAX_INT_BITS bits are errors too (repeated squaring through
  consts would otherwise exhaust memory); so are computed strings longer than
  MAX_STRING_LENGTH characters (`"x" * 600000000` is a LimitError, not a 600 MB model).

Evaluation errors raise `DerivationError` (a `LimitError` for the string limit) carrying the
span of the operator or call that failed.
"""
from __future__ import annotations

import math
import random
from typing import Any, Callable, Mapping

from .errors import DerivationError, GrammarError, LimitError
from .ir.base import Span
from .ir.expr import Binary, Bool, Call, Num, Ref, Str, Unary, Vector

Compiled = Callable[[Any], Any]
Resolver = Callable[[str, "Span | None"], "Compiled | None"]

__all__ = ["Compiled", "MAX_INT_BITS", "MAX_STRING_LENGTH", "NOT_CONSTANT", "SimpleEnv",
           "arity_problem", "compile_expr", "constant", "evaluate", "fold_constant", "is_constant"]

# Longest string an expression may compute (names, colours, paths, materials are far shorter).
MAX_STRING_LENGTH = 100_000
# Largest integer (in bits) an expression may compute exactly; floats take over up to ~1e308.
MAX_INT_BITS = 1024
_INT_LIMIT = 1 << MAX_INT_BITS


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


# -- the compiler ------------------------------------------------------------------------------
class _Compiler:
    """One compilation. `fold_errors` (folding mode) collects the errors of constant
    subexpressions instead of deferring them to run time, and treats unknown functions and
    wrong arities (which the checker reports itself) as non-constant."""

    __slots__ = ("resolve", "functions", "fold_errors")

    def __init__(self, resolve: Resolver, functions: Mapping[str, Any],
                 fold_errors: list[DerivationError] | None = None):
        self.resolve = resolve
        self.functions = functions
        self.fold_errors = fold_errors

    def _lazy(self, name: str, args: list, span: Any) -> Compiled:
        """select()/pick(): only the chosen argument is evaluated."""
        g = _lazy_select(args, span) if name == "select" else _lazy_pick(args, span)
        if all(is_constant(x) for x in args):
            return self.fold(g)
        return g

    def fold(self, g: Compiled) -> Compiled:
        """Evaluate a closure whose inputs are all constant once, now. An error is deferred to
        run time (the engine reports it with the derivation's context), or collected when
        folding for the checker."""
        try:
            return constant(g(None))
        except DerivationError as exc:
            if self.fold_errors is not None:
                self.fold_errors.append(exc)
            return g

    def compile(self, e: Any) -> Compiled:
        span = e.span
        if isinstance(e, Num):
            v = e.value
            return constant(int(v) if float(v).is_integer() and abs(v) < 2 ** 53 else v)
        if isinstance(e, (Str, Bool)):
            return constant(e.value)
        if isinstance(e, Ref):
            f = self.resolve(e.name, span)
            if f is None:
                raise GrammarError(f"unknown name {e.name!r}", span, code="undefined-name")
            return f
        if isinstance(e, Vector):
            items = [self.compile(i) for i in e.items]
            if all(is_constant(i) for i in items):
                return constant(tuple(i._value for i in items))  # type: ignore[attr-defined]
            return lambda env: tuple(i(env) for i in items)
        if isinstance(e, Unary):
            return self.unary(e)
        if isinstance(e, Binary):
            return self.binary(e)
        if isinstance(e, Call):
            return self.call(e)
        raise GrammarError(f"not an expression: {type(e).__name__}", span)

    def unary(self, e: Unary) -> Compiled:
        a = self.compile(e.operand)
        span = e.span
        if e.op == "!":
            def g(env: Any) -> Any:
                return not a(env)
        elif e.op == "-":
            def g(env: Any) -> Any:
                return _negate(a(env), span)
        else:
            g = a
        return self.fold(g) if is_constant(a) else g

    def binary(self, e: Binary) -> Compiled:
        a = self.compile(e.left)
        b = self.compile(e.right)
        op, span = e.op, e.span
        if op == "&&":
            def g(env: Any) -> Any:
                return a(env) and b(env)
        elif op == "||":
            def g(env: Any) -> Any:
                return a(env) or b(env)
        elif op == "==":
            def g(env: Any) -> Any:
                return a(env) == b(env)
        elif op == "!=":
            def g(env: Any) -> Any:
                return a(env) != b(env)
        else:
            fn = _BINARY[op]

            def g(env: Any) -> Any:
                return fn(a(env), b(env), span)
        if is_constant(a) and is_constant(b):
            return self.fold(g)
        return g

    def call(self, e: Call) -> Compiled:
        span = e.span
        spec = self.functions.get(e.func)
        folding = self.fold_errors is not None
        if spec is None:
            if folding:
                return _not_constant
            known = ", ".join(sorted(self.functions))
            raise GrammarError(f"unknown function {e.func!r}", span, hint=f"known functions: {known}",
                               code="unknown-function")
        problem = arity_problem(e.func, spec, len(e.args))
        if problem is not None:
            if folding:
                return _not_constant
            raise GrammarError(problem, span, code="function-arity")
        args = [self.compile(x) for x in e.args]
        name = e.func
        if name == "rand":
            from .functions import RANDOM_FUNCTIONS
            impl = RANDOM_FUNCTIONS["rand"]

            def rand(env: Any) -> Any:
                vals = [x(env) for x in args]
                if len(vals) == 1:
                    vals = [0.0, vals[0]]
                try:
                    return impl(env.rng(), *vals)
                except (ValueError, TypeError, OverflowError) as exc:
                    raise _fail(f"rand(): {exc}", span, "function-error") from None
            return rand
        if name in ("select", "pick"):
            return self._lazy(name, args, span)
        from .functions import FILE_FUNCTIONS
        if name in FILE_FUNCTIONS:
            return _file_function(name, args[0], span)
        impl = spec.impl
        if impl is None:
            if folding:
                return _not_constant
            raise GrammarError(f"function {name!r} has no implementation (plugin {spec.plugin!r})", span,
                               code="function-without-impl")

        def call(env: Any) -> Any:
            return _call(impl, name, [x(env) for x in args], span)
        if all(is_constant(x) for x in args):
            return self.fold(call)
        return call


# Distinct queries (paths) whose answer one compiled file-function call remembers.
_FILE_CACHE_SIZE = 256


def _file_function(name: str, arg: Compiled, span: Span | None) -> Compiled:
    """CGA's fileSearch/fileRandom/fileExists bound to the folder of the grammar file that says
    the expression (as the compiler resolves a constant `i()` path). Each compiled call looks a
    query up once and remembers the answer: a facade asks the same query for every tile, and
    the files of one derivation do not change under it."""
    from pathlib import Path

    from .functions import TooManyFiles, file_exists, file_random, search_files

    base = (Path(span.file).parent if span is not None and span.file else Path(".")).resolve()
    cache: dict[str, Any] = {}

    def answer(env: Any) -> Any:
        q = arg(env)
        if not isinstance(q, str):
            raise _fail(f"{name}(): the {'path' if name == 'fileExists' else 'query'} must be a string, "
                        f"got {value_kind(q)}", span, "bad-operands")
        hit = cache.get(q)
        if hit is None:
            try:
                hit = file_exists(q, base) if name == "fileExists" else search_files(q, base)
            except TooManyFiles as exc:
                raise LimitError(f"{name}(): {exc}", span, code="limit-files") from None
            except (ValueError, OSError) as exc:
                raise _fail(f"{name}(): {exc}", span, "function-error") from None
            if len(cache) < _FILE_CACHE_SIZE:
                cache[q] = hit
        return hit

    if name == "fileExists":
        return answer
    if name == "fileSearch":
        return lambda env: "".join(p + ";" for p in answer(env))
    return lambda env: file_random(env.rng(), answer(env))


def _lazy_select(args: list, span: Any) -> Compiled:
    cond, a, b = args

    def select(env: Any) -> Any:
        return a(env) if cond(env) else b(env)
    return select


def _lazy_pick(args: list, span: Any) -> Compiled:
    u, rest = args[0], args[1:]
    if len(rest) % 2 == 0:
        def missing(env: Any) -> Any:
            raise _fail("pick(u, p1, v1, ..., other) needs the 'other' value last", span, "function-error")
        return missing
    pairs, other = list(zip(rest[0:-1:2], rest[1:-1:2])), rest[-1]

    def pick(env: Any) -> Any:
        x, acc = u(env), 0.0
        for p, v in pairs:
            acc += p(env)
            if x < acc:
                return v(env)
        return other(env)
    return pick


def compile_expr(expr: Any, resolve: Resolver, functions: Mapping[str, Any]) -> Compiled:
    """Compile an IR expression into `f(env)`.

    `resolve(name, span)` returns a compiled closure for a reference (or None: unknown name,
    reported as a GrammarError at the reference). `functions` maps names to FunctionSpecs
    (`registries.functions`). `rand` draws from `env.rng()`. Errors of constant
    subexpressions are deferred to run time.
    """
    if functions is None:
        raise TypeError("compile_expr: functions= is required (e.g. registries.functions)")
    return _Compiler(resolve, functions).compile(expr)


def fold_constant(expr: Any, lookup: Callable[[str], Any], functions: Mapping[str, Any],
                  errors: list[DerivationError] | None = None) -> Any:
    """The checker's constant-folding mode: the value of `expr` if every name in it is a
    known constant (`lookup(name)` returns its value, or NOT_CONSTANT), else NOT_CONSTANT.

    Errors of constant subexpressions (`1 / 0`, `9 ^ 9 ^ 9`, `"x" * 600000000`) are appended
    to `errors` as the DerivationErrors the engines would raise. Unknown names and functions
    make the expression non-constant (the checker reports them on its own).

    This walks the tree instead of compiling closures (the checker folds every expression of a
    file once), with the very operator and call implementations `compile_expr` uses, and folds
    exactly what `compile_expr` folds."""
    collected: list[DerivationError] = [] if errors is None else errors
    return _Folder(lookup, functions, collected).fold(expr)


class _Folder:
    __slots__ = ("lookup", "functions", "errors")

    def __init__(self, lookup: Callable[[str], Any], functions: Mapping[str, Any],
                 errors: list[DerivationError]):
        self.lookup, self.functions, self.errors = lookup, functions, errors

    def _run(self, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except DerivationError as exc:
            self.errors.append(exc)
            return NOT_CONSTANT

    def fold(self, e: Any) -> Any:  # noqa: C901 - one branch per node kind, as in _Compiler
        if isinstance(e, Num):
            v = e.value
            return int(v) if float(v).is_integer() and abs(v) < 2 ** 53 else v
        if isinstance(e, (Str, Bool)):
            return e.value
        if isinstance(e, Ref):
            return self.lookup(e.name)
        if isinstance(e, Vector):
            items = [self.fold(i) for i in e.items]
            return NOT_CONSTANT if any(i is NOT_CONSTANT for i in items) else tuple(items)
        if isinstance(e, Unary):
            x = self.fold(e.operand)
            if x is NOT_CONSTANT:
                return x
            if e.op == "!":
                return not x
            if e.op == "-":
                return self._run(lambda: _negate(x, e.span))
            return x
        if isinstance(e, Binary):
            x, y = self.fold(e.left), self.fold(e.right)
            if x is NOT_CONSTANT or y is NOT_CONSTANT:
                return NOT_CONSTANT
            op = e.op
            if op == "&&":
                return x and y
            if op == "||":
                return x or y
            if op == "==":
                return x == y
            if op == "!=":
                return x != y
            fn = _BINARY[op]
            return self._run(lambda: fn(x, y, e.span))
        if isinstance(e, Call):
            spec = self.functions.get(e.func)
            if spec is None or arity_problem(e.func, spec, len(e.args)) is not None:
                for a in e.args:  # their own errors still count
                    self.fold(a)
                return NOT_CONSTANT
            if e.func == "select":  # lazy: only the chosen value may fail
                c = self.fold(e.args[0])
                return NOT_CONSTANT if c is NOT_CONSTANT else self.fold(e.args[1] if c else e.args[2])
            if e.func == "pick":
                return NOT_CONSTANT
            args = [self.fold(a) for a in e.args]
            if e.func == "rand" or spec.impl is None or any(a is NOT_CONSTANT for a in args):
                return NOT_CONSTANT
            return self._run(lambda: _call(spec.impl, e.func, args, e.span))
        return NOT_CONSTANT


def _call(impl: Callable[..., Any], name: str, vals: list, span: Span | None) -> Any:
    """A function call as the engines make it: errors and over-long strings located."""
    try:
        r = impl(*vals)
    except (ValueError, TypeError, ZeroDivisionError, OverflowError) as exc:
        raise _fail(f"{name}(): {exc}", span, "function-error") from None
    if type(r) is str and len(r) > MAX_STRING_LENGTH:
        raise _string_limit(len(r), span)
    return r


def evaluate(expr: Any, variables: Mapping[str, Any] | None = None, *, functions: Mapping[str, Any],
             seed: int = 0, names: Callable[[str], Any] | None = None) -> Any:
    """Evaluate one expression with plain variables (dotted names included as keys).

    `names(name)` gives a value for a name that is not a variable (e.g. a tiling grammar's
    bare part-type names), or None: unknown. Engines should `compile_expr` once instead.
    """
    env = SimpleEnv(variables, seed)

    def resolve(name: str, span: Span | None) -> Compiled | None:
        if name in env.variables:
            return lambda en, _n=name: en.variables[_n]
        if names is not None:
            value = names(name)
            if value is not None:
                return constant(value)
        return None
    return compile_expr(expr, resolve, functions)(env)
