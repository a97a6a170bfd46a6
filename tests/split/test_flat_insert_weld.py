"""A flat open asset whose flat axis is float noise (1e-9 m, as the quads of a public rule
set's glTF shutters are) inserted in the default mode: the slab it is closed into stays where
the asset is, not grown by the weld's factor (size + 2 mm) / size (13 km before; issue 26)."""
from __future__ import annotations

import numpy as np

import grammarkit


def test_a_flat_insert_with_noise_thickness_stays_in_place(tmp_path):
    obj = tmp_path / "pane.obj"
    obj.write_text("v 0 0 0.37052780100\nv 1 0 0.37052780100\nv 1 1 0.37052780348\nv 0 1 0.37052780348\n"
                   "f 1 2 3\nf 1 3 4\n", encoding="utf-8")
    g = ("Lot --> extrude(5) comp(f) { front: F | side: W. }\n"
         f'F --> s(4, 2, 0) t(1, 1, 0) i("{obj.as_posix()}") Pane.\n')
    for mode in ("solid", "cga"):
        m = grammarkit.derive(g, lot=[(0, 0), (20, 0), (20, 12), (0, 12)], surfaces=mode)
        v = np.vstack([m.mesh.vertices] + ([m.surface_vertices] if m.surface_triangle_count else []))
        assert np.abs(v).max() < 25, mode
        if mode == "solid":
            assert m.mesh.is_watertight
