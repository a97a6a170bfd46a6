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

User functions (`func f(a, b) = expr`, docs/language.md "Functions") come in as a
`FunctionTable` (`user=`): overloads by arity, each body compiled once, lazily, with its
parameters read from a call frame and every other name resolved as the caller's resolver
does. Calls are by value and may recurse (directly or mutually); `select`, `pick`, `&&` and
`||` evaluate lazily, so a recursion guarded by them ends. Nesting deeper than MAX_CALL_DEPTH
calls, or more than MAX_CALLS calls for one evaluation, is a located LimitError naming the
function.

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
import sys
from typing import Any, Callable, Iterable, Mapping

from .errors import DerivationError, GrammarError, LimitError
from .ir.base import Span
from .ir.expr import Binary, Bool, Call, Num, Ref, Str, Unary, Vector

Compiled = Callable[[Any], Any]
Resolver = Callable[[str, "Span | None"], "Compiled | None"]

__all__ = ["Compiled", "FunctionTable", "MAX_CALLS", "MAX_CALL_DEPTH", "MAX_INT_BITS", "MAX_STRING_LENGTH",
           "NOT_CONSTANT", "SimpleEnv", "arity_problem", "compile_expr", "constant", "evaluate",
           "fold_constant", "folding_table", "is_constant"]

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

    __slots__ = ("resolve", "functions", "fold_errors", "user")

    def __init__(self, resolve: Resolver, functions: Mapping[str, Any],
                 fold_errors: list[DerivationError] | None = None, user: "FunctionTable | None" = None):
        self.resolve = resolve
        self.functions = functions
        self.fold_errors = fold_errors
        self.user = user

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
        folding = self.fold_errors is not None
        user = self.user
        if user is not None and e.func in user.overloads:  # a user function hides a built-in one
            problem = user.arity_problem(e.func, len(e.args))
            if problem is not None:
                if folding:
                    return _not_constant
                raise GrammarError(problem, span, hint=user.signatures(e.func), code="function-arity")
            args = [self.compile(x) for x in e.args]
            return _user_call(user, user.body(e.func, len(args)), args, span)
        spec = self.functions.get(e.func)
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


# -- user functions --------------------------------------------------------------------------
class _Body:
    """One overload's compiled body; `fn` is set once compiled (a recursive call compiled
    while its own body is being compiled reads it at run time)."""

    __slots__ = ("name", "params", "fn")

    def __init__(self, name: str, params: tuple[str, ...]):
        self.name, self.params = name, params
        self.fn: Compiled | None = None


class _Frame:
    """What a function body is evaluated on: the caller's environment (`env`, never a frame:
    names other than parameters are read from it), the argument values, the call depth and
    the count of calls made so far in this evaluation (a one-item list shared by all frames)."""

    __slots__ = ("env", "args", "depth", "calls")

    def __init__(self, env: Any, args: list, depth: int, calls: list):
        self.env, self.args, self.depth, self.calls = env, args, depth, calls

    def rng(self) -> random.Random:  # rand() and fileRandom() in a body draw from the caller's
        return self.env.rng()


