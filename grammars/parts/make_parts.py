"""Generate the part meshes that grammars insert with i("parts/NAME.glb").

Run: python grammars/parts/make_parts.py   (writes next to this script, atomically)

Parts are modelled in a unit-ish box with manifold3d; `i()` fits their bounding box to the
scope, so only proportions matter.
"""
from __future__ import annotations

from pathlib import Path

import manifold3d

from grammarkit.geometry.convert import to_trimesh
from grammarkit.geometry.exporters import export

M = manifold3d.Manifold
HERE = Path(__file__).resolve().parent


def chimney() -> manifold3d.Manifold:
    """A brick stack with a wider cap and two flue pots."""
    shaft = M.cube((1.0, 0.5, 3.0))
    cap = M.cube((1.16, 0.66, 0.18)).translate((-0.08, -0.08, 3.0))
    pots = [M.cylinder(0.35, 0.09, 0.07, 12).translate((x, 0.25, 3.18)) for x in (0.3, 0.7)]
    return M.batch_boolean([shaft, cap, *pots], manifold3d.OpType.Add)


def dormer() -> manifold3d.Manifold:
    """A small gabled dormer body (box + triangular prism)."""
    body = M.cube((1.0, 1.0, 1.0))
    tri = manifold3d.CrossSection([[[0.0, 0.0], [1.0, 0.0], [0.5, 0.5]]])
    roof = M.extrude(tri, 1.0).transform([[1, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 1.0]])
    return M.batch_boolean([body, roof], manifold3d.OpType.Add)


PARTS = {"chimney": chimney, "dormer": dormer}


def main() -> None:
    for name, build in PARTS.items():
        solid = build()
        assert solid.status() == manifold3d.Error.NoError, name
        path = export(to_trimesh(solid), HERE / f"{name}.glb")
        print(f"wrote {path} ({solid.num_tri()} triangles)")


if __name__ == "__main__":
    main()
