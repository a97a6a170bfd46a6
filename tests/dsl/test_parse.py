"""Parsing: every construct of the language becomes the expected IR, with spans and comments."""
from __future__ import annotations

from pathlib import Path

import pytest

import grammarkit
from grammarkit.dsl import parse
from grammarkit.errors import GrammarError
from grammarkit.ir import (
    Attr, Binary, Bool, Branch, Call, Case, Choice, Const, Default, Import, Nil, Num, OpCall, PartDef,
    Pattern, Push, Ref, Repeat, Rule, Str, Successor, Terminal, Unary, Use, Vector,
)

DATA = Path(__file__).parent / "data"


def body(src: str):
    """Items of the body of the first rule in `src`."""
    return parse(src).rules[0].body.items


def expr(src: str):
    return parse(f"const c = {src}").consts[0].value


def test_header_and_default_name(tmp_path):
    assert parse("grammar paris\nA --> B").name == "paris"
    assert parse("A --> B").name == "main"
    f = tmp_path / "castle.grammar"
    f.write_text("A --> B\n")
    assert parse(f).name == "castle"
    assert parse(f).source_path == str(f)
    odd = tmp_path / "3-storey.grammar"
    odd.write_text("A --> B\n")
    assert parse(odd).name == "_3_storey"  # always a printable identifier


def test_attr_range_enum_const():
    g = parse('attr h = 18 @range(9, 40)\nattr s = "a" @enum("a", "b")\nconst k = h * 2')
    h, s = g.attrs
    assert h == Attr(name="h", value=Num(value=18), range=(Num(value=9), Num(value=40)))
    assert s.enum == (Str(value="a"), Str(value="b"))
    assert g.consts[0] == Const(name="k", value=Binary(op="*", left=Ref(name="h"), right=Num(value=2)))


def test_precedence_and_associativity():
    assert expr("1 + 2 * 3") == Binary(op="+", left=Num(value=1),
                                       right=Binary(op="*", left=Num(value=2), right=Num(value=3)))
    assert expr("1 - 2 - 3") == Binary(op="-", left=Binary(op="-", left=Num(value=1), right=Num(value=2)),
                                       right=Num(value=3))
    # ^ is right-associative and binds tighter than unary minus
    assert expr("2 ^ 3 ^ 2") == Binary(op="^", left=Num(value=2),
                                       right=Binary(op="^", left=Num(value=3), right=Num(value=2)))
    assert expr("-2 ^ 2") == Unary(op="-", operand=Binary(op="^", left=Num(value=2), right=Num(value=2)))
    assert expr("a || b && !c == d") == Binary(
        op="||", left=Ref(name="a"),
        right=Binary(op="&&", left=Ref(name="b"),
                     right=Binary(op="==", left=Unary(op="!", operand=Ref(name="c")), right=Ref(name="d"))))
    assert expr("a < b + 1") == Binary(op="<", left=Ref(name="a"),
                                       right=Binary(op="+", left=Ref(name="b"), right=Num(value=1)))


def test_negative_literals_fold_but_parenthesised_do_not():
    assert expr("-3") == Num(value=-3)
    assert expr("-(3)") == Unary(op="-", operand=Num(value=3))
    assert expr("- -3") == Unary(op="-", operand=Num(value=-3))
    assert expr("2 ^ -1") == Binary(op="^", left=Num(value=2), right=Num(value=-1))


def test_literals_calls_dotted_vectors():
    assert expr('"a\\"b\\n"') == Str(value='a"b\n')
    assert expr("true") == Bool(value=True)
    assert expr("scope.sx / split.total") == Binary(op="/", left=Ref(name="scope.sx"),
                                                    right=Ref(name="split.total"))
    assert expr("rand(1, 2)") == Call(func="rand", args=(Num(value=1), Num(value=2)))
    assert expr("(1, 2, 3)") == Vector(items=(Num(value=1), Num(value=2), Num(value=3)))
    assert expr("(1,)") == Vector(items=(Num(value=1),))
    assert expr("1.5e3") == Num(value=1500)
    assert expr(".5") == Num(value=0.5)


def test_op_calls_positional_named_and_blocks():
    items = body("A --> roofGable(35, overhang=0.4, ridge=y) split(y) { 2: B | ~h: C | '0.3: D. }")
    gable, split = items
    assert isinstance(gable, OpCall) and gable.block is None
    assert [a.name for a in gable.args] == [None, "overhang", "ridge"]
    assert gable.args[2].value == Ref(name="ridge") or gable.args[2].value == Ref(name="y")
    assert [b.mode for b in split.block] == ["abs", "float", "rel"]
    assert split.block[1].key == Ref(name="h")
    assert split.block[2].body.items == (Terminal(name="D"),)


