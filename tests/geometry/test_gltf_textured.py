"""Khronos' glTF validator reports nothing (no errors, warnings, infos or hints) on GLB and glTF
files with CGA texturing: TEXCOORD_0 on textured primitives, embedded and referenced images,
a sampler, PBR factors and transparency (docs/cga.md, "Texturing")."""
from __future__ import annotations

import sys
from pathlib import Path

import grammarkit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "js"))
from _node import validate_gltf  # noqa: E402

LOT = [(0.0, 0.0), (12.0, 0.0), (12.0, 9.0), (0.0, 9.0)]
TEXT = ('Lot --> extrude(9) comp(f) { side: Facade | top: setupProjection(0, world.xy, 3, 3) '
        'texture("roof.jpg") projectUV(0) set(material.opacity, 0.8) Roof. | volume: Mass. }\n'
        'Facade --> setupProjection(0, scope.xy, 2, 3) texture("bricks.png") projectUV(0) '
        'split(y) { { ~3: split(x) { ~1: Wall. | 1.2: recess(0.3) set(material.metallic, 0.5) Glass. '
        '| ~1: Wall. } }* }\n')


def test_textured_files_validate_cleanly(tmp_path):
    from PIL import Image

    Image.new("RGB", (16, 16), (170, 70, 50)).save(tmp_path / "bricks.png")
    Image.new("RGB", (16, 16), (60, 60, 70)).save(tmp_path / "roof.jpg")
    (tmp_path / "t.grammar").write_text(TEXT)
    m = grammarkit.derive(str(tmp_path / "t.grammar"), lot=LOT)
    assert m.triangle_uvs is not None
    seams = dict(texture_seams=True)  # TEXCOORD_0 on textured primitives (CityEngine's look)
    files = [m.save(tmp_path / "m.glb", **seams), m.save(tmp_path / "m.gltf", **seams),
             m.save(tmp_path / "r.gltf", textures="reference", **seams),
             m.save(tmp_path / "r.glb", textures="reference", **seams),
             m.save(tmp_path / "seamless.glb")]  # the default: one seamless, untextured primitive
    reports = list(validate_gltf(files).values())
    assert len(reports) == 5
    for r in reports[:3] + reports[4:]:
        assert (r["errors"], r["warnings"], r["infos"], r["hints"]) == (0, 0, 0, 0), r
    # a GLB that references its images: valid, the validator only notes the URIs (info URI_GLB)
    r = reports[3]
    assert (r["errors"], r["warnings"], r["hints"]) == (0, 0, 0)
    assert {m["code"] for m in r["messages"]} == {"URI_GLB"}
