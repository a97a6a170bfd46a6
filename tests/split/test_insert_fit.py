"""`i(path, fit=NAME)`: the asset is handed to a fit from the registry (issue 8)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grammarkit import hookimpl
from grammarkit.dsl import check
from grammarkit.errors import GrammarError, ShapeError
from grammarkit.geometry.convert import mesh_report
from grammarkit.plugins import get_plugin_manager
from grammarkit.registry import FitSpec
from grammarkit.split import derive

PART = (Path(__file__).resolve().parents[2] / "grammars" / "parts" / "chimney.glb").as_posix()


def text(fit: str = "") -> str:
    arg = f", fit={fit}" if fit else ""
    return f'Lot --> footprint(rect(2, 3)) extrude(4) i("{PART}"{arg}) Chimney.\n'


calls = []


def squash(mesh, size):
    """Fill the scope in x and y, half its height; records what it was given."""
    calls.append((tuple(float(v) for v in mesh.bounds[0]), tuple(size)))
    out = mesh.copy()
    ext = out.extents
    out.apply_transform(np.diag([size[0] / ext[0], size[1] / ext[1], size[2] / 2 / ext[2], 1.0]))
    return out


def broken(mesh, size):
    return "not a mesh"


class Fits:
    @hookimpl
    def grammarkit_insert_fits(self):
        return [FitSpec("squash", "half height", squash), FitSpec("broken", "returns junk", broken)]


@pytest.fixture
def fits():
    pm = get_plugin_manager()
    pm.register(Fits(), "fit-fixture")
    calls.clear()
    yield
    pm.unregister("fit-fixture")


def test_default_fit_is_scale_and_unchanged():
    a, b = derive(text()), derive(text("scale"))
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.parts[0].size == pytest.approx((2.0, 3.0, 4.0), abs=1e-6)


def test_a_registered_fit_gets_the_normalised_asset_and_the_scope_size(fits):
    m = derive(text("squash"))
    lo, size = calls[0]
    assert lo == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)  # min corner at the origin
    assert size == pytest.approx((2.0, 3.0, 4.0))
    assert m.parts[0].size == pytest.approx((2.0, 3.0, 2.0), abs=1e-6)
    rep = mesh_report(m.mesh)
    assert rep.watertight and rep.manifold
    assert m.mesh.bounds[1][2] == pytest.approx(2.0, abs=3e-3)


def test_unknown_fits_are_check_errors_listing_the_known_ones(fits):
    d = [x for x in check(text("squeeze")) if x.severity == "error"]
    assert len(d) == 1 and d[0].message == "unknown fit 'squeeze' (argument 'fit' of i)"
    assert "squash" in d[0].hint and "scale" in d[0].hint
    with pytest.raises(GrammarError, match="unknown fit 'squeeze'"):
        derive(text("squeeze"))


def test_a_fit_returning_junk_is_a_located_error(fits):
    with pytest.raises(ShapeError) as info:
        derive(text("broken"))
    assert info.value.span is not None and info.value.span.line == 1
    assert "fitted by 'broken' (plugin fit-fixture): expected a triangle mesh, got str" in str(info.value)
