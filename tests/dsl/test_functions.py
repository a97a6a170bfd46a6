"""User functions `func f(a, b) = expr`: parsing, printing, checking, evaluation and deriving.

Overloads by arity, direct and mutual recursion ended by the lazy `select`, parameters that
hide attrs, the depth and call-count guards (located LimitErrors, never a RecursionError),
located checker errors, and the same values through `grammarkit.derive`, `evaluate` and the
checker's constant folding.
"""
from __future__ import annotations

import subprocess
import sys

import pytest

import grammarkit
from grammarkit.dsl import check, load, parse
from grammarkit.errors import GrammarError, LimitError
from grammarkit.expr_eval import MAX_CALL_DEPTH, evaluate
from grammarkit.ir import Function
from grammarkit.plugins import default_registries
from grammarkit.printer import print_grammar

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]

LIB = """grammar lib
func fact(n) = select(n <= 1, 1, n * fact(n - 1))
func fib(n) = select(n < 2, n, fib(n - 1) + fib(n - 2))
func even(n) = select(n == 0, true, odd(n - 1))
func odd(n) = select(n == 0, false, even(n - 1))
func area() = 6
func area(w) = w * w
func area(w, d) = w * d
func shadow(k) = k + 1
func withk(x) = x + k
func safe(n) = select(n == 0, 0, 1 / n)
func count_down(n) = select(n <= 0, 0, 1 + count_down(n - 1))
func forever(n) = forever(n + 1)
attr k = 100
"""


def ev(text: str, **variables):
    g = parse(LIB)
    expr = parse(f"const x = {text}").consts[0].value
    return evaluate(expr, {"k": 100, **variables}, functions=default_registries().functions,
                    user_functions=g.functions)


@pytest.mark.parametrize("text, value", [
    ("fact(5)", 120), ("fact(10)", 3628800), ("fib(10)", 55), ("fib(20)", 6765),
    ("even(10)", True), ("odd(7)", True), ("even(7)", False),
    ("area()", 6), ("area(3)", 9), ("area(3, 4)", 12),
    ("shadow(1)", 2),          # the parameter k hides the attr k
    ("withk(1)", 101),         # other names are the grammar's
    ("safe(0)", 0),            # select is lazy: 1 / 0 is never evaluated
    ("count_down(400)", 400),
])
def test_values(text, value):
    assert ev(text) == value


def test_the_depth_guard_is_a_located_limit_error():
    with pytest.raises(LimitError) as e:
        ev("forever(1)")
    d = e.value.diagnostics[0]
    assert d.code == "limit-recursion" and "'forever'" in d.message
    assert (d.span.line, d.span.column) == (13, 19)  # the recursive call in the body
    with pytest.raises(LimitError):
        ev(f"count_down({MAX_CALL_DEPTH})")  # MAX_CALL_DEPTH - 1 levels are fine, one more is not
    assert ev(f"count_down({MAX_CALL_DEPTH - 1})") == MAX_CALL_DEPTH - 1


def test_a_body_nested_deeply_per_call_gives_the_same_error_not_a_recursion_error():
    deep = "+".join(["(1"] * 40) + ")" * 40
    g = parse(f"func d(n) = select(n <= 0, 0, {deep} + d(n - 1))")
    expr = parse("const x = d(100000)").consts[0].value
    with pytest.raises(LimitError) as e:
        evaluate(expr, {}, functions=default_registries().functions, user_functions=g.functions)
    assert e.value.diagnostics[0].code == "limit-recursion"


def test_the_call_count_guard():
    with pytest.raises(LimitError) as e:
        ev("fib(40)")  # 331 million calls
    assert e.value.diagnostics[0].code == "limit-calls"
    assert "'fib'" in e.value.diagnostics[0].message


def test_print_parse_round_trip():
    g = parse(LIB)
    text = print_grammar(g)
    assert "func area(w, d) = w * d" in text
    assert "func fib(n) = select(n < 2, n, fib(n - 1) + fib(n - 2))" in text
    assert parse(text) == g
    assert len(g.functions) == 12 and all(isinstance(f, Function) for f in g.functions)
    assert [len(f.params) for f in g.functions if f.name == "area"] == [0, 1, 2]


def test_func_is_a_reserved_word():
    with pytest.raises(GrammarError) as e:
        parse("attr func = 1")
    assert e.value.diagnostics[0].code == "reserved-word"


DERIVE = """grammar recursion
attr floors = 4
attr floor_h = 3
func fib(n) = select(n < 2, n, fib(n - 1) + fib(n - 2))
func stack(i) = select(i <= 0, 0, floor_h + stack(i - 1))
func stack(i, h) = select(i <= 0, 0, h + stack(i - 1, h))
func half() = scope.sx / 2
const tall = stack(floors)
Lot --> extrude(stack(fib(5) - 2, 2)) Mass
Mass --> s(half(), scope.sy, tall) Box.
"""


