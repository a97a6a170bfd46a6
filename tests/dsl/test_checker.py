"""Semantic checks: each problem is reported, located, and all at once."""
from __future__ import annotations

from pathlib import Path

import pytest

from grammarkit.dsl import check, load
from grammarkit.errors import GrammarError

DATA = Path(__file__).parent / "data"


def diags(src: str, severity: str | None = None):
    out = check(src, filename="t.grammar")
    return [d for d in out if severity is None or d.severity == severity]


def messages(src: str, severity: str = "error") -> list[str]:
    return [d.message for d in diags(src, severity)]


def one(src: str, code: str, severity: str = "error"):
    found = [d for d in diags(src, severity) if d.code == code]
    assert found, [(d.code, d.message) for d in diags(src)]
    return found[0]


def test_full_examples_have_no_errors_or_warnings():
    for f in DATA.glob("*_full.grammar"):
        assert check(f) == [], [d.format() for d in check(f)]


def test_undefined_successor_is_a_warning_becoming_a_leaf():
    d = one("A --> extrude(1) Mass", "undefined-successor", "warning")
    assert "becomes a leaf" in d.message and d.span.column == 18
    assert not messages("A --> extrude(1) Mass")


def test_unknown_operation_lists_known_ones_closest_first():
    d = one("A --> extrdue(3) B.", "unknown-operation")
    assert d.message == "unknown operation 'extrdue'"
    assert d.hint.startswith("did you mean 'extrude'? known operations: extrude")
    assert "split" in d.hint


def test_argument_checks():
    assert one("A --> roofGable(30, overhng=1)", "unknown-argument").hint.startswith(
        "did you mean 'overhang'")
    assert "at most 1" in one("A --> extrude(1, 2)", "operation-arity").message
    assert "missing argument(s): height" in one("A --> extrude()", "operation-arity").message
    assert "must be x|y|z" in one("A --> split(w) { 1: B. }", "bad-argument-type").message
    assert "must be a number, not a string" in one('A --> extrude("tall")', "bad-argument-type").message
    assert "must be a string, not a number" in one("A --> color(3)", "bad-argument-type").message
    assert "given twice" in one("A --> extrude(1, height=2)", "bad-argument").message
    # a string attr where a number is needed
    assert one('attr s = "x"\nA --> extrude(s)', "bad-argument-type")


def test_block_kind_checks():
    assert "needs a block of sizes" in one("A --> split(x)", "block-kind").message
    assert "takes no { } block" in one("A --> extrude(1) { 1: B. }", "block-kind").message
    assert "not sizes" in one("A --> comp(f) { ~1: B. }", "block-kind").message
    # a whole number is an index selector (CGA: comp(f) { 0: A }); a fraction is not
    assert one("A --> comp(f) { 1.5: B. }", "unknown-selector")
    assert not [d for d in diags("A --> comp(f) { 0: B. | 2: C. }") if d.code in ("block-kind", "unknown-selector")]
    d = one("A --> comp(f) { topp: B. }", "unknown-selector")
    assert d.hint.startswith("did you mean 'top'?")
    assert one("A --> comp(f) { { top: B. }* }", "block-kind")
    assert not messages("A --> offset(-0.1) B.")  # optional selector block


def test_function_checks():
    assert one("const c = rnd(1, 2)", "unknown-function").hint.startswith("did you mean 'rand'?")
    assert "takes 1 argument(s), got 2" in one("const c = floor(1, 2)", "function-arity").message
    assert "at least 1" in one("const c = min()", "function-arity").message


def test_undefined_references():
    d = one("A --> extrude(hieght) B.\nattr height = 3", "undefined-name")
    assert d.hint.startswith("did you mean 'height'?")
    assert one("A --> extrude(scope.qq) B.", "undefined-name").message == "unknown built-in value 'scope.qq'"
    assert not messages("A(n) --> extrude(n * scope.sx + split.index / split.total) B.")
    assert not messages("snippet s : T {\n attr d = 2\n Start --> extrude(d)\n}")
    assert one("snippet s : T {\n Start --> extrude(d)\n}\nB --> extrude(d)", "undefined-name")


