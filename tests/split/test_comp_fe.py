"""`comp(fe)`: CGA's face edges (grammarkit/split/comp_edges.py): each edge of each face as an
edge shape (an edge two faces share comes once per face), in comp(f)'s face order, y the
face's normal, with comp(e)'s selectors."""
from __future__ import annotations

import io
from collections import Counter

import pytest

import grammarkit
from grammarkit.errors import GrammarError

LOT = [(0.0, 0.0), (10.0, 0.0), (10.0, 6.0), (0.0, 6.0)]


def derive(text: str, lot=LOT):
    return grammarkit.derive(text, lot=lot, surfaces="cga")  # CGA's open faces


def test_face_edges_of_a_lot_follow_its_outline():
    m = derive("Lot --> comp(fe) { all: E. }\n")
    parts = [p for p in m.parts if p.name == "E"]
    assert [round(p.size[0], 9) for p in parts] == [10.0, 6.0, 10.0, 6.0]
    assert [p.origin for p in parts] == [pytest.approx(v) for v in
                                         [(0, 0, 0), (10, 0, 0), (10, 6, 0), (0, 6, 0)]]
    for p in parts:  # y is the lot's normal; z = x × y points out of the lot
        assert p.axes[1] == pytest.approx((0, 0, 1))
    assert parts[0].axes[2] == pytest.approx((0, -1, 0)) and parts[1].axes[2] == pytest.approx((1, 0, 0))


def test_a_box_gives_every_edge_once_per_face_in_comp_f_order():
    m = derive("Lot --> extrude(3) comp(fe) { 0: First. | top: T. | bottom: B. | side: S. | inside: I. }\n")
    got = Counter(p.name for p in m.parts)
    # 6 faces x 4 edges = 24 (comp(e) gives 12): bottom face first (edge 0, then 3 more),
    # the top face's 4 edges look up, the 4 side faces' 16 edges look sideways
    assert got == {"First": 1, "B": 3, "T": 4, "S": 16}
    assert len(derive("Lot --> extrude(3) comp(e) { all: E. }\n").parts) == 12
    idx = derive("Lot --> extrude(3) comp(fe) { all: E. }\n")
    assert [p.size[0] for p in idx.parts][:8] == pytest.approx([10, 6, 10, 6, 10, 6, 10, 6])
    assert sum(p.size[0] for p in idx.parts) == pytest.approx(2 * (4 * 10 + 4 * 6 + 4 * 3))


def test_roof_edge_selectors_and_index_selectors():
    m = derive("Lot --> extrude(3) comp(f) { top: roofGable(45) comp(fe) { ridge: R. | eave: V. | 3: X. | all: E. } }\n")
    got = Counter(p.name for p in m.parts)
    assert got["R"] == 2 and got["V"] == 4  # the ridge once for each roof plane
    ridge = [p for p in m.parts if p.name == "R"]
    assert all(p.size[0] == pytest.approx(10.0) for p in ridge)
    assert all(p.origin[2] == pytest.approx(6.0, abs=1e-6) for p in ridge)  # 3 m wall + 3 m roof


def test_fences_along_the_lot_edges_are_watertight():
    import trimesh

    from grammarkit.geometry.exporters import encode_glb

    m = derive("Lot --> comp(fe) { all: s(scope.sx, 0.2, 1) i(\"builtin:cube\") Fence. }\n")
    assert len([p for p in m.parts if p.name == "Fence"]) == 4
    loaded = trimesh.load(io.BytesIO(encode_glb(m)), file_type="glb")
    mesh = loaded.to_mesh() if isinstance(loaded, trimesh.Scene) else loaded
    mesh = trimesh.Trimesh(mesh.vertices, mesh.faces)
    assert mesh.is_watertight
    # each fence is 0.2 high (y: the lot's normal) and 1 deep on the outer side of its edge
    # (z points out of the lot), so neighbouring fences do not overlap: 2*(10+6) * 0.2 * 1
    assert m.manifold.volume() == pytest.approx(32 * 0.2 * 1.0, rel=0.02)


def test_bad_comp_mode_is_a_located_error():
    with pytest.raises(GrammarError) as e:
        derive("Lot --> comp(ef) { all: E. }\n")
    assert e.value.span is not None and e.value.span.line == 1
