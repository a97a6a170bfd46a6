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


The package, one concern a module: `values` (limits, operators, constants), `compiler`
(`compile_expr`, user functions, `evaluate`), `folding` (`fold_constant`). This module is the
public import path.
"""
from __future__ import annotations

from .compiler import FunctionTable, compile_expr, evaluate
from .folding import fold_constant, folding_table
from .values import (
    FOLD_MAX_CALLS, MAX_CALL_DEPTH, MAX_CALLS, MAX_INT_BITS, MAX_STRING_LENGTH, NOT_CONSTANT,
    Compiled, Resolver, SimpleEnv, arity_problem, constant, is_constant, value_kind,
)

__all__ = ["FOLD_MAX_CALLS", "MAX_CALLS", "MAX_CALL_DEPTH", "MAX_INT_BITS", "MAX_STRING_LENGTH",
           "NOT_CONSTANT", "Compiled", "FunctionTable", "Resolver", "SimpleEnv", "arity_problem",
           "compile_expr", "constant", "evaluate", "fold_constant", "folding_table", "is_constant",
           "value_kind"]
