"""CGA's print(value) (grammarkit/split/ops/ op_print): derivation messages on
Model.messages, in the tree JSON, and printed by `grammarkit derive`; imported from CGA."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.cli import main
from grammarkit.errors import DerivationError
from grammarkit.split import engine

LOT = [(0.0, 0.0), (10.0, 0.0), (10.0, 8.0), (0.0, 8.0)]
TEXT = ('attr n = 3\n'
        'Lot --> print("floors " + str(n)) extrude(9) split(z) { { 3: F }* }\n'
        'F --> print(split.index) print(scope.sz > 2) Floor.\n')


def test_messages_in_derivation_order_with_the_rule_that_printed_them():
    m = grammarkit.derive(TEXT, lot=LOT)
    assert m.messages == ["Lot: floors 3", "F: 0", "F: true", "F: 1", "F: true", "F: 2", "F: true"]
    assert json.loads(m.tree_json())["messages"] == m.messages
    assert len(m.parts) == 3  # print changes nothing else
    assert grammarkit.derive("Lot --> extrude(3) X.\n", lot=LOT).messages == []


def test_messages_past_the_limit_are_counted(monkeypatch):
    monkeypatch.setattr(engine, "MAX_MESSAGES", 2)
    m = grammarkit.derive(TEXT, lot=LOT)
    assert m.messages == ["Lot: floors 3", "F: 0", "... 5 more messages not kept"]


def test_print_of_a_list_value_is_an_error():
    with pytest.raises(DerivationError, match="print"):
        grammarkit.derive("Lot --> print(rect(1, 2)) X.\n", lot=LOT)


def test_grammarkit_derive_prints_the_messages(tmp_path):
    g = tmp_path / "p.grammar"
    g.write_text(TEXT)
    res = CliRunner().invoke(main, ["derive", str(g), "-o", str(tmp_path / "p.glb")])
    assert res.exit_code == 0, res.output
    assert "print: Lot: floors 3" in res.output and "print: F: 2" in res.output


def test_cga_print_is_translated():
    r = translate_cga('Lot --> print("a " + 3) extrude(3) X.\n', filename="t.cga")
    assert r.ok and 'print("a " + str(3))' in r.text
    assert all(c.status == "translated" for c in r.report.constructs)
    assert grammarkit.derive(r.grammar, lot=LOT).messages == ["Lot: a 3"]