def test_recursive_functions_in_a_derivation():
    g = load(DERIVE)
    m = grammarkit.derive(g, seed=0, lot=LOT)
    lo, hi = m.mesh.bounds
    size = hi - lo
    # x: half of the 20 m lot; z: stack(4) = 4 floors of 3 m (the extrusion was 3 * 2 = 6 m)
    assert size[0] == pytest.approx(10, abs=0.01)
    assert size[2] == pytest.approx(12, abs=0.01)
    # the attrs a body reads are the derivation's, overrides included
    m2 = grammarkit.derive(g, seed=0, lot=LOT, attrs={"floors": 2, "floor_h": 5})
    lo, hi = m2.mesh.bounds
    assert (hi - lo)[2] == pytest.approx(10, abs=0.01)


def test_random_values_in_a_function_are_deterministic():
    g = load("""grammar r
func jitter(n) = select(n <= 0, 0, rand(0, 1) + jitter(n - 1))
Lot --> extrude(1 + jitter(5)) Mass.
""")
    heights = [float(grammarkit.derive(g, seed=s, lot=LOT).mesh.bounds[1][2]) for s in (1, 1, 2)]
    assert heights[0] == heights[1] and heights[0] != heights[2]
    assert 1 <= heights[0] <= 6


def test_runaway_recursion_in_a_derivation_is_a_located_error():
    text = """grammar r
func grow(n) = grow(n + 1) + 1
Lot --> extrude(grow(1)) Mass.
"""
    with pytest.raises(GrammarError) as e:  # with a constant argument `check` finds it already
        load(text)
    assert e.value.diagnostics[0].code == "limit-recursion"
    g = load(text.replace("grow(1))", "grow(scope.sx))"))  # depends on the shape: found by deriving
    with pytest.raises(LimitError) as e:
        grammarkit.derive(g, seed=0, lot=LOT)
    d = e.value.diagnostics[0]
    assert d.code == "limit-recursion" and (d.span.line, d.span.column) == (2, 16)


def codes(text):
    return [(d.severity, d.code, d.span.line, d.span.column, d.message, d.hint) for d in check(text)]


def test_checker_errors_are_located():
    text = """grammar bad
func f(a) = a
func f(a, b) = a + b
func f(x) = x
func g(a, a) = a
func h(n) = nope(n) + q
Lot --> extrude(f(1, 2, 3)) Mass
Mass --> extrude(f(1) + f(1, 2) + h(1)) Box.
"""
    found = codes(text)
    dup = [x for x in found if x[1] == "duplicate"]
    assert dup[0][2:4] == (4, 1) and "function 'f' with 1 parameter is defined twice" in dup[0][4]
    assert "(first at <string>:2:1)" in dup[0][4]
    assert dup[1][2:4] == (5, 1) and "parameter 'a' of function 'g'" in dup[1][4]
    arity = [x for x in found if x[1] == "function-arity"]
    assert len(arity) == 1 and arity[0][2:4] == (7, 17)
    assert arity[0][4] == "function 'f' takes 1 or 2 argument(s), got 3"
    assert arity[0][5] == "defined: f(a) at <string>:2:1; f(a, b) at <string>:3:1"
    unknown = [x for x in found if x[1] == "unknown-function"]
    assert [(x[2], x[3]) for x in unknown] == [(6, 13)]
    undefined = [x for x in found if x[1] == "undefined-name"]
    assert [(x[2], x[3]) for x in undefined] == [(6, 23)]  # q: a body sees params, attrs, consts


def test_checker_folds_constant_calls_and_reports_what_deriving_would():
    found = codes("""grammar c
func inv(x) = 1 / (x - 3)
func loop(n) = loop(n + 1)
const a = inv(3)
const b = loop(0)
const ok = inv(4)
Lot --> extrude(ok) Mass.
""")
    errors = [(x[1], x[2], x[3]) for x in found if x[0] == "error"]
    assert ("division-by-zero", 2, 15) in errors
    assert ("limit-recursion", 3, 16) in errors


def test_a_value_cycle_through_a_function_is_reported():
    found = codes("""grammar c
const a = twice(1)
func twice(x) = 2 * x * b
const b = a + 1
Lot --> extrude(a) Mass.
""")
    assert any(x[1] == "cycle" and "a -> b -> a" in x[4] for x in found)


def test_shadowing_a_built_in_function_is_a_warning_and_the_user_function_wins():
    text = """grammar s
func min(a, b) = a + b
Lot --> extrude(min(1, 2)) Mass.
"""
    warnings = [x for x in codes(text) if x[0] == "warning"]
    assert [(x[1], x[2]) for x in warnings] == [("shadows-function", 2)]
    m = grammarkit.derive(load(text), seed=0, lot=LOT)
    assert float(m.mesh.bounds[1][2]) == pytest.approx(3, abs=0.01)


def test_tiling_grammars_reject_functions_with_a_located_error():
    found = codes("""grammar t
func w(n) = 2 * n
part Block = box(w(1), 1, 1)
""")
    bad = [x for x in found if x[1] == "func-in-tiling"]
    assert [(x[2], x[3]) for x in bad] == [(2, 1)]


def test_cli_check_reports_file_line_column(tmp_path):
    f = tmp_path / "f.grammar"
    f.write_text("func f(a) = a\nLot --> extrude(f()) Mass.\n")
    r = subprocess.run([sys.executable, "-m", "grammarkit", "check", str(f)], capture_output=True, text=True)
    assert r.returncode != 0
    assert f"{f}:2:17: error: function 'f' takes 1 argument(s), got 0" in r.stdout + r.stderr
    assert "Traceback" not in r.stdout + r.stderr
