"""Recursive CGA functions become grammarkit functions (`func`) instead of being dropped; the
other functions stay inlined. Tested with the corpus's own recursive functions
(grammars/cga/Plant_Distributor.cga) and small CGA files: values computed while deriving."""
from __future__ import annotations

from pathlib import Path

import pytest
from _cga_helpers import LOT, imported, line

import grammarkit
from grammarkit.cga import translate_cga
from grammarkit.dsl import check, load, parse
from grammarkit.expr_eval import evaluate
from grammarkit.plugins import default_registries
from grammarkit.split.compile import compile_grammar

CORPUS = Path(__file__).resolve().parents[2] / "grammars" / "cga"


@pytest.fixture(scope="module")
def plants():
    return translate_cga(CORPUS / "Plant_Distributor.cga", missing_assets="drop")


def test_the_corpus_recursive_functions_are_translated(plants):
    warned = [c for c in plants.report.constructs if c.feature == "fn:recursive"]
    assert warned == []
    funcs = {f.name: f for f in plants.grammar.functions}
    assert set(funcs) == {"_genIdxList", "filterGenerics", "filterKeyword", "filterHeights", "filterZones",
                          "filterContinent", "filterCategory", "_getSum", "_getMix"}
    # CGA's `_genIdxList(n-1)+(n-1)+";"` joins text: the number is made text, as CGA does
    assert "func _genIdxList(n) = select(n > 0, _genIdxList(n - 1) + str(n - 1) + \";\", \"\")" in plants.text
    # _getMix has a 0-parameter overload that is not recursive: it stays inlined
    assert [len(f.params) for f in plants.grammar.functions if f.name == "_getMix"] == [1]
    assert [d for d in check(plants.grammar) if d.severity == "error"] == []


def test_the_corpus_recursive_functions_compute_cga_values(plants):
    g = plants.grammar
    values = compile_grammar(g, default_registries()).evaluate_values({}, 0)
    # const _idxAll = _genIdxList(Plant.nPlants): "0;1;...;126;" (127 plants)
    assert values["_idxAll"] == "".join(f"{i};" for i in range(127))
    functions = default_registries().functions

    def ev(text):
        return evaluate(parse(f"const x = {text}").consts[0].value, values, functions=functions,
                        user_functions=g.functions)
    generics = ev("filterGenerics(_idxAll)")
    names = values["Plant__dataCommonName"].split(";")
    kept = [int(i) for i in generics.split(";") if i]
    assert kept and kept == [i for i in range(127) if "Generic" not in names[i]]
    # _getSum adds the weights of a list of indices: with the default Mixture ("Large species
    # dominant") a plant's weight is the area of its circle, _circleArea(_radiusAvg(idx))
    assert values["Mixture"] == "Large species dominant"
    radius = [float(r) for r in values["Plant__dataRadiusAvg"].split(";") if r]
    want = sum(radius[i] * radius[i] * 3.14159265359 for i in (0, 5, 9))
    assert ev('_getSum("0;5;9;")') == pytest.approx(want, rel=1e-12)
    assert ev('_getSum("")') == 0


def test_the_corpus_file_derives_a_custom_mix(plants):
    model = grammarkit.derive(plants.grammar, seed=0, lot=LOT, attrs={"Mix": "Custom"})
    assert model is not None


CGA = """
version "2019.0"
attr floors = 4
fact(n) = case n <= 1: 1 else: n * fact(n - 1)
storeys(i) = case i <= 0: 0 else: 3 + storeys(i - 1)
storeys(i, h) = case i <= 0: 0 else: h + storeys(i - 1, h)
isEven(n) = case n == 0: true else: isOdd(n - 1)
isOdd(n) = case n == 0: false else: isEven(n - 1)
half(x) = x / 2
Lot --> extrude(storeys(floors, half(fact(3)))) Mass
Mass --> case isEven(floors): s(fact(3), '1, '1) Even. else: Odd.
"""


def test_recursive_cga_functions_derive_with_cga_values():
    result = imported(CGA)
    text = result.text
    assert "func fact(n) = select(n <= 1, 1, n * fact(n - 1))" in text
    assert "func storeys(i, h) = select(i <= 0, 0, h + storeys(i - 1, h))" in text
    assert "func isEven(n) = select(n == 0, true, isOdd(n - 1))" in text
    assert "half" not in text.split("Lot -->")[0]  # not recursive: inlined, as before
    assert "storeys(floors, fact(3) / 2)" in line(result, "Lot")
    assert not [c for c in result.report.constructs if c.status != "translated"]
    g = load(text)
    m = grammarkit.derive(g, seed=0, lot=LOT)
    lo, hi = m.mesh.bounds
    size = hi - lo
    # extrude(storeys(4, 3)) = 12 m; isEven(4): s(fact(3) = 6, ...) keeps 6 m of the 20 m lot
    assert size[2] == pytest.approx(12, abs=0.01)
    assert size[0] == pytest.approx(6, abs=0.01)
    assert [p.name for p in m.parts] == ["Even"]
    odd = grammarkit.derive(g, seed=0, lot=LOT, attrs={"floors": 3})
    assert [p.name for p in odd.parts] == ["Odd"]


def test_a_recursive_function_whose_body_does_not_translate_is_dropped_with_its_own_feature():
    result = translate_cga(CGA.replace("n * fact(n - 1)", "n * fact(n - 1) * assetInfo(\"x\", \"sx\")"),
                           filename="t.cga")
    fact = [c for c in result.report.constructs if c.kind == "function" and c.name == "fact"]
    assert fact[0].status == "dropped" and fact[0].feature == "fn:assetInfo"
    assert "func fact" not in result.text
