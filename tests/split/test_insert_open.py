"""`i()` of open meshes (surface parts), built-in primitives, and CGA's trim planes."""
from __future__ import annotations

from functools import partial

import numpy as np
import pytest
import trimesh

from grammarkit.geometry.convert import mesh_report
from grammarkit.split import derive as _derive
from grammarkit.split.assets import BUILTINS

# These tests pin CGA's open-face semantics (`surfaces="cga"`); the default, one watertight
# solid, is tested in test_cga_solid.py.
derive = partial(_derive, surfaces="cga")


@pytest.fixture
def open_box(tmp_path):
    """A box without its top: 10 triangles, 4 boundary edges (not a closed solid)."""
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    up = box.face_normals[:, 2] > 0.5
    mesh = trimesh.Trimesh(box.vertices, box.faces[~up], process=False)
    assert not mesh.is_watertight
    path = tmp_path / "open.obj"
    mesh.export(path)
    return path.as_posix()


def surface_names(model):
    return sorted({model.tags[t].name for t in model.surface_tags.tolist()})


def test_an_open_mesh_is_inserted_as_a_surface_part(G, open_box):
    m = derive(G(f'Lot --> footprint(rect(8, 6)) extrude(3) comp(f) {{ top: s(4, 2, 1) '
                 f'i("{open_box}") Planter. | volume: Mass. }}'))
    # the mass stays one watertight solid, the open asset is beside it in the surface layer
    assert mesh_report(m.mesh).watertight
    assert surface_names(m) == ["Planter"] and len(m.surface_faces) == 10
    V = m.surface_vertices
    assert V.min(axis=0) == pytest.approx((0, 0, 3)) and V.max(axis=0) == pytest.approx((4, 2, 4))
    # a split trims the open mesh like a solid (no caps: it stays open)
    m = derive(G(f'Lot --> footprint(rect(4, 2)) extrude(1) i("{open_box}") split(x) {{ 1: A. | ~1: B. }}'))
    assert surface_names(m) == ["A", "B"]
    a = [k for k, t in enumerate(m.surface_tags.tolist()) if m.tags[t].name == "A"]
    assert m.surface_vertices[m.surface_faces[a]].reshape(-1, 3)[:, 0].max() == pytest.approx(1.0)


def test_comp_of_an_open_mesh_gives_its_faces(G, open_box):
    m = derive(G(f'Lot --> footprint(rect(2, 1)) extrude(1) i("{open_box}") comp(f) {{ side: S. | bottom: B. }}'))
    assert sorted(p.name for p in m.parts) == ["B", "S", "S", "S", "S"]
    assert len(m.mesh.faces) == 0


@pytest.mark.parametrize("name", [b for b in BUILTINS])
def test_builtin_primitives_fill_the_scope(G, name):
    m = derive(G(f'Lot --> footprint(rect(4, 2)) extrude(3) i("builtin:{name}") A.'))
    if name in ("quad", "disk"):  # open: surfaces
        assert len(m.mesh.faces) == 0 and surface_names(m) == ["A"]
        lo, hi = m.surface_vertices.min(axis=0), m.surface_vertices.max(axis=0)
        assert lo == pytest.approx((0, 0, 0)) and hi == pytest.approx((4, 2, 0))
        return
    rep = mesh_report(m.mesh)
    assert rep.watertight and rep.manifold
    lo, hi = m.mesh.bounds
    assert lo == pytest.approx((0, 0, 0), abs=2e-3) and hi == pytest.approx((4, 2, 3), abs=2e-3)
    volume = {"cube": 24.0, "cube:notex": 24.0, "cylinder": np.pi * 2 * 1 * 3, "cylinder:y": np.pi * 2 * 1.5 * 2,
              "cone": np.pi * 2 * 1 * 3 / 3, "sphere": 4 / 3 * np.pi * 2 * 1 * 1.5}[name]
    assert rep.volume == pytest.approx(volume, rel=0.05)  # polygonal circles are a bit smaller


def test_unknown_builtin_is_a_located_error(G):
    from grammarkit.errors import DerivationError

    with pytest.raises(DerivationError) as e:
        derive(G('Lot --> footprint(rect(4, 2)) extrude(3) i("builtin:cubee") A.'))
    assert "unknown built-in primitive 'builtin:cubee'" in str(e.value) and e.value.span.line == 1


def test_trim_planes_mitre_inserts_at_the_corners(G):
    # a cornice 1 m deep, 1 m longer than the facade at each end: CGA's trim planes (the
    # bisectors with the neighbouring faces) cut it at 45 degrees at both corners
    cornice = 'comp(f) { front: t(-1, 0, 0) s(scope.sx + 2, 0.5, 1) i("builtin:cube") C. }'
    m = derive(G(f"Lot --> footprint(rect(4, 2)) extrude(3) {cornice}"))
    rep = mesh_report(m.mesh)
    assert rep.watertight and rep.volume == pytest.approx(0.5 * (4 + 1), rel=0.01)  # not 0.5 * 6
    # on the front face of a footprint the same cube, kept inside the facade, is not cut
    m = derive(G('Lot --> footprint(rect(4, 2)) extrude(3) comp(f) { front: s(scope.sx, 0.5, 1) '
                 'i("builtin:cube") C. }'))
    assert mesh_report(m.mesh).volume == pytest.approx(0.5 * 4, rel=0.01)
    # the four mitred cornices of all sides meet without overlapping: a closed frame
    m = derive(G("Lot --> footprint(rect(4, 2)) extrude(3) "
                 "comp(f) { side: t(-1, 0, 0) s(scope.sx + 2, 0.5, 1) i(\"builtin:cube\") C. }"))
    rep = mesh_report(m.mesh)
    assert rep.watertight and rep.volume == pytest.approx(0.5 * (6 * 4 - 4 * 2), rel=0.01)
    assert rep.euler_number == 0  # one ring (a torus), not four overlapping blocks


def test_trim_false_turns_the_trim_planes_off(G):
    cornice = 'comp(f) { front: trim(false) t(-1, 0, 0) s(scope.sx + 2, 0.5, 1) i("builtin:cube") C. }'
    m = derive(G(f"Lot --> footprint(rect(4, 2)) extrude(3) {cornice}"))
    assert mesh_report(m.mesh).volume == pytest.approx(0.5 * 6, rel=0.01)  # the whole cube
