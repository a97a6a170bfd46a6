"""CGA texturing -> grammarkit: setupProjection per frame (a lot's y-up scope, a face's scope,
world axes), `~`/`'` texture sizes, projectUV and the UV operations, texture() and
set(material.*), and that the imported projections give the UVs CityEngine's would."""
from __future__ import annotations

import numpy as np

import grammarkit
from grammarkit.cga import translate_cga
from _cga_helpers import imported, line, LOT  # noqa: E402  (tests/cga/conftest.py)


def test_face_projection_sizes_floating_and_relative():
    r = imported("Lot --> extrude(9) comp(f) { side: F }\n"
                 "F --> setupProjection(0, scope.xy, ~2, '0.5) projectUV(0) texture(\"b.jpg\") X.\n")
    text = line(r, "F")
    assert ("setupProjection(0, scope.xy, scope.sx / max(1, round(scope.sx / 2)), 0.5 * scope.sy) "
            "projectUV(0) texture(\"b.jpg\")") in text
    assert r.report.warned == 0
    assert {a["path"] for a in r.report.assets} == {"b.jpg"}  # listed (not found) in the report


def test_lot_projection_maps_cga_z_to_a_mirrored_grammarkit_y():
    # on the lot (frame Y) CGA's scope.xz is the ground plane with z running from the back to the
    # street: grammarkit's y runs the other way, so the v size is mirrored and the offset taken
    # from the back
    r = imported("Lot --> setupProjection(0, scope.xz, 4, 2, 1, 0.5) projectUV(0) X.\n")
    assert "setupProjection(0, scope.xy, 4, -2, 1, scope.sy - 0.5)" in line(r, "Lot")
    m = grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")  # UVs of open faces
    V, F, uv = m.surface_vertices, m.surface_faces, m.surface_uvs
    x, y = V[F][..., 0], V[F][..., 1]
    cga_z = 16.0 - y  # CGA's lot z: 0 at the back edge (y = 16), 16 at the street
    assert np.allclose(uv[..., 0], (x - 1.0) / 4.0) and np.allclose(uv[..., 1], (cga_z - 0.5) / 2.0)


def test_world_projection_axes_are_y_up_in_cga():
    r = imported("Lot --> setupProjection(0, world.xz, 3, 3) projectUV(0) X.\n")
    assert "setupProjection(0, world.xy, 3, -3)" in line(r, "Lot")
    m = grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")  # UVs of open faces
    V, F, uv = m.surface_vertices, m.surface_faces, m.surface_uvs
    assert np.allclose(uv[..., 1], -V[F][..., 1] / 3.0)  # CGA's world z is grammarkit's -y


def test_uv_operations_and_materials_translate():
    r = imported("Lot --> extrude(5) comp(f) { side: F }\n"
                 "F --> setupProjection(0, scope.xy, 2, 2) projectUV(0) translateUV(0, 0.5, 0) scaleUV(0, 2, 1) "
                 "rotateUV(0, 90) set(material.opacity, 0.4) set(material.colormap, \"w.png\") "
                 "set(material.color.r, 0.2) deleteUV(2) X.\n")
    text = line(r, "F")
    for piece in ("translateUV(0, 0.5, 0)", "scaleUV(0, 2, 1)", "rotateUV(0, 90)", "set(material.opacity, 0.4)",
                  'set(material.colormap, "w.png")', "set(material.color.r, 0.2)", "deleteUV(2)"):
        assert piece in text
    assert r.report.warned == 0
    m = grammarkit.derive(r.grammar, lot=LOT, surfaces="cga")  # UVs of open faces
    assert m.surface_uvs is not None
    assert {t.color for t in m.tags if t.name == "X"} == {"#33ffff"}  # CGA's default colour is white


def test_what_is_not_translated_says_why():
    r = imported("attr t = fileRandom(\"a/*.jpg\")\n"
                 "Lot --> setupProjection(0, scope.xy, 1, 1, 0, 0, 1) texture(t) copyUV(1, 0) X.\n")
    features = {c.feature for c in r.report.constructs if c.status != "translated"}
    assert {"setupProjection:uwFactor", "op:copyUV"} <= features
    # a computed file name is kept, evaluated at derive time (tests/cga/test_file_functions.py)
    assert 'texture(t)' in line(r, "Lot") and 'fileRandom("a/*.jpg")' in r.text
    # approximated, kept (CGA's scope.xy on the lot is grammarkit's scope.xz: x and up)
    assert "setupProjection(0, scope.xz, 1, 1)" in line(r, "Lot")


def test_found_textures_are_made_relative_to_the_output(tmp_path):
    from PIL import Image

    (tmp_path / "rules").mkdir()
    (tmp_path / "assets").mkdir()
    Image.new("RGB", (4, 4), (1, 2, 3)).save(tmp_path / "assets" / "b.png")
    src = tmp_path / "rules" / "b.cga"
    src.write_text('Lot --> extrude(6) comp(f) { side: setupProjection(0, scope.xy, 2, 2) texture("b.png") '
                   "projectUV(0) W. }\n")
    out = tmp_path / "out" / "b.grammar"
    r = translate_cga(src, output=out)
    assert r.ok and 'texture("../assets/b.png")' in r.text