class FunctionTable:
    """The user functions of a grammar (`func` statements, `grammarkit.ir.Function`) for one way
    of resolving names: `resolve(name, span)` gives a closure (or None: unknown) for a name a
    body uses that is not one of its parameters, as for the grammar's top-level expressions
    (attrs, consts, built-in values); a parameter hides an attr or const of the same name.

    Overloads are told apart by arity; the first definition of a name and arity counts (the
    checker reports the others). Bodies are compiled once, at their first call site, with
    `prepare(expr)` applied first when given (an engine's rewrite of its own built-ins)."""

    def __init__(self, functions: Iterable[Any], resolve: Resolver, builtins: Mapping[str, Any], *,
                 prepare: Callable[[Any], Any] | None = None, max_calls: int = MAX_CALLS):
        self.overloads: dict[str, dict[int, Any]] = {}
        for f in functions:
            self.overloads.setdefault(f.name, {}).setdefault(len(f.params), f)
        self.resolve = resolve
        self.builtins = builtins
        self.prepare = prepare
        self.max_calls = max_calls
        self._bodies: dict[tuple[str, int], _Body] = {}

    def __bool__(self) -> bool:
        return bool(self.overloads)

    def signatures(self, name: str) -> str:
        """The overloads of `name`, for messages: "defined: f(n) at file:2:1; f(a, b) at ..."."""
        parts = []
        for n in sorted(self.overloads.get(name, {})):
            d = self.overloads[name][n]
            where = f" at {d.span}" if d.span is not None and d.span.line else ""
            parts.append(f"{name}({', '.join(d.params)}){where}")
        return "defined: " + "; ".join(parts)

    def arity_problem(self, name: str, n: int) -> str | None:
        arities = sorted(self.overloads[name])
        if n in arities:
            return None
        want = " or ".join(str(a) for a in arities) if len(arities) <= 2 else \
            ", ".join(str(a) for a in arities[:-1]) + f" or {arities[-1]}"
        return f"function '{name}' takes {want} argument(s), got {n}"

    def body(self, name: str, n: int) -> _Body:
        key = (name, n)
        found = self._bodies.get(key)
        if found is not None:
            return found
        d = self.overloads[name][n]
        params = tuple(d.params)
        outer = self.resolve
        found = self._bodies[key] = _Body(name, params)

        def resolve(ref: str, span: Span | None) -> Compiled | None:
            if ref in params:
                i = params.index(ref)
                return lambda fr, _i=i: fr.args[_i]
            g = outer(ref, span)
            if g is None or is_constant(g):
                return g
            return lambda fr, _g=g: _g(fr.env)
        try:
            value = self.prepare(d.value) if self.prepare is not None else d.value
            found.fn = _Compiler(resolve, self.builtins, user=self).compile(value)
        except BaseException:
            del self._bodies[key]
            raise
        return found


def _ensure_stack() -> None:
    if sys.getrecursionlimit() < _STACK_FRAMES:
        sys.setrecursionlimit(_STACK_FRAMES)


def _user_call(table: FunctionTable, body: _Body, args: list, span: Span | None) -> Compiled:
    """A call of a user function: arguments evaluated in the caller's frame (by value), the body
    on a new frame; the depth and call-count guards; RecursionError -> the same LimitError."""
    name = body.name
    max_calls = table.max_calls

    def too_deep() -> LimitError:
        return LimitError(f"function '{name}': calls nested more than {MAX_CALL_DEPTH} deep (a recursion "
                          "that does not end?)", span, code="limit-recursion",
                          hint="make the recursion stop: guard the recursive call with select(...)")

    def call(env: Any) -> Any:
        vals = [a(env) for a in args]
        if type(env) is _Frame:
            depth = env.depth + 1
            if depth > MAX_CALL_DEPTH:
                raise too_deep()
            calls = env.calls
            calls[0] += 1
            if calls[0] > max_calls:
                raise LimitError(f"function '{name}': more than {max_calls:,} calls in one evaluation",
                                 span, code="limit-calls")
            return body.fn(_Frame(env.env, vals, depth, calls))  # type: ignore[misc]
        _ensure_stack()
        try:
            return body.fn(_Frame(env, vals, 1, [1]))  # type: ignore[misc]
        except RecursionError:
            raise too_deep() from None
    return call


def compile_expr(expr: Any, resolve: Resolver, functions: Mapping[str, Any], *,
                 user: FunctionTable | None = None) -> Compiled:
    """Compile an IR expression into `f(env)`.

    `resolve(name, span)` returns a compiled closure for a reference (or None: unknown name,
    reported as a GrammarError at the reference). `functions` maps names to FunctionSpecs
    (`registries.functions`). `rand` draws from `env.rng()`. Errors of constant
    subexpressions are deferred to run time. `user`: the grammar's user functions.
    """
    if functions is None:
        raise TypeError("compile_expr: functions= is required (e.g. registries.functions)")
    return _Compiler(resolve, functions, user=user if user else None).compile(expr)


