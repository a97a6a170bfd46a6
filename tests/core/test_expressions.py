"""One expression evaluator: the same expression means the same thing in a split grammar, a
tiling grammar and `grammarkit check` (issue 8). Each case runs through all three."""
from __future__ import annotations

import math
import time

import pytest

from grammarkit.dsl import check, load, parse
from grammarkit.errors import GrammarError, GrammarkitError, LimitError
from grammarkit.expr_eval import MAX_STRING_LENGTH, NOT_CONSTANT, evaluate, fold_constant
from grammarkit.functions import BUILTIN_FUNCTIONS
from grammarkit.split import derive
from grammarkit.tiling import rules_from_grammar

FUNCTIONS = {f.name: f for f in BUILTIN_FUNCTIONS}
LOT = "Lot --> footprint(rect(1, 1)) extrude(1) X.\n"


def split_value(expr: str):
    """The value of an attr in a derived split model (evaluated by the engine's value env)."""
    return derive(f"attr v = {expr}\n" + LOT).attrs["v"]


def split_param_value(expr: str, arg: str):
    """The value computed at derive time from a rule parameter (not folded at compile time):
    the model's height is the expression's value, with `n` = arg."""
    m = derive(f"Lot --> A({arg})\nA(n) --> footprint(rect(1, 1)) extrude({expr}) X.\n")
    return m.parts[0].size[2]


def tiling_value(expr: str):
    """The value in a tiling grammar's compiled rules (a dock placement's x)."""
    g = parse(f"const v = {expr}\npart A = box(1, 1, 1)\npart B = box(1, 1, 1)\n"
              "dock A -- B { at (v, 0, 0) }\n")
    return rules_from_grammar(g).docks[("A", "B")][0].at[0]


def check_value_is(expr: str, value) -> bool:
    """Whether `check` folds the expression to `value` (an @enum listing only that value)."""
    diags = check(f"attr v = {expr} @enum({value!r})\n" + LOT)
    errors = [d for d in diags if d.severity == "error"]
    assert all(d.code == "not-in-enum" for d in errors), [d.format() for d in errors]
    return not errors


@pytest.mark.parametrize("expr, value", [
    ("-7 % 3", -1.0), ("7 % -3", 1.0), ("-7.5 % 2", -1.5), ("7 % 3", 1.0),
    ("2 ^ 10", 1024), ("2 ^ 3 ^ 2", 512), ("-2 ^ 2", -4), ("2 ^ -1", 0.5), ("7 / 2", 3.5),
    ("10 - 4 - 3", 3),
])
def test_arithmetic_is_the_same_everywhere(expr, value):
    assert split_value(expr) == value
    assert tiling_value(expr) == pytest.approx(float(value))
    assert check_value_is(expr, value)
    assert evaluate(parse(f"const v = {expr}").consts[0].value, functions=FUNCTIONS) == value


def test_modulo_follows_the_dividend_at_derive_time_too():
    # -7 % 3 == -1 (C, Java, CGA): a height of -1 + 3 = 2
    assert split_param_value("n % 3 + 3", "-7") == pytest.approx(2.0, abs=1e-6)


ERRORS = [
    ("1 / 0", "division by zero", "division-by-zero"),
    ("5 % 0", "modulo by zero", "division-by-zero"),
    ("9 ^ 9 ^ 9", "number too large", "number-too-large"),
    ("(-8) ^ 0.5", "not a real number", "not-real"),
    ('"x" * 600000000', "string limit exceeded", "limit-string"),
    ('"x" * 1e10', "string limit exceeded", "limit-string"),
    ("floor(1e308) * 16", "number too large", "number-too-large"),
]


