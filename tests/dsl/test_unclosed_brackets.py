"""An unexpected end names the bracket that was never closed, with its position."""
from grammarkit.dsl import check
from grammarkit.dsl.parser import unclosed_brackets


def _errors(text):
    return [d for d in check(text) if d.severity == "error"]


def test_unclosed_block_in_the_middle_of_a_file_is_the_end_of_a_statement():
    text = ("Lot --> extrude(3) Mass\n"
            "Mass --> comp(f) { top: Roof. | side: Facade\n"
            "Facade --> split(y) { 3: A. | ~1: B. }\n")
    (err,) = _errors(text)
    assert err.span.line == 2
    assert err.message == "syntax error: unexpected end of statement"
    assert "the '{' opened at line 2, column 18 is never closed" in err.hint


def test_unclosed_bracket_at_the_end_of_the_file():
    (err,) = _errors("A --> split(x) { 1: B |\n")
    assert err.message == "syntax error: unexpected end of file"
    assert "the '{' opened at line 1, column 16 is never closed" in err.hint


def test_scanner_ignores_brackets_in_strings_and_comments():
    assert unclosed_brackets('A --> color("(") # {\n') == []
    assert unclosed_brackets("A --> t(1, [2\n") == [("(", 1, 8), ("[", 1, 12)]
