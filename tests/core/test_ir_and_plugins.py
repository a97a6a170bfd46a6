"""The IR contract (equality without spans, JSON round trip) and the plugin manager."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

import grammarkit.ir as ir
from grammarkit.hookspecs import hookimpl
from grammarkit.plugins import PluginManager
from grammarkit.registry import OperationSpec, Param


def _sample_grammar(line: int) -> ir.Grammar:
    span = ir.Span(file="a.grammar", line=line, column=1)
    body = ir.Seq(items=(
        ir.OpCall(name="split", args=(ir.Arg(value=ir.Ref(name="y")),), block=(
            ir.Branch(mode="float", key=ir.Num(value=3.2), body=ir.Seq(items=(ir.Successor(name="Floor"),))),
            ir.Repeat(items=(ir.Branch(key=ir.Num(value=1), body=ir.Seq(items=(ir.Terminal(name="W"),))),)),
        ), span=span),
        ir.Choice(arms=(ir.ChoiceArm(percent=ir.Num(value=30), body=ir.Seq(items=(ir.Nil(),))),),
                  otherwise=ir.Seq(items=(ir.Successor(name="B", args=(ir.Ref(name="split.index"),)),))),
    ))
    return ir.Grammar(name="g", statements=(
        ir.Attr(name="h", value=ir.Num(value=18), range=(ir.Num(value=9), ir.Num(value=40)), span=span),
        ir.Rule(name="Lot", body=body, span=span, comments=("# a comment",)),
        ir.PartDef(name="Wall", geometry=ir.Call(func="box", args=(ir.Num(value=4), ir.Num(value=1), ir.Num(value=3)))),
    ))


def test_equality_ignores_spans_and_comments():
    a, b = _sample_grammar(1), _sample_grammar(7)
    assert a == b and hash(a) == hash(b)
    c = a.model_copy(update={"name": "other"})
    assert c != a


def test_json_round_trip_keeps_spans():
    g = _sample_grammar(3)
    data = json.loads(g.model_dump_json())
    back = ir.Grammar.model_validate(data)
    assert back == g
    assert back.statements[1].span.line == 3


def test_ir_is_immutable():
    g = _sample_grammar(1)
    with pytest.raises(Exception):
        g.name = "x"  # type: ignore[misc]  # frozen: the assignment must fail


def test_family_and_typed_views():
    g = _sample_grammar(1)
    assert g.family == "tiling"  # a part makes it a tiling grammar
    assert [r.name for r in g.rules] == ["Lot"] and [a.name for a in g.attrs] == ["h"]


class _GoodPlugin:
    @hookimpl
    def grammarkit_operations(self):
        return [OperationSpec("twist", (Param("angle"),), doc="test op")]


class _BrokenPlugin:
    @hookimpl
    def grammarkit_operations(self):
        raise RuntimeError("boom")


def test_broken_plugin_is_reported_and_others_still_work():
    pm = PluginManager(load_entry_points=False)
    pm.register(_BrokenPlugin(), "broken")
    pm.register(_GoodPlugin(), "good")
    ops = pm.operations()
    assert "twist" in ops and ops["twist"].plugin == "good"
    infos = {i.name: i for i in pm.plugins()}
    assert not infos["broken"].ok and "boom" in infos["broken"].errors[0]
    assert infos["good"].provides["operation"] == ["twist"]


def test_duplicate_contribution_is_an_error_naming_both_and_pluggy_order_decides():
    # issue 8: hooks go through pluggy's call order (the later registered first, unless
    # tryfirst/trylast say otherwise); the clash is reported on both plugins
    pm = PluginManager(load_entry_points=False)
    pm.register(_GoodPlugin(), "first")
    pm.register(_GoodPlugin(), "second")
    assert pm.operations()["twist"].plugin == "second"
    infos = {i.name: i for i in pm.plugins()}
    assert any("also provided by plugin 'second'" in e for e in infos["first"].errors)
    assert any("also provided by plugin 'first'" in e for e in infos["second"].errors)


def test_builtin_features_come_from_entry_points():
    pm = PluginManager()
    names = {i.name for i in pm.plugins()}
    assert {"core-functions", "split-operations"} <= names
    assert pm.operations()["split"].plugin == "split-operations"
    assert pm.functions()["rand"].plugin == "core-functions"


def test_cli_help_runs():
    out = subprocess.run([sys.executable, "-m", "grammarkit.cli", "--help"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "check" in out.stdout