def test_attr_range_and_enum_checks():
    assert "outside its @range(9, 40)" in one("attr h = 50 @range(9, 40)", "out-of-range").message
    assert "is empty: 40 > 9" in one("attr h = 20 @range(40, 9)", "bad-range").message
    assert "not one of its @enum" in one('attr s = "x" @enum("a", "b")', "not-in-enum").message
    assert not messages('attr k = 2\nattr h = k * 10 @range(k, 40)\nattr s = "a" @enum("a", "b")')
    assert one("const k = 50\nattr h = k @range(9, 40)", "out-of-range")


def test_duplicates():
    assert "defined twice (first at t.grammar:1:1)" in one("attr a = 1\nconst a = 2", "duplicate").message
    assert one("A --> B.\nA --> C.", "duplicate")
    assert one("snippet s : T { Start --> NIL }\nsnippet s : T { Start --> NIL }", "duplicate")
    assert one("part P = box(1, 1, 1)\npart P = box(1, 1, 1)", "duplicate")
    assert one("A(x, x) --> B.", "duplicate")
    assert one("snippet s : T {\n Start --> NIL\n Start --> NIL\n}", "duplicate")


def test_cyclic_consts_report_the_cycle():
    d = one("const a = b + 1\nconst b = c * 2\nconst c = a\nconst d = 1", "cycle")
    assert d.message == "cyclic definition: a -> b -> c -> a"
    assert len([x for x in diags("const a = b + 1\nconst b = a") if x.code == "cycle"]) == 1
    assert one("attr x = x + 1", "cycle")


def test_snippet_bindings():
    base = "snippet gable : Roof { Start --> roofGable(30) }\nsnippet door : Door { Start --> NIL }\n"
    assert one(base + "use gabel as Roof", "unknown-snippet").hint.startswith("did you mean 'gable'?")
    d = one(base + "use gable as Door", "object-type")
    assert "Door is an object type" in d.message
    assert not messages(base + "A --> extrude(1) Roof\nuse gable as Roof")
    assert one(base + "default door for Roof", "object-type")
    assert one(base + "default nope for Roof", "unknown-snippet")
    assert one("snippet s : T { Other --> NIL }", "snippet-start")
    assert "add up to 120%" in one(base + "variants Roof { gable: 70% | gable2: 50% }",
                                   "bad-percent").message
    assert one(base + "variants Roof { door: 50% }", "object-type")


def test_stochastic_percentages():
    assert "add up to 110%" in one("A --> 60%: B. | 50%: C.", "bad-percent").message
    assert not messages("A --> 60%: B. | 40%: C. | else: D.")
    assert not messages("attr p = 30\nA --> p%: B. | else: C.")
    assert one("attr p = 70\nA --> p%: B. | 40%: C.", "bad-percent")


def test_successor_arity_and_unreachable_rules():
    assert "takes 1 argument(s), got 2" in one("A --> B(1, 2)\nB(i) --> NIL", "successor-arity").message
    w = one("Lot --> extrude(1) Mass.\nOrphan --> NIL", "unreachable", "warning")
    assert "'Orphan' is never used" in w.message and "'Lot'" in w.message
    # rules reached from a snippet bound with `use` are reachable
    assert not diags("Lot --> Roof\nsnippet g : Roof { Start --> Chimney }\nuse g as Roof\n"
                     "Chimney --> NIL")
    assert not diags("Lot --> Roof\nsnippet g : Roof { Start --> NIL }\ndefault g for Roof")


def test_tiling_checks():
    src = (DATA / "tiling_full.grammar").read_text()
    assert check(src) == []
    assert one(src + "\nneighbors Tower: {Wal}", "unknown-part").hint.startswith("did you mean 'Wall'?")
    assert one(src + "\nsite Keep.top at (0, 0, 0)", "unknown-part")
    assert one(src + "\ndock Tower.roof -- Wall", "unknown-site")
    assert one(src + "\nconstraint conected", "unknown-constraint").hint.startswith(
        "did you mean 'connected'?")
    assert one(src + "\nconstraint path(from=Moat, to=Tower)", "unknown-part")
    assert one(src + "\nexample e { Keep at (0, 0, 0) }", "unknown-part")
    assert one(src + "\nneighbors Wall: Gate in 3..1", "bad-range")


