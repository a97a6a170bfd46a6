"""CGA scatter -> grammarkit: the `{ Rule }` block, means per frame, relative and absolute
stddevs, and the imported rule deriving points where CGA's would."""
from __future__ import annotations

import numpy as np

import grammarkit
from grammarkit.cga import translate_cga
from _cga_helpers import imported, line, LOT  # noqa: E402  (tests/cga/conftest.py)


def test_scatter_of_a_rule_and_of_a_call_with_arguments():
    r = imported("Lot --> scatter(surface, 12, uniform) { Tree(2) }\n"
                 "Tree(h) --> s(0.5, h, 0.5) center(xz) primitiveCube() Trunk.\n")
    assert line(r, "Lot") == "Lot --> scatter(surface, 12, uniform) { all: Tree(2) }"
    assert not [c for c in r.report.constructs if c.status != "translated"]
    m = grammarkit.derive(r.grammar, lot=LOT, seed=1)
    trunks = [p for p in m.parts if p.name == "Trunk"]
    assert len(trunks) == 12
    # CGA's point y (up, the surface normal) is grammarkit's z: trunks stand 2 m tall on the lot
    assert all(abs(p.size[2] - 2.0) < 1e-9 for p in trunks)
    assert m.mesh.is_watertight


def test_a_bare_name_block_and_gaussian_arguments():
    r = imported("Lot --> scatter(surface, 50, gaussian, left, '0.1) { Leaf }\n")
    assert line(r, "Lot") == "Lot --> scatter(surface, 50, gaussian, left, 0.1) { all: Leaf. }"
    p = np.array([q.origin for q in grammarkit.derive(r.grammar, lot=LOT, surfaces="cga").parts if q.name == "Leaf"])
    assert len(p) == 50 and p[:, 0].mean() < 3.0


def test_an_absolute_stddev_is_approximated_and_a_face_mean_is_mapped():
    r = imported("Lot --> extrude(8) comp(f) { front: F }\nF --> scatter(surface, 5, gaussian, top, 2) { Leaf }\n")
    assert "scatter(surface, 5, gaussian, back, 2 / max(" in line(r, "F")
    assert {c.feature for c in r.report.constructs if c.status == "approximated"} == {"scatter:stddev"}
    # the points are all CGA shows (no geometry): the surfaces mode that emits them as they are
    # (the default mode keeps no solid for the consumed volume, since no surviving face spans it)
    grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")


def test_a_scatter_block_with_selectors_is_reported():
    r = translate_cga("Lot --> scatter(surface, 5, uniform) { all: Leaf }\n", filename="t.cga")
    assert any(c.feature == "scatter:block" for c in r.report.constructs)
