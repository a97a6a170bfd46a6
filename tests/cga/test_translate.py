"""CGA constructs -> grammarkit IR: each supported construct, the axis mapping, warnings."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.cga import import_cga, translate_cga
from _cga_helpers import LOT, imported  # noqa: E402  (tests/cga/conftest.py)
from grammarkit.ir import Attr, Branch, Case, Choice, Const, Num, OpCall, Push, Ref, Repeat, Rule, Successor


def rule(result, name: str) -> Rule:
    return next(r for r in result.grammar.rules if r.name == name)


def ops(seq, name):
    return [it for it in seq.items if isinstance(it, OpCall) and it.name == name]


def test_attrs_ranges_enums_consts():
    r = imported('''
@Range(min=2, max=10) attr h = 5
@Range(0, 8) attr o = 3
@Enum("a", "b") attr style = "a"
@Range("x", "y") attr old_enum = "x"
@Order(1) @Group("G") attr plain = 1
const k = h * 2 + o
Lot --> extrude(k) X.
''')
    attrs = {a.name: a for a in r.grammar.attrs}
    assert attrs["h"].range == (Num(value=2), Num(value=10))
    assert attrs["o"].range == (Num(value=0), Num(value=8))
    assert [e.value for e in attrs["style"].enum] == ["a", "b"]
    assert [e.value for e in attrs["old_enum"].enum] == ["x", "y"]
    assert attrs["plain"].range is None and attrs["plain"].enum is None
    assert isinstance(r.grammar.consts[0], Const)
    assert r.report.ignored["@Order"] == 1 and r.report.ignored["@Group"] == 1


def test_default_outside_range_is_widened_with_a_warning():
    r = imported("@Range(min=28, max=150) attr H = 10\nLot --> extrude(H) X.\n")
    assert r.grammar.attrs[0].range == (Num(value=10), Num(value=150))
    warnings = [d for d in r.diagnostics if d.severity == "warning"]
    assert warnings and warnings[0].span.line == 1 and "widened" in warnings[0].message


def test_rule_parameters_case_and_stochastic():
    r = imported('''
Lot --> extrude(10) A(3)
A(n) --> case n > 2: B(n - 1) case n == 2: C. else: NIL
B(m) --> 30%: X. 20%: Y. else: Z.
''')
    a = rule(r, "A")
    assert a.params == ("n",)
    case = a.body.items[0]
    assert isinstance(case, Case) and len(case.arms) == 2 and case.otherwise is not None
    choice = rule(r, "B").body.items[0]
    assert isinstance(choice, Choice) and [arm.percent.value for arm in choice.arms] == [30, 20]


def test_split_sizes_and_repeats():
    r = imported('''
Lot --> extrude(10) comp(f) { front: F }
F --> split(x) { 1: A | { ~2: B | 0.3: C }* | '0.1: D | ~scope.sx / 4: E }
G --> split(y) { ~3: Floor }*
''')
    block = ops(rule(r, "F").body, "split")[0].block
    assert [type(b).__name__ for b in block] == ["Branch", "Repeat", "Branch", "Branch"]
    assert block[0].mode == "abs" and block[2].mode == "rel"
    assert block[1].items[0].mode == "float" and block[1].items[1].mode == "abs"
    # `~scope.sx / 4` is floating (scope.sx / 4), as in CGA
    assert block[3].mode == "float" and block[3].key.op == "/"
    whole = ops(rule(r, "G").body, "split")[0].block
    assert len(whole) == 1 and isinstance(whole[0], Repeat)


def test_axis_mapping_on_volumes_and_faces():
    r = imported('''
Lot --> extrude(12) Mass
Mass --> [ split(y) { 3: Ground | ~1: Upper } ] split(z) { 2: Back | ~1: Front } 
Face --> split(y) { 1: A | ~1: B }
Lot2 --> comp(f) { side: Face }
''')
    mass = rule(r, "Mass")
    push, depth = mass.body.items
    assert isinstance(push, Push)
    up = push.body.items[0]
    assert up.args[0].value == Ref(name="z")                       # CGA y (up) -> z
    assert depth.args[0].value == Ref(name="y")                    # CGA z (street) -> y ...
    assert [b.body.items[0].name for b in depth.block] == ["Front", "Back"]   # ... reversed


def test_face_frame_is_identity_and_rules_are_specialised_per_frame():
    r = imported('''
Lot --> extrude(10) comp(f) { front: Tile | top: Roof } Tile
Tile --> split(y) { ~1: W. }
Roof --> roofHip(30, 0.5)
''')
    names = {rr.name for rr in r.grammar.rules}
    assert {"Tile", "Tile_y"} <= names
    face = ops(rule(r, "Tile").body, "split")[0]
    volume = ops(rule(r, "Tile_y").body, "split")[0]
    assert face.args[0].value == Ref(name="y") and volume.args[0].value == Ref(name="z")
    roof = ops(rule(r, "Roof").body, "roofHip")[0]
    assert roof.args[1].name == "overhang"


def test_comp_selectors_on_an_extruded_face_follow_cga_axes():
    r = imported('''
Lot --> extrude(10) comp(f) { front: Bal }
Bal --> extrude(1) comp(f) { front: F. | top: T. | side: S. }
''')
    block = ops(rule(r, "Bal").body, "comp")[0].block
    keys = [b.key.name for b in block]
    assert keys[:2] == ["top", "back"]                  # CGA front (+z) / top (+y) of a face volume
    assert set(keys[2:]) == {"top", "bottom", "left", "right"}


def test_relative_s_t_and_transforms():
    r = imported('''
Lot --> extrude(10) comp(f) { front: F }
F --> s('1, '0.5, 0.2) t(0, 0, -0.3) r(0, 0, 15) center(x) i("missing.obj")
''')
    f = rule(r, "F").body.items
    s = f[0]
    assert s.args[0].value == Ref(name="scope.sx")
    assert s.args[1].value.op == "*" and s.args[1].value.right == Ref(name="scope.sy")
    assert [it.name for it in f] == ["s", "t", "r", "center", "i"]
    assert r.report.assets == [{"path": "missing.obj", "found": False, "resolved": None, "line": 3}]


def test_s_on_a_volume_keeps_cga_origin_at_the_back():
    r = imported("Lot --> extrude(10) s('1, '1, 4) X.\n")
    t, s = rule(r, "Lot").body.items[1:3]
    assert t.name == "t" and s.name == "s"
    assert s.args[1].value == Num(value=4)          # CGA depth (z) is grammarkit's sy
    model = grammarkit.derive(r.grammar, lot=LOT)
    lo, hi = model.mesh.bounds
    assert hi[1] == pytest.approx(16, abs=0.01) and lo[1] == pytest.approx(12, abs=0.01)


def test_functions_are_inlined_and_colors_converted():
    r = imported('''
attr base = 3
half(x) = x / 2
tall = base * 4
Lot --> extrude(half(tall) + 1) color(1, 0.5, 0) X.
''')
    ex = rule(r, "Lot").body.items[0]
    assert ex.args[0].value.op == "+"
    color = rule(r, "Lot").body.items[1]
    assert color.args[0].value.value == "#ff8000"
    fn = [c for c in r.report.constructs if c.kind == "function"]
    assert all(c.status == "translated" for c in fn) and len(fn) == 2


def test_offset_then_comp_inside_border_is_one_offset():
    r = imported("Lot --> offset(-2) comp(f) { inside: extrude(5) In. | border: Border. }\n")
    off = rule(r, "Lot").body.items[0]
    assert off.name == "offset" and [b.key.name for b in off.block] == ["inside", "border"]


def test_block_before_more_items_keeps_the_shape():
    r = imported("Lot --> extrude(9) comp(f) { front: F }\nF --> split(y) { ~3: Fl. }* Ledge\n")
    items = rule(r, "F").body.items
    assert isinstance(items[0], Push) and items[0].body.items[0].name == "split"


def test_untranslatable_constructs_warn_with_location_and_feature():
    text = ("Lot -->\n  copyUV(1, 0)\n  extrude(geometry.angle(zenith) * 0.1)\n"
            "  setNormals(hard)\n  X.\n")
    result = translate_cga(text, filename="w.cga")
    assert result.ok
    warnings = [d for d in result.diagnostics if d.severity == "warning"]
    assert [(d.span.line, d.span.column) for d in warnings] == [(2, 3), (3, 3), (4, 3)]
    assert {c.feature for c in result.report.constructs if c.status != "translated"} == {
        "op:copyUV", "fn:geometry.angle", "op:setNormals"}
    formatted = warnings[0].format(text)
    assert formatted.startswith("w.cga:2:3: warning: not translated: copyUV()")
    assert "    ^" in formatted


def test_counts_are_consistent():
    r = imported("attr a = 1\nLot --> extrude(3) setNormals(hard) X.\n")
    rep = r.report
    assert rep.total == rep.translated + rep.warned
    assert rep.to_json()["constructs"]["dropped"] == 1


def test_public_api_and_lazy_name():
    grammar, diags = grammarkit.import_cga("Lot --> extrude(4) X.\n")
    assert grammar is not None and not diags
    assert grammarkit.check(grammarkit.print_grammar(grammar)) == []


def test_cga_and_grammarkit_derive_the_same_building():
    cga = '''
attr H = 12
Lot --> extrude(H) comp(f) { top: Roof | side: Facade }
Roof --> roofHip(30) R.
Facade --> split(y) { ~3: Floor }*
Floor --> split(x) { 1: W. | { ~3: Win | 0.5: W. }* }
Win --> split(y) { 1: W. | 1.5: extrude(0.2) Frame. | ~1: W. }
'''
    hand = '''
attr H = 12
Lot --> extrude(H) comp(f) { top: Roof | side: Facade }
Roof --> roofHip(30) R.
Facade --> split(y) { { ~3: Floor }* }
Floor --> split(x) { 1: W. | { ~3: Win | 0.5: W. }* }
Win --> split(y) { 1: W. | 1.5: extrude(0.2) Frame. | ~1: W. }
'''
    g, diags = import_cga(cga)
    assert g is not None and not diags
    a = grammarkit.derive(g, lot=LOT)
    b = grammarkit.derive(grammarkit.parse(hand), lot=LOT)
    assert a.mesh.volume == pytest.approx(b.mesh.volume, rel=1e-9)
    assert (a.mesh.bounds == b.mesh.bounds).all()
    assert a.mesh.is_watertight


def test_a_first_rule_with_parameters_is_not_the_start_rule():
    # a parameterless root that leads to the rest of the file starts instead (with a warning)
    r = translate_cga("Part(h) --> extrude(h) P.\nLot --> Part(3)\n", filename="s.cga")
    assert r.ok and r.grammar.rules[0].name == "Lot"
    assert any(c.feature == "start:params" for c in r.report.constructs)
    assert grammarkit.derive(r.grammar, lot=LOT).mesh.is_watertight
    # a library of rules with parameters: the first rule stays first, and deriving says why
    # it cannot start (not an IndexError deep in the engine)
    r = translate_cga("Vol(i, use) --> case use == \"a\": Sub(i) else: B.\n"
                      "Sub(i) --> extrude(i) A.\n", filename="l.cga")
    assert r.ok and r.grammar.rules[0].name == "Vol"
    assert any(c.feature == "start:params" and c.status == "dropped" for c in r.report.constructs)
    with pytest.raises(grammarkit.errors.GrammarError) as e:
        grammarkit.derive(r.grammar, lot=LOT)
    assert "start rule 'Vol' takes parameters (i, use_)" in str(e.value) and e.value.span.line == 1


def test_case_and_stochastic_values_become_select_and_pick():
    text = ('attr type = "tall"\n'
            'attr h = case type == "tall": 30 case type == "mid": 20 else: 10\n'
            'const w = 40%: 2 30%: 3 else: 4\n'
            'inv(x) = case x == 0: 0 else: 1 / x\n'
            "Lot --> extrude(h + inv(0)) s(w, '1, '1) X.\n")
    r = imported(text)
    assert not [c for c in r.report.constructs if c.status != "translated"]
    assert 'select(type == "tall", 30, select(type == "mid", 20, 10))' in r.text
    assert "pick(rand(0, 100), 40, 2, 30, 3, 4)" in r.text
    tops = {t: grammarkit.derive(r.grammar, attrs={"type": t}, lot=LOT).mesh.bounds[1][2]
            for t in ("tall", "mid", "low")}
    assert tops == pytest.approx({"tall": 30, "mid": 20, "low": 10}, abs=0.01)
    widths = {round(grammarkit.derive(r.grammar, seed=s, lot=LOT).mesh.bounds[1][0]) for s in range(40)}
    assert widths == {2, 3, 4}  # every arm is drawn for some seed


def test_scope_alignment_operations_and_the_frame_they_leave():
    text = ("Lot --> alignScopeToAxes(y) rotateScope(0, 30, 0) alignScopeToGeometry(yUp, 0, longest) "
            "extrude(3) comp(f) { front: alignScopeToGeometry(yUp, 0, 0) split(z) { 1: A | ~1: B } }\n"
            "A --> extrude(1) A.\nB --> extrude(2) B.\n")
    r = imported(text)
    assert not [c for c in r.report.constructs if c.status != "translated"]
    assert ('alignScopeToAxes("z") rotateScope(0, 0, 30) alignScopeToGeometry("longest")' in r.text)
    # after alignScopeToGeometry(yUp, ...) the face is in CGA's y-up frame: split(z) is
    # grammarkit's split(y), reversed
    assert "alignScopeToGeometry(0) split(y) { ~1: B | 1: A }" in r.text
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert m.mesh.is_watertight
    # rotateScope about an axis in the face plane is translated too (tests/cga/test_scope_ops_import.py)
    r = translate_cga("Lot --> rotateScope(90, 0, 0) X.\n", filename="r.cga")
    assert r.report.warned == 0 and "rotateScope(90, 0, 0)" in r.text


def test_text_joins_and_list_functions():
    r = imported('attr id = 7\nattr names = "a;b;c;"\n'
                 'Lot --> report("Height." + id, 3) report(listItem(names, 1) + 2, listSize(names)) '
                 'extrude(float("4")) X.\n')
    assert 'report("Height." + str(id), 3)' in r.text
    assert "report(listItem(names, 1) + str(2), listSize(names))" in r.text
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert set(m.reports) == {"Height.7", "b2"} and m.reports["b2"]["sum"] == 3


def test_reverse_normals_replace_and_list_random():
    r = imported('attr l = "a;b;c;"\nLot --> reverseNormals report(replace(listRandom(l), "a", "x"), 1) X.\n')
    assert "reverseNormals()" in r.text and "listItem(l, floor(rand(0, listSize(l))))" in r.text
    drawn = set()
    for seed in range(30):
        drawn |= set(grammarkit.derive(r.grammar, seed=seed, lot=LOT).reports)
    assert drawn == {"x", "b", "c"}


def test_imports_are_translated_under_their_alias(tmp_path):
    (tmp_path / "lib.cga").write_text('attr h = 1\nattr c = "#ff0000"\nconst k = 2\n'
                                      'tall(x) = x * k\n'
                                      'Block --> extrude(tall(h)) color(c) Part(h)\nPart(h) --> B.\n'
                                      'Unused --> X.\n')
    main = tmp_path / "main.cga"
    main.write_text('attr c = "#00ff00"\nimport lib : "/some/project/rules/lib.cga" (h = 3)\n'
                    "@StartRule\nLot --> lib.Block\n")
    r = translate_cga(main)
    assert r.ok, [d.message for d in r.diagnostics]
    # the import and its call are translated; the imported file's own constructs are counted
    # when it is imported on its own
    assert {c.kind for c in r.report.constructs} >= {"import", "successor"}
    assert not [c for c in r.report.constructs if c.status != "translated"]
    assert "attr lib_h = 3" in r.text and "attr lib_c = c" in r.text  # argument, propagation
    assert "Unused" not in r.text  # imported rules only when called
    m = grammarkit.derive(r.grammar, lot=LOT)
    assert m.mesh.bounds[1][2] == pytest.approx(6, abs=0.01)  # tall(3) = 3 * 2
    assert {p.color for p in m.parts} == {"#00ff00"}
    # a missing file, and a cycle, are reported, not followed
    (tmp_path / "loop.cga").write_text('import me : "loop.cga"\nLot --> me.Lot\n')
    r = translate_cga(tmp_path / "loop.cga")
    assert [c.feature for c in r.report.constructs if c.status != "translated"][:1] == ["import"]
    r = translate_cga('import gone : "nowhere.cga"\nLot --> gone.X\n', filename=str(tmp_path / "g.cga"))
    assert any("not found" in (c.message or "") for c in r.report.constructs)


def test_set_trim_vertical_is_trim():
    r = imported("Lot --> extrude(3) comp(f) { side: set(trim.vertical, false) set(trim.horizontal, false) "
                 "s('1, '1, 1) i(\"builtin:cube\") C }\n")
    assert "trim(false)" in r.text and "trim.horizontal" not in r.text
    assert not [c for c in r.report.constructs if c.status != "translated"]
