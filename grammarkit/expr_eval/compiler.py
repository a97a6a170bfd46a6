"""The compiler: an IR expression becomes a closure `f(env)`, compiled once and evaluated many
times (no tree walking, no pydantic access in the hot loop); constant subexpressions are folded
at compile time. User functions (`FunctionTable`) are compiled here too: their calls nest
compiled bodies on call frames.
"""
from __future__ import annotations

import random
import sys
from typing import Any, Callable, Iterable, Mapping

from ..errors import DerivationError, GrammarError, LimitError
from ..ir.base import Span
from ..ir.expr import Binary, Bool, Call, Num, Ref, Str, Unary, Vector
from .values import (
    _BINARY, MAX_CALL_DEPTH, MAX_CALLS, _STACK_FRAMES, Compiled, Resolver, SimpleEnv, _call, _fail,
    _negate, _not_constant, arity_problem, constant, is_constant, value_kind,
)

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
                # constants carry their value as a function attribute (values.constant)
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
        else:  # unary plus: the operand itself
            return self.fold(a) if is_constant(a) else a
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
            from ..functions import RANDOM_FUNCTIONS
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
        from ..functions import FILE_FUNCTIONS
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

    from ..functions import TooManyFiles, file_exists, file_random, search_files

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

                def parameter(fr: Any, _i: int = i) -> Any:
                    return fr.args[_i]
                return parameter
            g = outer(ref, span)
            if g is None or is_constant(g):
                return g

            def caller_name(fr: Any, _g: Compiled = g) -> Any:
                return _g(fr.env)
            return caller_name
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
            # fn is set once the body is compiled, before any call of it runs (FunctionTable.body)
            return body.fn(_Frame(env.env, vals, depth, calls))  # type: ignore[misc]
        _ensure_stack()
        try:
            return body.fn(_Frame(env, vals, 1, [1]))  # type: ignore[misc]  # set, as above
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
            def variable(en: Any, _n: str = name) -> Any:
                return en.variables[_n]
            return variable
        if names is not None:
            value = names(name)
            if value is not None:
                return constant(value)
        return None
    user = FunctionTable(user_functions, resolve, functions) if user_functions else None
    return compile_expr(expr, resolve, functions, user=user)(env)
