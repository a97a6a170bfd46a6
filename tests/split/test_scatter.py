"""CGA's scatter (grammarkit/split/scatter.py): point shapes on a face, on a volume's surface,
in a volume and in the scope; uniform and gaussian; counts, domains, normals, determinism."""
from __future__ import annotations

import numpy as np
import pytest

import grammarkit
from grammarkit.errors import DerivationError, GrammarError

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.

def derive_cga(*args, **kw):
    return grammarkit.derive(*args, surfaces="cga", **kw)


RECT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]
ELL = [(0.0, 0.0), (20.0, 0.0), (20.0, 8.0), (8.0, 8.0), (8.0, 16.0), (0.0, 16.0)]


def points(text: str, lot=RECT, seed: int = 0, name: str = "P") -> tuple[np.ndarray, list]:
    m = derive_cga(text, lot=lot, seed=seed)
    parts = [p for p in m.parts if p.name == name]
    return np.array([p.origin for p in parts]), parts


def test_uniform_points_on_a_face_lie_in_it_and_cover_it():
    p, parts = points("Lot --> scatter(surface, 400, uniform) { all: P. }\n", lot=ELL)
    assert len(p) == 400
    assert np.allclose(p[:, 2], 0.0)
    # inside the L: not in the notch x > 8, y > 8
    assert not np.any((p[:, 0] > 8 + 1e-9) & (p[:, 1] > 8 + 1e-9))
    assert p[:, 0].min() >= -1e-9 and p[:, 0].max() <= 20 + 1e-9 and p[:, 1].min() >= -1e-9
    # area-weighted: the L is 160 + 64 = 224 m2, the wing x < 8, y > 8 is 64 of it
    share = np.mean((p[:, 0] < 8) & (p[:, 1] > 8))
    assert share == pytest.approx(64 / 224, abs=0.07)
    assert all(q.size == (0.0, 0.0, 0.0) for q in parts)


def test_the_same_seed_gives_the_same_points_and_another_seed_others():
    text = "Lot --> scatter(surface, 30, uniform) { all: P. }\n"
    a, _ = points(text, seed=3)
    b, _ = points(text, seed=3)
    c, _ = points(text, seed=4)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


def test_gaussian_points_cluster_about_the_mean():
    p, _ = points("Lot --> scatter(surface, 600, gaussian) { all: P. }\n")
    assert np.allclose(p[:, 2], 0.0)
    assert p[:, 0].mean() == pytest.approx(10.0, abs=0.5) and p[:, 1].mean() == pytest.approx(8.0, abs=0.5)
    # CGA's default stddev '0.16: 0.16 * 20 = 3.2 m along x (a little less: draws are kept in the lot)
    assert 2.6 < p[:, 0].std() < 3.4
    left, _ = points("Lot --> scatter(surface, 400, gaussian, left, 0.1) { all: P. }\n")
    assert left[:, 0].min() >= -1e-9  # rejected outside the face
    assert left[:, 0].mean() < 2.5 and left[:, 1].mean() == pytest.approx(8.0, abs=0.5)


def test_surface_of_a_volume_puts_points_on_its_faces_with_z_along_the_normal():
    p, parts = points("Lot --> extrude(10) scatter(surface, 300, uniform) { all: P. }\n")
    on_face = (np.isclose(p[:, 0], 0) | np.isclose(p[:, 0], 20) | np.isclose(p[:, 1], 0)
               | np.isclose(p[:, 1], 16) | np.isclose(p[:, 2], 0) | np.isclose(p[:, 2], 10))
    assert on_face.all()
    for q, part in zip(p, parts):
        z = np.array(part.axes[2])
        if np.isclose(q[2], 10) and not (np.isclose(q[0], 0) or np.isclose(q[0], 20)
                                         or np.isclose(q[1], 0) or np.isclose(q[1], 16)):
            assert np.allclose(z, (0, 0, 1))  # on the roof: up
        if np.isclose(q[0], 20) and 0 < q[2] < 10 and 0 < q[1] < 16:
            assert np.allclose(z, (1, 0, 0))  # on the right wall: +x


def test_volume_and_scope_domains_fill_the_box():
    p, parts = points("Lot --> extrude(10) scatter(volume, 200, uniform) { all: P. }\n")
    assert len(p) == 200
    assert (p >= -1e-9).all() and (p <= np.array([20, 16, 10]) + 1e-9).all()
    assert p[:, 2].std() > 2.0  # spread through the height, not on a face
    assert all(np.allclose(q.axes, np.eye(3)) for q in parts)  # the points keep the shape's axes
    s, _ = points("Lot --> extrude(10) scatter(scope, 50, uniform) { all: P. }\n")
    assert len(s) == 50 and (s <= np.array([20, 16, 10]) + 1e-9).all()


def test_volume_of_a_face_falls_back_to_its_surface():
    p, _ = points("Lot --> scatter(volume, 40, uniform) { all: P. }\n")
    assert len(p) == 40 and np.allclose(p[:, 2], 0.0)


def test_counts_round_and_zero_makes_nothing():
    p, _ = points("Lot --> [ scatter(surface, 2.6, uniform) { all: P. } ] Ground.\n")
    assert len(p) == 3
    p, _ = points("Lot --> [ scatter(surface, 0, uniform) { all: P. } ] Ground.\n")
    assert len(p) == 0


def test_scattered_inserts_are_a_watertight_model():
    m = derive_cga("Lot --> scatter(surface, 25, uniform) { all: Tree }\n"
                          "Tree --> s(0.4, 0.4, 3) center(xy) i(\"builtin:cylinder\") Trunk.\n", lot=RECT, seed=2)
    assert sum(p.name == "Trunk" for p in m.parts) == 25
    assert m.mesh.is_watertight


def test_bad_scatter_arguments_are_located_errors():
    with pytest.raises(GrammarError, match="surface.volume.scope"):
        derive_cga("Lot --> scatter(everywhere, 3, uniform) { all: P. }\n", lot=RECT)
    with pytest.raises(GrammarError, match="selector"):
        derive_cga("Lot --> scatter(surface, 3, uniform) { top: P. }\n", lot=RECT)
    with pytest.raises(DerivationError, match="scatter"):
        derive_cga("Lot --> scatter(surface, 1e9, uniform) { all: P. }\n", lot=RECT)
