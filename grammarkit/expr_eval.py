"""Evaluating IR expressions: compile once into Python closures, call many times.

The split engine evaluates the same expressions thousands of times per building, so an
expression is compiled once per grammar into a closure `f(env)` (no tree walking, no
pydantic access in the hot loop). Names are resolved at compile time by a `resolve(name)`
callback that returns a closure or None; this keeps the evaluator free of any knowledge of
shapes, rules or geometry. The environment `env` is whatever the caller passes at run time;
resolvers decide which of its attributes they read (the split engine passes a shape with
`.sz`, `.params`, `.split_index`, ... and `.rng()`).

Runtime problems (division by zero, a function that rejects its arguments, a type error
such as `"a" * 2`) raise `DerivationError` carrying the expression's source span.
"""
from __future__ import annotations

import math
import operator
import random
from typing import Any, Callable, Mapping

from .errors import DerivationError, GrammarError
from .ir.base import Span
from .ir.expr import Binary, Bool, Call, Num, Ref, Str, Unary, Vector

Compiled = Callable[[Any], Any]
Resolver = Callable[[str, Span | None], "Compiled | None"]

__all__ = ["Compiled", "compile_expr", "evaluate", "is_constant", "SimpleEnv"]


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


def _where(span: Span | None) -> str:
    return f" at {span}" if span is not None and span.line else ""


def _fail(message: str, span: Span | None) -> DerivationError:
    return DerivationError(message, span)


def _truthy(v: Any) -> bool:
    return bool(v)


def _pow(a: Any, b: Any) -> Any:
    """`a ^ b` as a real number. Integer powers are exact only while they stay small: Python
    would otherwise compute `9 ^ 9 ^ 9` as an integer of 370 million digits (minutes, GBs),
    so large ones go through floats, which overflow to a clear error instead."""
    if type(a) is int and type(b) is int and (b < 0 or b * max(abs(a).bit_length(), 1) > 256):
        a = float(a)
    r = a ** b
    if isinstance(r, complex):
        raise ValueError(f"{a!r} ^ {b!r} is not a real number")
    return r


_ARITH: dict[str, Callable[[Any, Any], Any]] = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "^": _pow,
    "==": operator.eq, "!=": operator.ne, "<": operator.lt, "<=": operator.le,
    ">": operator.gt, ">=": operator.ge,
}


def is_constant(f: Compiled) -> bool:
    return getattr(f, "_const", False)


def _const(value: Any) -> Compiled:
    def f(env: Any, _v=value) -> Any:
        return _v
    f._const = True  # type: ignore[attr-defined]
    f._value = value  # type: ignore[attr-defined]
    return f


def compile_expr(expr: Any, resolve: Resolver, functions: Mapping[str, Any] | None = None) -> Compiled:
    """Compile an IR expression into `f(env)`.

    `resolve(name, span)` returns a compiled closure for a reference (or None: unknown name,
    reported as a GrammarError at the reference). `functions` maps names to FunctionSpecs
    (default: the plugin manager's registry). `rand` draws from `env.rng()`.
    """
    if functions is None:
        from .plugins import get_plugin_manager
        functions = get_plugin_manager().functions()
    return _compile(expr, resolve, functions)


def _compile(e: Any, resolve: Resolver, functions: Mapping[str, Any]) -> Compiled:
    span = e.span
    if isinstance(e, Num):
        v = e.value
        return _const(int(v) if float(v).is_integer() and abs(v) < 2 ** 53 else v)
    if isinstance(e, (Str, Bool)):
        return _const(e.value)
    if isinstance(e, Ref):
        f = resolve(e.name, span)
        if f is None:
            raise GrammarError(f"unknown name {e.name!r}", span, code="unknown-name")
        return f
    if isinstance(e, Vector):
        items = [_compile(i, resolve, functions) for i in e.items]
        if all(is_constant(i) for i in items):
            return _const(tuple(i._value for i in items))  # type: ignore[attr-defined]
        return lambda env: tuple(i(env) for i in items)
    if isinstance(e, Unary):
        a = _compile(e.operand, resolve, functions)
        if e.op == "!":
            g = lambda env: not a(env)  # noqa: E731
        elif e.op == "-":
            def g(env: Any) -> Any:
                try:
                    return -a(env)
                except TypeError as exc:
                    raise _fail(f"cannot negate: {exc}", span) from None
        else:
            g = a
        return _fold(g) if is_constant(a) else g
    if isinstance(e, Binary):
        return _compile_binary(e, resolve, functions)
    if isinstance(e, Call):
        return _compile_call(e, resolve, functions)
    raise GrammarError(f"not an expression: {type(e).__name__}", span)


