"""The printer: parse(print(ir)) == ir for generated IRs, fmt is idempotent, examples round-trip."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grammarkit.dsl import KEYWORDS, check, parse
from grammarkit.errors import GrammarError
from grammarkit.ir import (
    Arg, Attr, Binary, Bool, Branch, Call, Case, CaseArm, Choice, ChoiceArm, Const, ConstraintDef,
    CountRange, Default, DockDef, ExampleDef, Function, Grammar, Import, InlinePart, NeighborRule, Nil, Num,
    OpCall, PartDef, Pattern, Placement, Push, Ref, Repeat, Rule, Seq, SiteDef, Snippet, Str,
    Successor, Terminal, Unary, Use, Variants, VariantOption, Vector,
)
from grammarkit.printer import format_grammar, print_grammar

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parent / "data"

# Rule names and operation names are drawn from disjoint pools: `Name(args)` reads back as a
# successor exactly when Name is a rule of the grammar (the printer refuses the other cases).
RULE_NAMES = ["Lot", "Mass", "Facade", "A", "B_2", "Start"]
OP_NAMES = ["extrude", "split", "comp", "my_op", "t"]

ident = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,5}", fullmatch=True).filter(lambda s: s not in KEYWORDS)
dotted = st.builds(lambda a, b: f"{a}.{b}", ident, ident)
text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=6)
comment_text = st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=12).map(
    lambda s: (" " + s).rstrip())

numbers = st.floats(allow_nan=False, allow_infinity=False, width=64)
leaves = st.one_of(
    st.builds(Num, value=numbers),
    st.builds(Num, value=st.integers(-1000, 1000).map(float)),
    st.builds(Str, value=text),
    st.builds(Bool, value=st.booleans()),
    st.builds(Ref, name=ident),
    st.builds(Ref, name=dotted),
)
BIN_OPS = ["+", "-", "*", "/", "%", "^", "==", "!=", "<", "<=", ">", ">=", "&&", "||"]


def _extend(children):
    return st.one_of(
        st.builds(Unary, op=st.sampled_from(["-", "+", "!"]), operand=children),
        st.builds(Binary, op=st.sampled_from(BIN_OPS), left=children, right=children),
        st.builds(Call, func=ident, args=st.lists(children, max_size=3).map(tuple)),
        st.builds(Vector, items=st.lists(children, max_size=3).map(tuple)),
    )


exprs = st.recursive(leaves, _extend, max_leaves=8)
percents = st.one_of(st.builds(Num, value=st.floats(0, 1e6)), st.builds(Ref, name=ident))


def seqs(rule_names, depth):
    """Non-empty sequences; a Pattern only as the last item."""
    simple = [
        st.builds(Successor, name=st.one_of(ident, st.sampled_from(RULE_NAMES))),
        st.builds(Successor, name=st.sampled_from(rule_names),
                  args=st.lists(exprs, min_size=1, max_size=2).map(tuple)),
        st.builds(Terminal, name=ident),
        st.builds(Nil),
        st.builds(OpCall, name=st.sampled_from(OP_NAMES), args=st.lists(
            st.builds(Arg, name=st.one_of(st.none(), ident), value=exprs), max_size=3).map(tuple),
            block=st.none()),
    ]
    if depth > 0:
        inner = st.deferred(lambda: seqs(rule_names, depth - 1))
        branch = st.builds(Branch, mode=st.sampled_from(["abs", "rel", "float"]), key=exprs, body=inner)
        block_items = st.recursive(branch, lambda c: st.builds(
            Repeat, items=st.lists(c, max_size=3).map(tuple)), max_leaves=4)
        simple += [
            st.builds(OpCall, name=st.sampled_from(OP_NAMES), args=st.lists(
                st.builds(Arg, name=st.one_of(st.none(), ident), value=exprs), max_size=2).map(tuple),
                block=st.lists(block_items, max_size=3).map(tuple)),
            st.builds(Push, body=inner),
            st.builds(Case, arms=st.lists(st.builds(CaseArm, cond=exprs, body=inner), min_size=1,
                                          max_size=3).map(tuple), otherwise=st.one_of(st.none(), inner)),
            st.builds(Choice, arms=st.lists(st.builds(ChoiceArm, percent=percents, body=inner),
                                            min_size=1, max_size=3).map(tuple),
                      otherwise=st.one_of(st.none(), inner)),
        ]
    item = st.one_of(*simple)
    pattern = st.builds(Pattern, group=st.lists(ident, min_size=1, max_size=3).map(tuple),
                        tail=st.one_of(st.none(), ident))
    return st.builds(lambda items, last: Seq(items=tuple(items) + ((last,) if last else ())),
                     st.lists(item, min_size=1, max_size=4),
                     st.one_of(st.none(), pattern))


def rules(names, depth=2):
    return st.builds(Rule, name=st.sampled_from(RULE_NAMES), params=st.lists(ident, max_size=2).map(tuple),
                     body=seqs(names, depth), comments=st.lists(comment_text, max_size=2).map(tuple))


attrs = st.builds(Attr, name=ident, value=exprs,
                  range=st.one_of(st.none(), st.tuples(exprs, exprs)),
                  enum=st.one_of(st.none(), st.lists(exprs, max_size=3).map(tuple)),
                  comments=st.lists(comment_text, max_size=2).map(tuple))
vec3 = st.tuples(exprs, exprs, exprs)
placements = st.builds(Placement, at=vec3, rot=st.one_of(st.none(), vec3))
args = st.lists(st.builds(Arg, name=st.one_of(st.none(), ident), value=exprs), max_size=3).map(tuple)


def statements():
    names = RULE_NAMES
    return st.one_of(
        attrs,
        st.builds(Const, name=ident, value=exprs),
        st.builds(Function, name=ident, params=st.lists(ident, max_size=3).map(tuple), value=exprs,
                  comments=st.lists(comment_text, max_size=2).map(tuple)),
        rules(names),
        st.builds(Snippet, name=ident, object_type=ident, attrs=st.lists(attrs, max_size=2).map(tuple),
                  rules=st.lists(rules(names, 1), max_size=2).map(tuple)),
        st.builds(Use, snippet=ident, anchor=ident),
        st.builds(Default, snippet=ident, object_type=ident),
        st.builds(Variants, object_type=ident, options=st.lists(
            st.builds(VariantOption, snippet=ident, weight=percents), max_size=3).map(tuple)),
        st.builds(Import, path=text),
        st.builds(PartDef, name=ident, geometry=st.builds(Call, func=ident,
                                                          args=st.lists(exprs, max_size=3).map(tuple))),
        st.builds(SiteDef, part=ident, name=ident, position=vec3,
                  facing=st.sampled_from(["+x", "-x", "+y", "-y", "+z", "-z"]),
                  mirror=st.one_of(st.none(), st.sampled_from(["x", "y", "z"]))),
        st.builds(DockDef, a=ident, a_site=st.one_of(st.none(), ident), b=ident,
                  b_site=st.one_of(st.none(), ident), placements=st.lists(placements, max_size=3).map(tuple)),
        st.builds(NeighborRule, part=ident,
                  multisets=st.lists(st.lists(ident, max_size=3).map(tuple), max_size=3).map(tuple),
                  counts=st.lists(st.builds(CountRange, type=ident, lo=st.integers(0, 50),
                                            hi=st.one_of(st.none(), st.integers(0, 50))),
                                  max_size=3).map(tuple)),
        st.builds(ConstraintDef, name=ident, args=args),
        st.builds(ExampleDef, name=ident, source=text, parts=st.just(())),
        st.builds(ExampleDef, name=ident, source=st.none(), parts=st.lists(
            st.builds(InlinePart, type=ident, placement=placements), max_size=3).map(tuple)),
    )


@st.composite
def grammars(draw):
    stmts = draw(st.lists(statements(), max_size=6))
    # every rule name used by a successor-with-arguments must be a rule of the grammar
    stmts += [Rule(name=n, body=Seq(items=(Nil(),))) for n in RULE_NAMES]
    return Grammar(name=draw(ident), statements=tuple(stmts),
                   comments=tuple(draw(st.lists(comment_text, max_size=2))),
                   trailing_comments=tuple(draw(st.lists(comment_text, max_size=2))))


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(grammars())
def test_parse_print_round_trip_for_generated_irs(g):
    text = print_grammar(g)
    again = parse(text)
    assert again == g, text
    # printing is canonical: the printed text is a fixed point of fmt
    assert print_grammar(again) == text
    assert format_grammar(text) == text


@settings(max_examples=300, deadline=None, derandomize=True)
@given(exprs)
def test_expression_round_trip(e):
    from grammarkit.printer import format_expr
    text = format_expr(e)
    assert parse(f"const c = {text}").consts[0].value == e, text


def _example_files():
    files = sorted((ROOT / "grammars").glob("**/*.grammar")) + sorted(DATA.glob("*.grammar"))
    return files


@pytest.mark.parametrize("path", _example_files(), ids=lambda p: p.name)
def test_example_grammars_round_trip_and_check(path):
    source = path.read_text(encoding="utf-8")
    g = parse(source, filename=str(path))
    text = format_grammar(source, filename=str(path))
    assert parse(text, filename=str(path)) == g
    assert format_grammar(text, filename=str(path)) == text  # idempotent
    assert print_grammar(parse(print_grammar(g))) == print_grammar(g)
    errors = [d for d in check(path) if d.severity == "error"]
    assert not errors, "\n".join(d.format() for d in errors)


def test_there_are_example_grammars():
    assert len(_example_files()) >= 2


def test_fmt_keeps_comments_and_layout_rules():
    src = ("# top\ngrammar g\n# about h\nattr   h=18@range( 9,40 )# why\n\n\n"
           "A-->split(y){1:B|{~h:C}*}\n# bye\n")
    out = format_grammar(src)
    assert out == ("# top\ngrammar g\n\n# about h\n# why\nattr h = 18 @range(9, 40)\n\n"
                   "A --> split(y) { 1: B | { ~h: C }* }\n\n# bye\n")
    assert format_grammar(out) == out


def test_long_blocks_break_one_branch_per_line():
    branches = " | ".join(f"{i}: Part_{i}" for i in range(12))
    out = format_grammar(f"A --> split(x) {{ {branches} }}")
    lines = out.splitlines()
    assert lines[0] == "A --> split(x) {"
    assert lines[1] == "  0: Part_0" and lines[2] == "  | 1: Part_1" and lines[-1] == "}"
    assert max(len(line) for line in lines) <= 100
    assert format_grammar(out) == out


def test_numbers_are_printed_minimally():
    out = format_grammar("const a = 3.0 + 0.50 + 1e3 + 2.5e-7")
    assert out == "const a = 3 + 0.5 + 1000 + 2.5e-07\n"


def test_headerless_files_stay_headerless(tmp_path):
    f = tmp_path / "x.grammar"
    assert format_grammar("A --> B", filename=str(f)) == "A --> B\n"
    assert format_grammar("grammar other\nA --> B", filename=str(f)).startswith("grammar other\n")


@pytest.mark.parametrize("bad", [
    Grammar(name="g", statements=(Rule(name="A", body=Seq(items=())),)),
    Grammar(name="g", statements=(Const(name="c", value=Num(value=float("inf"))),)),
    Grammar(name="g", statements=(Const(name="not a name", value=Num(value=1)),)),
    Grammar(name="g", statements=(Rule(name="A", body=Seq(items=(OpCall(name="A"),))),)),
    Grammar(name="g", statements=(Rule(name="A", body=Seq(items=(
        Successor(name="B", args=(Num(value=1),)),))),)),
    Grammar(name="g", statements=(Rule(name="A", body=Seq(items=(
        Pattern(group=("B",)), Successor(name="C")))),)),
    Grammar(name="g", statements=(ExampleDef(name="e", source="f.glb", parts=(
        InlinePart(type="T", placement=Placement(at=(Num(value=0),) * 3)),)),)),
])
def test_unprintable_irs_raise_a_clear_error(bad):
    with pytest.raises(GrammarError) as e:
        print_grammar(bad)
    assert e.value.diagnostics[0].message.startswith("cannot print grammar:")