def fold_constant(expr: Any, lookup: Callable[[str], Any], functions: Mapping[str, Any],
                  errors: list[DerivationError] | None = None, *, user: FunctionTable | None = None) -> Any:
    """The checker's constant-folding mode: the value of `expr` if every name in it is a
    known constant (`lookup(name)` returns its value, or NOT_CONSTANT), else NOT_CONSTANT.

    Errors of constant subexpressions (`1 / 0`, `9 ^ 9 ^ 9`, `"x" * 600000000`) are appended
    to `errors` as the DerivationErrors the engines would raise. Unknown names and functions
    make the expression non-constant (the checker reports them on its own).

    This walks the tree instead of compiling closures (the checker folds every expression of a
    file once), with the very operator and call implementations `compile_expr` uses, and folds
    exactly what `compile_expr` folds.

    A call of a user function with constant arguments is evaluated when `user` (made by
    `folding_table`) is given: at most FOLD_MAX_CALLS calls, and only while the body reads
    nothing but its parameters and constants (else it is NOT_CONSTANT)."""
    collected: list[DerivationError] = [] if errors is None else errors
    return _Folder(lookup, functions, collected, user if user else None).fold(expr)


class _NotConstantSignal(Exception):
    """Raised by a folded function body that reads a non-constant value (or draws a number)."""


def _raise_not_constant(env: Any) -> Any:
    raise _NotConstantSignal()


class _FoldEnv:
    def rng(self) -> Any:
        raise _NotConstantSignal()


_FOLD_ENV = _FoldEnv()


def folding_table(functions: Iterable[Any], lookup: Callable[[str], Any],
                  builtins: Mapping[str, Any]) -> FunctionTable:
    """User functions for `fold_constant(..., user=)`: a body name whose `lookup(name)` is
    NOT_CONSTANT makes the call non-constant."""
    def resolve(name: str, span: Span | None) -> Compiled:
        v = lookup(name)
        return _raise_not_constant if v is NOT_CONSTANT else constant(v)
    return FunctionTable(functions, resolve, builtins, max_calls=FOLD_MAX_CALLS)


class _Folder:
    __slots__ = ("lookup", "functions", "errors", "user")

    def __init__(self, lookup: Callable[[str], Any], functions: Mapping[str, Any],
                 errors: list[DerivationError], user: FunctionTable | None = None):
        self.lookup, self.functions, self.errors, self.user = lookup, functions, errors, user

    def _user(self, e: Call) -> Any:
        user = self.user
        args = [self.fold(a) for a in e.args]
        if user.arity_problem(e.func, len(args)) is not None or any(a is NOT_CONSTANT for a in args):
            return NOT_CONSTANT
        try:
            body = user.body(e.func, len(args))
            return _user_call(user, body, [constant(a) for a in args], e.span)(_FOLD_ENV)
        except _NotConstantSignal:
            return NOT_CONSTANT
        except DerivationError as exc:
            if exc.diagnostics[0].code != "limit-calls":  # too long to fold: derive decides
                self.errors.append(exc)
            return NOT_CONSTANT
        except GrammarError:  # a body the checker reports on its own (unknown name, ...)
            return NOT_CONSTANT

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
            if self.user is not None and e.func in self.user.overloads:
                return self._user(e)
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
             seed: int = 0, names: Callable[[str], Any] | None = None,
             user_functions: Iterable[Any] = ()) -> Any:
    """Evaluate one expression with plain variables (dotted names included as keys).

    `names(name)` gives a value for a name that is not a variable (e.g. a tiling grammar's
    bare part-type names), or None: unknown. `user_functions`: `func` statements
    (`grammarkit.ir.Function`, e.g. `grammar.functions`) the expression may call; their bodies
    see the same variables. Engines should `compile_expr` once instead.
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
    user = FunctionTable(user_functions, resolve, functions) if user_functions else None
    return compile_expr(expr, resolve, functions, user=user)(env)
