"""comp(e), comp(v) and comp.sel (grammarkit/split/comp_edges.py): which components a shape
has, their scopes, CGA's selectors (orientation, border/inside, roof edges) and comp.sel."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.errors import GrammarError

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.

def derive_cga(*args, **kw):
    return grammarkit.derive(*args, surfaces="cga", **kw)


LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]
ELL = [(0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (8.0, 8.0), (8.0, 16.0), (0.0, 16.0)]


def count(model, *names):
    return {n: sum(1 for p in model.parts if p.name == n) for n in names}


def test_a_box_has_twelve_edges_and_eight_vertices():
    m = derive_cga("Lot --> extrude(6) comp(e) { vertical: V. | aslant: T. | nutant: B. }\n", lot=LOT)
    # a vertical corner's normal is horizontal (the mean of its two walls'); a top edge's points
    # up at 45 degrees (wall and roof), a bottom edge's down (CGA's component ranges)
    assert count(m, "V", "T", "B") == {"V": 4, "T": 4, "B": 4}
    lengths = sorted(round(p.size[0], 6) for p in m.parts)
    assert lengths == [6.0] * 4 + [16.0] * 4 + [20.0] * 4
    m = derive_cga("Lot --> extrude(6) comp(v) { aslant: T. | nutant: B. }\n", lot=LOT)
    assert count(m, "T", "B") == {"T": 4, "B": 4}
    assert all(p.size == (0.0, 0.0, 0.0) for p in m.parts)


def test_edges_of_a_face_are_its_outline_and_border():
    m = derive_cga('Lot --> comp(e) { border: report("len", scope.sx) E. }\n', lot=ELL)
    assert m.reports["len"]["n"] == 6 and m.reports["len"]["sum"] == pytest.approx(72.0)
    m = derive_cga("Lot --> comp(v) { inside: I. | border: B. }\n", lot=ELL)
    assert count(m, "I", "B") == {"I": 0, "B": 6}


def test_pipes_along_vertical_edges_are_solids():
    m = derive_cga("Lot --> extrude(6) comp(e) { vertical: s(scope.sx, 0.4, 0.4) center(yz) Pipe. }\n",
                          lot=LOT)
    assert count(m, "Pipe") == {"Pipe": 4}
    assert all(p.size == pytest.approx((6.0, 0.4, 0.4)) for p in m.parts)
    assert m.mesh.is_watertight and m.manifold.volume() == pytest.approx(4 * 6 * 0.16, rel=0.05)


def test_roof_edges():
    text = ("Lot --> extrude(6) comp(f) { top: {roof} comp(e) { ridge: R. | eave: E. | hip: H. "
            "| valley: V. | all: O. } }\n")
    m = derive_cga(text.replace("{roof}", "roofHip(30)"), lot=LOT)
    assert count(m, "R", "E", "H", "V") == {"R": 1, "E": 4, "H": 4, "V": 0}
    m = derive_cga(text.replace("{roof}", "roofGable(30)"), lot=LOT)
    assert count(m, "R", "E", "H", "V") == {"R": 1, "E": 2, "H": 0, "V": 0}
    m = derive_cga(text.replace("{roof}", "roofHip(30)"), lot=ELL)
    assert count(m, "V")["V"] >= 1  # the L's inner corner


def test_comp_sel_names_the_branch():
    m = derive_cga('Lot --> extrude(5) comp(f) { left: S | right: S | 2: S | all: NIL }\n'
                          'S --> report(comp.sel, comp.index) W.\n', lot=LOT)
    assert set(m.reports) == {"left", "right", "2"}
    assert m.reports["2"]["sum"] == 2


def test_an_unknown_component_is_an_error():
    with pytest.raises(GrammarError, match="comp"):
        derive_cga("Lot --> comp(g) { all: X. }\n")