def test_nested_repeat_groups():
    (split,) = body("A --> split(x) { ~1: W. | { 1.2: Win | { ~0.2: W. }* }* | ~1: W. }")
    outer = split.block[1]
    assert isinstance(outer, Repeat)
    assert isinstance(outer.items[1], Repeat)
    assert outer.items[1].items[0] == Branch(mode="float", key=Num(value=0.2),
                                             body=outer.items[1].items[0].body)


def test_selectors_nil_terminal_push():
    items = body("A --> comp(f) { top: Roof | bottom: NIL } [ t(0, 0, 1) Chimney ] Wall.")
    comp, push, term = items
    assert comp.block[0].key == Ref(name="top")
    assert comp.block[1].body.items == (Nil(),)
    assert isinstance(push, Push) and push.body.items[1] == Successor(name="Chimney")
    assert term == Terminal(name="Wall")


def test_successor_calls_resolve_by_rule_names():
    g = parse("A --> split(y) { { ~3: Floor(split.index) }* } foo(1)\nFloor(i) --> Wall.")
    split, foo = g.rules[0].body.items
    succ = split.block[0].items[0].body.items[0]
    assert succ == Successor(name="Floor", args=(Ref(name="split.index"),))
    assert isinstance(foo, OpCall)  # not a rule: an operation (checked against the registry)
    assert g.rules[1].params == ("i",)


def test_case_choice_pattern_nesting():
    (case,) = body("A --> case x > 1: (case y: B else: C) D else: E")
    assert isinstance(case, Case) and len(case.arms) == 1
    assert isinstance(case.arms[0].body.items[0], Case)
    assert case.arms[0].body.items[1] == Successor(name="D")
    assert case.otherwise.items == (Successor(name="E"),)
    (choice,) = body("A --> 30%: B | p%: C | else: D")
    assert isinstance(choice, Choice)
    assert [a.percent for a in choice.arms] == [Num(value=30), Ref(name="p")]
    rep, pat = body("A --> repeat(x, 2, 0.3) (Window Pillar)* Window")
    assert pat == Pattern(group=("Window", "Pillar"), tail="Window")
    _, pat = body("A --> repeat(x, 2) (W)*")
    assert pat == Pattern(group=("W",))
    # a successor followed by a parenthesised group (space before '(') is not a call
    items = body("A --> B (case x: C else: D)")
    assert items[0] == Successor(name="B") and isinstance(items[1], Case)


def test_snippets_use_default_variants_import():
    g = parse('import "lib.grammar"\n'
              "snippet gable : Roof {\n  attr d = 35 @range(15, 60)\n  Start --> roofGable(d)\n"
              "  Other --> NIL; Third --> NIL\n}\n"
              "use gable as Roof\ndefault gable for Roof\n"
              "variants Roof { gable: 50% | hip: 30% }")
    (imp,) = g.imports
    assert imp == Import(path="lib.grammar")
    (s,) = g.snippets
    assert s.object_type == "Roof" and [r.name for r in s.rules] == ["Start", "Other", "Third"]
    assert s.attrs[0].name == "d"
    assert g.uses == (Use(snippet="gable", anchor="Roof"),)
    assert g.defaults == (Default(snippet="gable", object_type="Roof"),)
    assert [o.snippet for o in g.variants[0].options] == ["gable", "hip"]
    assert g.family == "split"


def test_tiling_statements():
    g = parse((DATA / "tiling_full.grammar").read_text())
    assert g.family == "tiling"
    assert g.parts[0] == PartDef(name="Tower", geometry=Call(func="mesh", args=(Str(value="parts/tower.glb"),)))
    site = g.sites[0]
    assert (site.part, site.name, site.facing, site.mirror) == ("Wall", "end", "-x", "x")
    d0, d1, d2 = g.docks
    assert (d0.a, d0.a_site, d0.b, d0.b_site) == ("Tower", "side", "Wall", "end")
    assert len(d1.placements) == 2 and d1.placements[1].rot is None
    assert d2.placements[1].rot == (Num(value=0), Num(value=0), Num(value=180))
    tower, wall, gate = g.neighbor_rules
    assert tower.multisets == (("Wall", "Wall"), ("Wall", "Wall", "Gate"))
    assert [(c.type, c.lo, c.hi) for c in wall.counts] == [("Tower", 1, 2), ("Gate", 0, 1), ("Wall", 0, None)]
    assert gate.multisets[1] == () and gate.counts[0].lo == gate.counts[0].hi == 0
    assert [c.name for c in g.constraints] == ["connected", "grounded", "path", "count"]
    assert g.constraints[2].args[0].name == "from"
    small, tiny, line = g.examples
    assert small.source == "examples/castle_small.glb" and not small.parts
    assert [p.type for p in tiny.parts] == ["Tower", "Wall"]
    assert len(line.parts) == 3