@pytest.mark.parametrize("expr, words, code", ERRORS)
def test_errors_are_the_same_everywhere_and_located(expr, words, code):
    text = f"attr a = 1\nconst v = {expr}\n" + LOT
    col = text.splitlines()[1].index(expr.split()[0]) + 1
    t0 = time.perf_counter()
    # check: an error at the expression
    errors = [d for d in check(text) if d.severity == "error"]
    assert len(errors) == 1 and words in errors[0].message and errors[0].code == code, errors
    assert errors[0].span.line == 2 and errors[0].span.column >= col
    # a split grammar: deriving the text fails at load with the same diagnostic
    with pytest.raises(GrammarError) as info:
        derive(text)
    assert words in str(info.value) and info.value.diagnostics[0].code == code
    # a tiling grammar: the same message, code and place
    g = parse(f"attr a = 1\nconst v = {expr}\npart A = box(1, 1, 1)\npart B = box(1, 1, 1)\n"
              "dock A -- B { at (v, 0, 0) }\n")
    with pytest.raises(GrammarError) as info:
        rules_from_grammar(g)
    d = info.value.diagnostics[0]
    assert words in d.message and d.code == code and d.span.line == 2
    assert time.perf_counter() - t0 < 5  # 9 ^ 9 ^ 9 and "x" * 6e8 fail at once, never hang


@pytest.mark.parametrize("expr, words, code", ERRORS)
def test_errors_at_derive_time_are_located_derivation_errors(expr, words, code):
    # the same operations on a rule parameter are only known while deriving
    first, rest = expr.split(" ", 1)
    text = f"Lot --> A({first})\nA(n) --> footprint(rect(1, 1)) extrude(1) material(n {rest}) X.\n"
    if code == "limit-string":
        exc = LimitError
    else:
        exc = GrammarkitError
    t0 = time.perf_counter()
    with pytest.raises(exc) as info:
        derive(text)
    assert time.perf_counter() - t0 < 5
    assert words in str(info.value) and info.value.diagnostics[0].code == code
    assert info.value.span is not None and info.value.span.line == 2


def test_big_integer_remainder_is_exact_not_an_overflow():
    # floor(1e308) is an integer of 1024 bits: its remainder is computed exactly
    expected = float(math.floor(1e308) % 7)
    assert split_value("floor(1e308) % 7") == expected
    assert tiling_value("floor(1e308) % 7") == expected
    assert check_value_is("floor(1e308) % 7", expected)
    assert split_value("2 ^ 200 * 2 ^ 200 % 3") == float((2 ** 400) % 3)


def test_string_results_are_limited_but_ordinary_strings_work():
    m = derive('attr name = "brick"\nLot --> footprint(rect(1, 1)) extrude(1) material(name + "_" + "red") X.\n')
    assert m.parts[0].material == "brick_red"
    ok = "x" * (MAX_STRING_LENGTH // 2)
    with pytest.raises(LimitError):
        evaluate(parse(f'const v = "{ok}" + "{ok}x"').consts[0].value, functions=FUNCTIONS)


def test_folding_mode_reports_errors_and_non_constants():
    e = parse("const v = 2 * (1 / 0) + x").consts[0].value
    errors: list = []
    assert fold_constant(e, lambda n: NOT_CONSTANT, FUNCTIONS, errors) is NOT_CONSTANT
    assert [x.diagnostics[0].code for x in errors] == ["division-by-zero"]
    e = parse("const v = max(a, 3) * 2").consts[0].value
    assert fold_constant(e, {"a": 5}.get, FUNCTIONS) == 10
    assert fold_constant(parse("const v = rand(1, 2)").consts[0].value, {}.get, FUNCTIONS) is NOT_CONSTANT


def test_check_warns_when_only_an_attr_default_makes_an_expression_fail():
    # `--set d=2` would make this work: a warning, not an error
    diags = check("attr d = 0\nLot --> footprint(rect(1, 1)) extrude(1 / d) X.\n")
    assert [(d.severity, d.code) for d in diags] == [("warning", "division-by-zero")]
    assert "default value of d" in diags[0].message
    m = derive("attr d = 0\nLot --> footprint(rect(1, 1)) extrude(1 / d) X.\n", attrs={"d": 2})
    assert m.parts[0].size[2] == pytest.approx(0.5)


def test_compile_expr_needs_the_functions_explicitly():
    from grammarkit.expr_eval import compile_expr

    e = parse("const v = 1").consts[0].value
    with pytest.raises(TypeError, match="functions"):
        compile_expr(e, lambda name, span: None, None)  # type: ignore[arg-type]  # the missing functions= is the point


def test_load_of_a_good_grammar_is_unaffected():
    g = load("attr w = 3 % 2\n" + LOT)
    assert g.attrs[0].name == "w"
