"""Issue 27's speed switches change time, not output: each corpus rule package derived with a
switch on and off gives the same mesh byte for byte (and, in the default mode, watertight).
The switches stay so that benchmarks/bench_prt.py --prior can time the code before them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grammarkit.split import closings, derive

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted((ROOT / "grammars" / "cga" / "packages").glob("*.rpk"))
LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]


@pytest.fixture
def imported(cga_packages):
    return cga_packages


def _mesh_bytes(model) -> tuple:
    mesh = model.mesh
    return (
        np.asarray(mesh.vertices).tobytes(),
        np.asarray(mesh.faces).tobytes(),
        tuple(model.triangle_tags.tolist())
        if hasattr(model.triangle_tags, "tolist")
        else tuple(model.triangle_tags),
    )


@pytest.mark.parametrize("package", [p.stem for p in PACKAGES])
def test_numpy_reach_gives_the_same_model(imported, package, monkeypatch):
    monkeypatch.setattr(closings, "NUMPY_REACH", False)
    before = derive(imported[package], lot=LOT)
    monkeypatch.setattr(closings, "NUMPY_REACH", True)
    # the arrays even for a package of one volume
    monkeypatch.setattr(closings, "NUMPY_REACH_MIN", 0)
    after = derive(imported[package], lot=LOT)
    assert _mesh_bytes(before) == _mesh_bytes(after)
    assert after.mesh.is_watertight and after.mesh.is_winding_consistent


def test_numpy_reach_matches_the_loops_on_tilted_frames():
    """The two reach computations on made-up terminals and closings in rotated frames."""
    rng = np.random.default_rng(3)

    def frame():
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        return tuple(map(float, rng.normal(size=3) * 5)), tuple(
            tuple(map(float, r)) for r in q
        )

    class Ctx:
        pass

    ctx = Ctx()
    closing_frames = {10 + i: frame() for i in range(4)}
    by_node = {
        n: (n, n, i, (o, ax, (3.0, 2.0, 1.0)))
        for i, (n, (o, ax)) in enumerate(closing_frames.items())
    }
    ctx.leaves, ctx.tags = [], {}
    for t in range(30):
        o, ax = frame()
        ctx.leaves.append((t, o, ax, tuple(map(float, rng.uniform(0, 4, size=3)))))
        ctx.tags[t] = (None,) * 5 + (t,)
    above = {t: tuple(n for n in by_node if (t + n) % 3) for t in range(30)}
    python = closings._reach_python(ctx, by_node, above.__getitem__)
    numpy_ = closings._reach_numpy(ctx, by_node, above.__getitem__)
    assert python.keys() == numpy_.keys() and len(python) == 4
    for n in python:
        assert np.allclose(python[n], numpy_[n], rtol=0, atol=1e-12)


def test_numpy_inner_rectangle_gives_the_same_rectangles(monkeypatch):
    """innerRectangle's candidates from arrays: the same largest rectangle as the loops, on
    rectilinear lots (ties between equal areas included) and random star polygons, turned."""
    import math

    from grammarkit.split.ops import lots

    rng = np.random.default_rng(7)
    faces = [
        (((0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)),),
        (((0.0, 0.0), (20.0, 0.0), (20.0, 5.0), (8.0, 5.0), (8.0, 12.0), (0.0, 12.0)),),
        (
            (
                (0.0, 0.0),
                (10.0, 0.0),
                (10.0, 4.0),
                (6.0, 4.0),
                (6.0, 8.0),
                (4.0, 8.0),
                (4.0, 4.0),
                (0.0, 4.0),
            ),
        ),
    ]
    for _ in range(4):
        n = int(rng.integers(5, 10))
        ang, r = np.sort(rng.uniform(0, 2 * math.pi, n)), rng.uniform(3, 10, n)
        faces.append(
            (
                tuple(
                    (float(r[i] * math.cos(ang[i])), float(r[i] * math.sin(ang[i])))
                    for i in range(n)
                ),
            )
        )
    for face in faces:
        for c, sn in ((1.0, 0.0), (math.cos(0.3), math.sin(0.3))):
            monkeypatch.setattr(lots, "NUMPY_INNER_RECTANGLE", False)
            loops = lots.largest_rectangle(face, c, sn)
            monkeypatch.setattr(lots, "NUMPY_INNER_RECTANGLE", True)
            assert lots.largest_rectangle(face, c, sn) == loops
            assert loops is not None