def test_every_problem_reported_at_once():
    src = ("attr h = 50 @range(9, 40)\nconst a = b\nconst b = a\n"
           "A --> extrdue(1) split(w) { 1: B. } comp(f) { topp: C. }\nuse nope as X\n")
    codes = {d.code for d in diags(src, "error")}
    assert {"out-of-range", "cycle", "unknown-operation", "bad-argument-type", "unknown-selector",
            "unknown-snippet"} <= codes


def test_load_raises_with_all_errors_and_returns_grammar_otherwise():
    with pytest.raises(GrammarError) as e:
        load("A --> extrdue(1)\nB --> C(1)\n")
    assert len([d for d in e.value.diagnostics if d.severity == "error"]) >= 1
    g = load("A --> extrude(1) Mass")  # warnings do not stop load
    assert g.rules[0].name == "A"


def test_imports(tmp_path):
    (tmp_path / "lib.grammar").write_text(
        "attr floor_h = 3\nFloor(i) --> split(x) { ~1: Wall. }\n"
        "snippet gable : Roof { Start --> roofGable(30) }\n")
    main = tmp_path / "main.grammar"
    main.write_text('import "lib.grammar"\nLot --> extrude(floor_h) split(y) { ~3: Floor(1) }\n'
                    "use gable as Roof\n")
    assert [d for d in check(main) if d.severity == "error"] == []
    g = load(main)
    assert [r.name for r in g.rules] == ["Floor", "Lot"]
    assert g.rules[0].span.file.endswith("lib.grammar")  # spans keep their file
    # the call to an imported rule is a successor, not an unknown operation
    succ = g.rules[1].body.items[1].block[0].body.items[0]
    assert type(succ).__name__ == "Successor" and succ.name == "Floor"
    # unreachable-rule warnings consider the start rule of the main file
    (tmp_path / "missing.grammar").write_text('import "nowhere.grammar"\nA --> NIL\n')
    d = one((tmp_path / "missing.grammar").read_text().replace("nowhere", str(tmp_path / "nowhere")),
            "import-missing")
    assert "not found" in d.message
    (tmp_path / "a.grammar").write_text('import "b.grammar"\nA --> NIL\n')
    (tmp_path / "b.grammar").write_text('import "a.grammar"\nB --> NIL\n')
    cyc = [x for x in check(tmp_path / "a.grammar") if x.code == "import-cycle"]
    assert cyc and "a.grammar -> b.grammar -> a.grammar" in cyc[0].message
    (tmp_path / "broken.grammar").write_text("A --> (\n")
    (tmp_path / "uses_broken.grammar").write_text('import "broken.grammar"\n')
    out = check(tmp_path / "uses_broken.grammar")
    assert any(x.span and x.span.file.endswith("broken.grammar") for x in out)


def test_plugin_operations_are_checked_like_builtins():
    from grammarkit.plugins import get_plugin_manager
    from grammarkit.registry import OperationSpec, Param
    from grammarkit import hookimpl

    class Plugin:
        @hookimpl
        def grammarkit_operations(self):
            return [OperationSpec("bevel", (Param("width"),))]

    pm = get_plugin_manager()
    assert one("A --> bevel(0.1) B.", "unknown-operation")
    pm.register(Plugin(), "test-bevel")
    try:
        assert not messages("A --> bevel(0.1) B.")
        assert one("A --> bevel()", "operation-arity")
    finally:
        pm.unregister("test-bevel")
    assert one("A --> bevel(0.1) B.", "unknown-operation")


def test_unused_rules_of_an_imported_library_are_not_reported(tmp_path):
    (tmp_path / "lib.grammar").write_text("Used --> NIL\nUnused --> NIL\n")
    main = tmp_path / "main.grammar"
    main.write_text('import "lib.grammar"\nLot --> extrude(1) Used\nOrphan --> NIL\n')
    warnings = [d for d in check(main) if d.code == "unreachable"]
    assert [w.message.split("'")[1] for w in warnings] == ["Orphan"]