def test_spans_point_at_source():
    g = parse("attr h = 1\n\nLot --> extrude(h) Mass", filename="x.grammar")
    rule = g.rules[0]
    assert (rule.span.file, rule.span.line, rule.span.column) == ("x.grammar", 3, 1)
    ext, mass = rule.body.items
    assert (ext.span.line, ext.span.column, ext.span.end_column) == (3, 9, 19)
    assert ext.args[0].value.span.column == 17
    assert mass.span.column == 20


def test_every_node_has_a_span():
    g = parse((DATA / "split_full.grammar").read_text(), filename="s.grammar")
    missing = []

    def walk(node, path):
        from grammarkit.ir import Node
        if isinstance(node, Node):
            if node.span is None or node.span.line == 0:
                missing.append(path)
            for name, value in node.__dict__.items():
                walk(value, f"{path}.{name}")
        elif isinstance(node, (tuple, list)):
            for i, v in enumerate(node):
                walk(v, f"{path}[{i}]")
    for i, s in enumerate(g.statements):
        walk(s, f"statements[{i}]")
    assert not missing, missing[:5]


def test_newlines_end_statements_except_in_brackets():
    g = parse("A --> split(y) {\n  1: B\n  | 2: C\n}\nB --> t(1,\n 2,\n 3)")
    assert len(g.rules) == 2
    with pytest.raises(GrammarError) as e:
        parse("A --> split(y)\n{ 1: B }")
    assert e.value.span.line == 2


def test_comments_attach_to_next_statement():
    g = parse("# file comment\ngrammar g\n# about h\nattr h = 1  # trailing\n"
              "snippet s : T {\n  # inside\n  Start --> NIL\n}\n# the end\n")
    assert g.comments == (" file comment",)
    assert g.attrs[0].comments == (" about h", " trailing")
    assert g.snippets[0].rules[0].comments == (" inside",)
    assert g.trailing_comments == (" the end",)


def test_public_api_is_lazy_and_works(tmp_path):
    f = tmp_path / "a.grammar"
    f.write_text("A --> extrude(1) B.\n")
    assert grammarkit.parse(f).rules[0].name == "A"
    assert grammarkit.check(f) == []
    assert grammarkit.format("A-->extrude( 1 )B.") == "A --> extrude(1) B.\n"


def test_ir_json_round_trip():
    g = parse((DATA / "split_full.grammar").read_text())
    again = type(g).model_validate_json(g.model_dump_json())
    assert again == g


@pytest.mark.parametrize("src, line, col, expected", [
    ("A --> split(x) { 1: B | ", 1, 24, "a number"),
    ("attr = 3", 1, 6, "a name"),
    ("A --> B\nC -> D", 2, 3, "'-->'"),
    ('attr s = "abc', 1, 10, None),
    ("site Wall at (1, 2, 3)", 1, 6, "a dotted name"),
])
def test_syntax_errors_are_located_and_in_plain_words(src, line, col, expected):
    with pytest.raises(GrammarError) as e:
        parse(src, filename="f.grammar")
    d = e.value.diagnostics[0]
    assert (d.span.file, d.span.line, d.span.column) == ("f.grammar", line, col)
    assert d.message.startswith("syntax error")
    if expected:
        assert expected in d.hint
    text = e.value.format(src)
    assert text.splitlines()[0].startswith(f"f.grammar:{line}:{col}: error: syntax error")
    assert "^" in text


def test_all_syntax_errors_reported_at_once():
    src = "A --> B\nattr = 1\nC --> D\nE --> split(x) {\nconst = 2\nF --> G"
    with pytest.raises(GrammarError) as e:
        parse(src)
    lines = [d.span.line for d in e.value.diagnostics if d.severity == "error"]
    assert 2 in lines and 5 in lines and len(lines) >= 2


def test_reserved_words_rejected_as_names():
    with pytest.raises(GrammarError) as e:
        parse("A --> t(1, 2, 3) at")
    assert "reserved word" in e.value.diagnostics[0].message
