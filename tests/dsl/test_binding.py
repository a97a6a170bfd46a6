"""One argument binder for `check` and the compiler (issue 8): what fails at derive because of
how the text is written is caught by `check` first, with the same code and place."""
from __future__ import annotations

import pytest

from grammarkit.dsl import check, parse
from grammarkit.errors import GrammarError
from grammarkit.split import compile as compile_split

# text, code: each must be refused by `check` AND by the compiler (given the parsed IR
# directly, without going through check), with the same code at the same place
CASES = [
    ("Lot --> footprint(rect(4, 4)) extrude(3) split(x) { 1: A. | ~1: B. } X.", "item-after-block"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) comp(f) { top: A. } extrude(1)", "item-after-block"),
    ("Lot --> footprint(rect(4, 4)) extrude(3, spin=2) X.", "unknown-argument"),
    ("Lot --> footprint(rect(4, 4)) extrude(3, 4) X.", "operation-arity"),
    ("Lot --> footprint(rect(4, 4)) extrude() X.", "operation-arity"),
    ("Lot --> footprint(rect(4, 4)) extrude(3, height=2) X.", "bad-argument"),
    ('Lot --> footprint(rect(4, 4)) extrude(3) color("#zzz") X.', "bad-argument-value"),
    ('Lot --> footprint(rect(4, 4)) extrude(3) color("#12") X.', "bad-argument-value"),
    ("Lot --> footprint(rect(4, 4)) split(w) { 1: A. }", "bad-argument-type"),
    ('Lot --> footprint(rect(4, 4)) extrude("tall") X.', "bad-argument-type"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) { 1: A. }", "block-kind"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) split(x)", "block-kind"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) comp(f) { topp: A. }", "unknown-selector"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) comp(f) { { top: A. }* }", "block-kind"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) (A)*\nA --> NIL", "pattern-without-repeat"),
    ("Lot --> footprint(rect(4, 4)) extrude(3) repeat(x, 1) X.", "repeat-without-pattern"),
    ('Lot --> footprint(rect(4, 4)) extrude(3) i("a.glb", fit=squeeze) X.', "bad-argument-value"),
    ("Lot --> B(1, 2)\nB(i) --> NIL", "successor-arity"),
    ("Lot --> footprint(rect(4, 4)) extrdue(3) X.", "unknown-operation"),
]


@pytest.mark.parametrize("text, code", CASES)
def test_check_catches_what_the_compiler_refuses_with_the_same_code(text, code):
    text += "\n"
    found = [d for d in check(text, filename="t.grammar") if d.severity == "error"]
    assert found and found[0].code == code, [(d.code, d.message) for d in found]
    with pytest.raises(GrammarError) as info:
        compile_split(parse(text, filename="t.grammar"))
    d = info.value.diagnostics[0]
    assert d.code == code, d.format()
    assert (d.span.line, d.span.column) == (found[0].span.line, found[0].span.column)
    assert d.message == found[0].message


def test_messages_say_what_and_where():
    d = [x for x in check("Lot --> split(x) { 1: A. } X.\n") if x.severity == "error"][0]
    assert d.message == "nothing may follow split(...) { ... }: its block consumes the shape"
    assert d.span.column == 28  # at the item that follows
    d = [x for x in check('Lot --> color("#zzz") X.\n') if x.severity == "error"][0]
    assert "must be a colour '#rrggbb' or '#rgb', got '#zzz'" in d.message
    d = [x for x in check('Lot --> extrude(1) i("a.glb", fit=squeeze) X.\n') if x.severity == "error"][0]
    assert d.message == "unknown fit 'squeeze' (argument 'fit' of i)" and "scale" in d.hint


def test_constant_arguments_are_checked_by_value():
    # the checker folds constants with the engines' evaluator: a colour held by an attr, a
    # string attr where a number belongs
    codes = [d.code for d in check('const c = "#12345g"\nLot --> extrude(1) color(c) X.\n')]
    assert codes == ["bad-argument-value"]
    # an attr's default may be a placeholder that a guard keeps away (`--set` gives the colour)
    assert not check('attr c = ""\nLot --> footprint(rect(1, 1)) extrude(1) A\n'
                     'A --> case c != "": color(c) X. else: Y.\n')
    codes = [d.code for d in check('attr s = "tall"\nLot --> extrude(s) X.\n')]
    assert codes == ["bad-argument-type"]
    assert not check('attr c = "#abc"\nLot --> footprint(rect(1, 1)) extrude(1) color(c) X.\n')
    # a rule parameter is not constant: checked at derive time
    assert not check("Lot --> A(3)\nA(c) --> footprint(rect(1, 1)) extrude(1) color(c) X.\n")


def test_good_grammars_still_check_and_compile():
    text = ("Lot --> footprint(rect(4, 4)) extrude(3) comp(f) { top: T. | side: S | bottom: NIL }\n"
            "S --> split(y) { { ~1: F. }* }\n")
    assert not check(text)
    compile_split(parse(text))


def test_constraint_arguments_use_the_same_binder():
    base = "part A = box(1, 1, 1)\npart B = box(1, 1, 1)\n"
    d = [x for x in check(base + "constraint path(from=A)\n") if x.severity == "error"]
    assert d and d[0].code == "operation-arity" and "constraint path is missing argument(s): to" in d[0].message
    d = [x for x in check(base + "constraint path(form=A, to=B)\n") if x.code == "unknown-argument"]
    assert d and d[0].hint.startswith("did you mean 'from'?")
    from grammarkit.tiling import rules_from_grammar

    with pytest.raises(GrammarError) as info:
        rules_from_grammar(parse(base + "constraint path(from=A)\n"))
    assert info.value.diagnostics[0].code == "operation-arity"
