"""Resource guards end runaway grammars quickly with a LimitError (or a located error) naming
the rule: repeats, recursion, huge sizes, huge integer powers."""
from __future__ import annotations

import time

import pytest

import grammarkit
from grammarkit.errors import DerivationError, GrammarError, GrammarkitError, LimitError, ShapeError
from grammarkit.split import Limits

FACADE_1KM = """Lot --> s(1000, 10, 0) extrude(10) comp(f) { side: F | top: NIL | bottom: NIL }
F --> split(x) { { 0.0001: A. }* }
"""


@pytest.mark.parametrize("text,rule,words", [
    (FACADE_1KM, "F", "repeat limit"),
    ("A --> A\n", "A", "depth limit"),
    ("A --> t(0, 0, 1) A B\n", "A", "depth limit"),
    ("Lot --> extrude(1e9) X.\n", "Lot", "extent limit"),
    ("Lot --> extrude(1e300) X.\n", "Lot", "extent limit"),
    ("Lot --> extrude(10) s(1e300, 3, 3) X.\n", "Lot", "extent limit"),
    ("Lot --> footprint(rect(1e200, 2)) extrude(3) X.\n", "Lot", "extent limit"),
    ("Lot --> extrude(10) comp(f) { top: R | side: W. | bottom: NIL }\nR --> roofHip(30, overhang=1e9) X.\n",
     "R", "extent limit"),
    ("Lot --> extrude(1e9) split(z) { {~3: F.}* }\n", "Lot", "repeat limit"),
])
def test_runaway_grammars_stop_with_a_limit_error(text, rule, words):
    t0 = time.perf_counter()
    with pytest.raises(LimitError) as info:
        grammarkit.derive(text)
    assert time.perf_counter() - t0 < 10
    msg = info.value.format()
    assert words in msg and repr(rule) in msg, msg
    assert info.value.span is not None and info.value.span.line >= 1


# Constant expressions that cannot be evaluated are caught by `check` (issue 8), so deriving the
# text fails with the GrammarError of loading it; with a rule parameter the derivation fails.
@pytest.mark.parametrize("expr", ["9 ^ 9 ^ 9", "2 ^ (2 ^ 40)", "10 ^ 1000"])
def test_huge_powers_fail_fast(expr):
    t0 = time.perf_counter()
    with pytest.raises(GrammarError) as info:
        grammarkit.derive(f"Lot --> extrude({expr}) X.\n")
    assert time.perf_counter() - t0 < 5
    assert info.value.span is not None and info.value.span.line == 1
    first, rest = expr.split(" ", 1)  # the same power with its base a rule parameter
    with pytest.raises(DerivationError) as info:
        grammarkit.derive(f"Lot --> A({first})\nA(n) --> extrude(n {rest}) X.\n")
    assert time.perf_counter() - t0 < 10
    assert info.value.span is not None and info.value.span.line == 2


def test_power_with_a_complex_result_is_an_error():
    with pytest.raises(GrammarError, match="not a real number"):
        grammarkit.derive("Lot --> extrude((-8) ^ 0.5) X.\n")
    with pytest.raises(DerivationError, match="not a real number"):
        grammarkit.derive("Lot --> A(-8)\nA(n) --> extrude(n ^ 0.5) X.\n")


def test_max_extent_is_a_limit_the_caller_can_set():
    m = grammarkit.derive("Lot --> extrude(50) X.\n")
    assert m.triangle_count == 12
    with pytest.raises(LimitError, match="extent"):
        grammarkit.derive("Lot --> extrude(50) X.\n", limits=Limits(max_extent=20))
    with pytest.raises(GrammarkitError, match="max_extent"):
        Limits(max_extent=float("nan"))


def test_insert_of_a_non_mesh_file_is_located_at_the_operation(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("hello")
    g = tmp_path / "ins.grammar"
    g.write_text(f'Lot --> extrude(10) i("{bad.as_posix()}") X.\n')
    with pytest.raises(ShapeError) as info:
        grammarkit.derive(g)
    span = info.value.span
    assert span is not None and span.line == 1 and span.column == 21, info.value.format()
    assert "notes.txt" in str(info.value) and "'Lot'" in str(info.value)


def test_too_many_solids_stop_before_the_boolean():
    # 150 x 150 boxes: under the shape and repeat limits, but a union that would take minutes
    text = "Lot --> extrude(10) split(x) { { 0.066: A }* }\nA --> split(y) { { 0.066: B. }* }\n"
    t0 = time.perf_counter()
    with pytest.raises(LimitError, match="solid limit") as info:
        grammarkit.derive(text, limits=Limits(max_solids=2_000))
    assert time.perf_counter() - t0 < 10
    assert "'A'" in str(info.value) and info.value.span.line == 2


def test_inserted_meshes_count_towards_the_triangle_limit(tmp_path):
    import trimesh

    trimesh.creation.icosphere(subdivisions=3).export(tmp_path / "ball.glb")  # 1,280 triangles
    g = tmp_path / "balls.grammar"
    g.write_text('Lot --> extrude(10) split(x) { { 0.1: i("ball.glb") B. }* }\n')
    t0 = time.perf_counter()
    with pytest.raises(LimitError, match="triangle limit") as info:
        grammarkit.derive(g, limits=Limits(max_triangles=50_000))
    assert time.perf_counter() - t0 < 10
    assert "'Lot'" in str(info.value) and info.value.span.line == 1
