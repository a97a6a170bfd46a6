"""A grammar attr that replaces a snippet attr with a value outside its range is flagged."""
from grammarkit.dsl import check

SNIPPET = """
snippet win : Window {
  attr depth = 0.2 @range(0.05, 0.4)
  Start --> recess(depth) Glass.
}
Lot --> footprint(rect(20, 10)) extrude(9) Mass.
use win as Window
"""


def _codes(text):
    return [(d.code, d.span.line if d.span else None) for d in check(text)]


def test_out_of_range_override_warns_at_the_grammar_attr():
    codes = _codes("grammar g\nattr depth = 20 @range(5, 40)\n" + SNIPPET)
    assert ("attr-override-range", 2) in codes


def test_in_range_override_is_how_models_set_snippet_params():
    codes = _codes("grammar g\nattr depth = 0.3\n" + SNIPPET)
    assert not any(c == "attr-override-range" for c, _ in codes)
