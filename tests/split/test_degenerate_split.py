"""split() on a shape with no extent along the axis: CGA makes no parts; a face split along
its own normal is a user error."""
from __future__ import annotations

import pytest

from grammarkit.errors import DerivationError
from grammarkit.split import derive


def test_the_sides_of_a_flat_volume_split_into_nothing_with_a_warning(G):
    # extrude(0) gives a volume 0 high: its sides have no height, split(y) has no parts
    m = derive(G("Lot --> footprint(rect(10, 6)) [ extrude(3) Mass. ] extrude(0) comp(f) { side: F }\n"
                 "F --> split(y) { 1: Floor. | ~1: Wall. }\n"))
    assert not [p for p in m.parts if p.name in ("Floor", "Wall")]
    assert [w for w in m.warnings if "size 0 along y" in w and "'F'" in w and "no parts" in w]
    assert m.mesh.is_watertight and m.mesh.volume == pytest.approx(180, rel=5e-3)


def test_a_face_split_along_its_normal_is_a_located_error(G):
    with pytest.raises(DerivationError) as e:
        derive(G("Lot --> footprint(rect(10, 6)) split(z) { 1: A. }\n"))
    assert "faces are flat" in str(e.value) and e.value.span.line == 1
