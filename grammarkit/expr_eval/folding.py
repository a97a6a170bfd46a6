"""The checker's constant folding: the value of an expression whose inputs are all known
constants, or `NOT_CONSTANT`, with the errors the engines would raise. It walks the tree (the
checker folds each expression of a file once) with the operators and calls the compiler uses,
and folds exactly what the compiler folds.
"""
from __future__ import annotations

from typing import Any, Callable, Iterable, Mapping

from ..errors import DerivationError, GrammarError
from ..ir.base import Span
from ..ir.expr import Binary, Bool, Call, Num, Ref, Str, Unary, Vector
from .compiler import FunctionTable, _user_call
from .values import (
    _BINARY, FOLD_MAX_CALLS, NOT_CONSTANT, Compiled, _call, _negate, arity_problem, constant,
)

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
        assert user is not None  # called only for the calls of a table's functions
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