def _fold(f: Compiled) -> Compiled:
    """Evaluate a closure whose inputs are all constant once, now."""
    return _const(f(None))


def _compile_binary(e: Binary, resolve: Resolver, functions: Mapping[str, Any]) -> Compiled:
    a = _compile(e.left, resolve, functions)
    b = _compile(e.right, resolve, functions)
    op, span = e.op, e.span
    if op == "&&":
        g = lambda env: a(env) and b(env)  # noqa: E731
    elif op == "||":
        g = lambda env: a(env) or b(env)  # noqa: E731
    elif op == "/":
        def g(env: Any) -> Any:
            y = b(env)
            if y == 0:
                raise _fail("division by zero", span)
            try:
                return a(env) / y
            except TypeError as exc:
                raise _fail(f"bad operands for '/': {exc}", span) from None
    elif op == "%":
        def g(env: Any) -> Any:
            y = b(env)
            if y == 0:
                raise _fail("modulo by zero", span)
            try:
                return math.fmod(a(env), y)
            except TypeError as exc:
                raise _fail(f"bad operands for '%': {exc}", span) from None
    else:
        fn = _ARITH[op]

        def g(env: Any) -> Any:
            try:
                return fn(a(env), b(env))
            except (TypeError, OverflowError, ZeroDivisionError, ValueError) as exc:
                raise _fail(f"bad operands for {op!r}: {exc}", span) from None
    if is_constant(a) and is_constant(b):
        try:
            return _fold(g)
        except DerivationError:
            return g  # report at run time, with the derivation's context
    return g


def _compile_call(e: Call, resolve: Resolver, functions: Mapping[str, Any]) -> Compiled:
    span = e.span
    spec = functions.get(e.func)
    if spec is None:
        known = ", ".join(sorted(functions))
        raise GrammarError(f"unknown function {e.func!r}", span, hint=f"known functions: {known}",
                           code="unknown-function")
    n = len(e.args)
    if n < spec.min_args or (spec.max_args is not None and n > spec.max_args):
        most = "any number of" if spec.max_args is None else str(spec.max_args)
        raise GrammarError(f"{e.func}() takes {spec.min_args} to {most} arguments, got {n}", span,
                           code="bad-arity")
    args = [_compile(x, resolve, functions) for x in e.args]
    if e.func == "rand":
        from .functions import RANDOM_FUNCTIONS
        impl = RANDOM_FUNCTIONS["rand"]

        def rand(env: Any) -> Any:
            vals = [x(env) for x in args]
            if len(vals) == 1:
                vals = [0.0, vals[0]]
            return impl(env.rng(), *vals)
        return rand
    impl = spec.impl
    if impl is None:
        raise GrammarError(f"function {e.func!r} has no implementation (plugin {spec.plugin!r})", span)
    name = e.func

    def call(env: Any) -> Any:
        vals = [x(env) for x in args]
        try:
            return impl(*vals)
        except (ValueError, TypeError, ZeroDivisionError, OverflowError) as exc:
            raise _fail(f"{name}(): {exc}", span) from None
    if all(is_constant(x) for x in args):
        try:
            return _fold(call)
        except DerivationError:
            return call
    return call


def evaluate(expr: Any, variables: Mapping[str, Any] | None = None, *, seed: int = 0,
             functions: Mapping[str, Any] | None = None) -> Any:
    """Evaluate one expression with plain variables (dotted names included as keys).

    Convenience for tools and tests; engines should `compile_expr` once instead.
    """
    env = SimpleEnv(variables, seed)

    def resolve(name: str, span: Span | None) -> Compiled | None:
        if name in env.variables:
            return lambda en, _n=name: en.variables[_n]
        return None
    return compile_expr(expr, resolve, functions)(env)
