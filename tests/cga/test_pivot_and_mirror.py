"""r(scopeCenter, ...) turns about the scope's centre, and s() with a negative size mirrors
(CGA's s: "negative sizes result in mirroring along the corresponding axes")."""
from __future__ import annotations

import numpy as np
import pytest

import grammarkit
from grammarkit.cga import translate_cga

RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]


def _derive(text: str):
    result = translate_cga(text, filename="t.cga")
    assert result.ok, [d.message for d in result.diagnostics]
    model = grammarkit.derive(result.grammar, seed=0, lot=RECT, surfaces="cga")  # CGA's own geometry
    parts = [np.asarray(model.mesh.vertices).reshape(-1, 3)]
    if model.surface_vertices is not None:
        parts.append(np.asarray(model.surface_vertices).reshape(-1, 3))
    return result, np.vstack(parts)


@pytest.mark.parametrize("angles", ["30, 45, 10", "0, 90, 0", "-3, 0, 0", "0, 0, 180"])
def test_rotation_about_the_scope_centre_keeps_the_centre(angles):
    # the box x 0..2, y 6..12 (CGA's scope keeps its back), z 0..4: centre (1, 9, 2)
    res, v = _derive(f"Lot --> extrude(4) s(2, 4, 6) r(scopeCenter, {angles}) X.\n")
    assert not [d for d in res.diagnostics if d.severity == "warning"]
    assert np.allclose(v.mean(axis=0), (1.0, 9.0, 2.0), atol=1e-3)
    _, plain = _derive("Lot --> extrude(4) s(2, 4, 6) X.\n")
    # the same box turned: the same extents sorted (a right angle) or a larger box (others)
    assert np.ptp(v, axis=0).max() >= np.ptp(plain, axis=0).max() - 1e-3


def test_rotation_about_the_origin_and_computed_angles():
    _, v = _derive("Lot --> extrude(4) s(2, 4, 6) r(0, 90, 0) X.\n")
    assert not np.allclose(v.mean(axis=0), (1.0, 9.0, 2.0), atol=1e-2)  # about the origin
    res, _ = _derive("attr a = 30\nLot --> extrude(4) s(2, 4, 6) r(scopeCenter, a, 0, 0) X.\n")
    (w,) = [d for d in res.diagnostics if d.severity == "warning"]
    assert "derive time" in w.message and w.span.line == 2


@pytest.mark.parametrize("text, lo, hi", [
    # CGA's lot scope: z runs from the back (grammarkit y = 12) to the front: -3 is behind it
    ("Lot --> extrude(4) s('1, '1, -3) X.\n", (0, 12, 0), (20, 15, 4)),
    ("Lot --> extrude(4) s(-5, '1, '1) X.\n", (-5, 0, 0), (0, 12, 4)),
    # a facade's z is its outward normal: -0.5 goes into the building
    ("Lot --> extrude(4) comp(f) { front: F }\nF --> s('1, '1, -0.5) i(\"builtin:cube\") X.\n",
     (0, 0, 0), (20, 0.5, 4)),
])
def test_negative_sizes_mirror_to_the_other_side(text, lo, hi):
    res, v = _derive(text)
    (w,) = [d for d in res.diagnostics if d.severity == "warning"]
    assert "negative size" in w.message and w.code == "cga-approximated"
    assert np.allclose(v.min(axis=0), lo, atol=0.01) and np.allclose(v.max(axis=0), hi, atol=0.01)


def test_translate_rel_scope_is_t_and_cleanup_geometry_is_said():
    res, v = _derive("Lot --> extrude(4) s(2, '1, 6) translate(rel, scope, 1, '0.5, 2) "
                     "cleanupGeometry(all, 0.1) X.\n")
    _, w = _derive("Lot --> extrude(4) s(2, '1, 6) t(1, '0.5, 2) X.\n")
    assert np.allclose(v.min(axis=0), w.min(axis=0)) and np.allclose(v.max(axis=0), w.max(axis=0))
    (d,) = [d for d in res.diagnostics if d.severity == "warning"]
    assert d.message.startswith("approximated: cleanupGeometry(): nothing is done")
    res = translate_cga("Lot --> translate(abs, world, 0, 0, 0) X.\n", filename="a.cga")
    (d,) = [d for d in res.diagnostics if d.severity == "warning"]
    assert "translate(abs, world" in d.message and d.span.column == 9
