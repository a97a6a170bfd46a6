"""The cheap sliver pre-check of the final union (grammarkit.split.union.may_have_slivers):
it must flag every shell the exact test (decompose + volume) would drop, and let ordinary
multi-shell buildings (windows, tiny but real pieces) through without manifold3d's decompose."""
from __future__ import annotations

import manifold3d
import numpy as np

from grammarkit.split import model, union

Manifold = manifold3d.Manifold


def _tet(height: float, at=(5.0, 0.0, 0.0), base: float = 1.0) -> Manifold:
    v = np.array([[0, 0, 0], [base, 0, 0], [0, base, 0], [0.3 * base, 0.3 * base, height]])
    v = (v + np.asarray(at)).astype(np.float32)
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]], dtype=np.uint32)
    return Manifold(manifold3d.Mesh(vert_properties=v, tri_verts=f))


def test_real_shells_are_not_suspects():
    body = Manifold.compose([Manifold.cube((1, 1, 1)), Manifold.cube((1, 1, 1)).translate((3, 0, 0)),
                             _tet(0.02)])  # a tiny real piece (a window's latch): 1e-3 m^3
    assert len(body.decompose()) == 3
    assert not union.may_have_slivers(body.to_mesh())
    assert model._drop_slivers(body) is body


def test_one_shell_is_never_a_suspect():
    assert not union.may_have_slivers(_tet(1e-7).to_mesh())


def test_a_sliver_is_suspected_and_dropped():
    # 1e-10 m^3, far from the origin (float32 positions)
    sliver = _tet(1.2e-5, at=(3.0, 2.0, 1.0), base=0.005)
    assert sliver.status() == manifold3d.Error.NoError and not sliver.is_empty()
    assert abs(sliver.volume()) < union.SLIVER_VOLUME
    body = Manifold.compose([Manifold.cube((2, 2, 2)), sliver])
    assert union.may_have_slivers(body.to_mesh())
    kept = model._drop_slivers(body)
    assert len(kept.decompose()) == 1
    assert abs(kept.volume() - 8.0) < 1e-6
