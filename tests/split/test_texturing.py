"""CGA texturing in the split engine: setupProjection / projectUV / the UV operations, texture()
and set(material.*), the texture coordinates of the derived mesh, and what reaches the GLB
(TEXCOORD_0, embedded or referenced images, PBR factors), read back watertight."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import trimesh

import grammarkit
from grammarkit.errors import DerivationError, GrammarError

LOT = [(0.0, 0.0), (10.0, 0.0), (10.0, 8.0), (0.0, 8.0)]


@pytest.fixture
def png(tmp_path):
    from PIL import Image

    path = tmp_path / "bricks.png"
    Image.new("RGB", (8, 8), (180, 60, 40)).save(path)
    return path


def derive(text: str, tmp_path=None, **kw):
    kw.setdefault("surfaces", "cga")  # CGA's open faces: what these tests pin
    if tmp_path is not None:  # a grammar file, so that texture paths resolve beside it
        path = tmp_path / "t.grammar"
        path.write_text(text)
        return grammarkit.derive(str(path), lot=LOT, **kw)
    return grammarkit.derive(text, lot=LOT, **kw)


def front_uvs(model):
    """(corner positions, uvs) of the solid's triangles facing -y (the front facade)."""
    V, F, uv = model.vertices, model.faces, model.triangle_uvs
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    front = n[:, 1] < -1e-9
    return V[F[front]].reshape(-1, 3), uv[front].reshape(-1, 2)


def test_scope_projection_on_a_facade_maps_world_units_to_texture_tiles():
    m = derive("Lot --> extrude(6) comp(f) { front: setupProjection(0, scope.xy, 2, 3) projectUV(0) F. "
               "| volume: M. }\n")
    P, uv = front_uvs(m)
    # the front face's scope: origin at the lot's corner, x along the street, y up
    assert np.allclose(uv[:, 0], P[:, 0] / 2.0) and np.allclose(uv[:, 1], P[:, 2] / 3.0)
    # triangles not painted by a projected terminal have no UVs
    assert np.isnan(m.triangle_uvs).any(axis=(1, 2)).sum() > 0


def test_offsets_and_mirrored_sizes():
    m = derive("Lot --> extrude(6) comp(f) { front: setupProjection(0, scope.xy, -2, 3, 1, 0.5) projectUV(0) F. "
               "| volume: M. }\n")
    P, uv = front_uvs(m)
    assert np.allclose(uv[:, 0], (P[:, 0] - 1.0) / -2.0) and np.allclose(uv[:, 1], (P[:, 2] - 0.5) / 3.0)


def test_a_projection_set_up_before_a_split_runs_on_across_the_tiles():
    once = derive("Lot --> extrude(6) comp(f) { front: setupProjection(0, scope.xy, 4, 4) Facade | volume: M. }\n"
                  "Facade --> split(x) { { ~2.5: projectUV(0) Tile. }* }\n")
    per_tile = derive("Lot --> extrude(6) comp(f) { front: Facade | volume: M. }\n"
                      "Facade --> split(x) { { ~2.5: setupProjection(0, scope.xy, 4, 4) projectUV(0) Tile. }* }\n")
    P, uv = front_uvs(once)
    assert np.allclose(uv[:, 0], P[:, 0] / 4.0)  # one projection: u runs on from tile to tile
    P, uv = front_uvs(per_tile)
    # a projection per tile starts again at every tile's origin (tiles are 2.5 m wide)
    start = np.floor((P[:, 0] + 1e-6) / 2.5) * 2.5
    inner = (P[:, 0] > 0.01) & (P[:, 0] < 9.99) & (np.abs(P[:, 0] - np.round(P[:, 0] / 2.5) * 2.5) > 0.01)
    assert np.allclose(uv[inner, 0], (P[inner, 0] - start[inner]) / 4.0)


def test_baked_uvs_move_with_the_geometry_and_projections_stay_in_the_world():
    text = ("Lot --> extrude(6) comp(f) { front: setupProjection(0, world.xz, 2, 2) {op} F. }\n")
    moved = derive(text.replace("{op}", "projectUV(0) t(3, 1, 0)"))
    late = derive(text.replace("{op}", "t(3, 1, 0) projectUV(0)"))
    # faces only: the surface layer. UVs baked before t() stay on the moved geometry (t moves
    # the face 3 m along its x, the street, and 1 m along its y, up)
    V, F = moved.surface_vertices, moved.surface_faces
    assert np.allclose(moved.surface_uvs[..., 0], (V[F][..., 0] - 3.0) / 2.0)
    assert np.allclose(moved.surface_uvs[..., 1], (V[F][..., 2] - 1.0) / 2.0)
    # projected after the move: the world projection is evaluated where the face is now
    V, F = late.surface_vertices, late.surface_faces
    assert np.allclose(late.surface_uvs[..., 0], V[F][..., 0] / 2.0)
    assert np.allclose(late.surface_uvs[..., 1], V[F][..., 2] / 2.0)


def test_s_stretches_baked_uvs_with_the_geometry():
    m = derive("Lot --> extrude(6) comp(f) { front: setupProjection(0, scope.xy, 10, 6) projectUV(0) "
               "s(5, 3, 0) F. }\n")
    V, F, uv = m.surface_vertices, m.surface_faces, m.surface_uvs
    # the face was 10 x 6 (one texture tile); halved in both directions it still shows the one tile
    assert np.allclose(uv[..., 0], V[F][..., 0] / 5.0) and np.allclose(uv[..., 1], V[F][..., 2] / 3.0)


def test_uv_operations_compose_in_texture_space():
    base = "Lot --> extrude(6) comp(f) { front: setupProjection(0, scope.xy, 2, 3) projectUV(0) {op} F. }\n"
    ref = derive(base.replace("{op}", ""))
    u0, v0 = ref.surface_uvs[..., 0], ref.surface_uvs[..., 1]
    shifted = derive(base.replace("{op}", "translateUV(0, 0.25, -1)")).surface_uvs
    assert np.allclose(shifted[..., 0], u0 + 0.25) and np.allclose(shifted[..., 1], v0 - 1)
    scaled = derive(base.replace("{op}", "scaleUV(0, 2, 0.5)")).surface_uvs
    assert np.allclose(scaled[..., 0], 2 * u0) and np.allclose(scaled[..., 1], 0.5 * v0)
    turned = derive(base.replace("{op}", "rotateUV(0, 90)")).surface_uvs
    assert np.allclose(turned[..., 0], -v0) and np.allclose(turned[..., 1], u0)
    assert derive(base.replace("{op}", "deleteUV(0)")).surface_uvs is None


def test_materials_reach_the_glb(tmp_path, png):
    text = ('Lot --> extrude(6) comp(f) { side: setupProjection(0, scope.xy, 2, 3) texture("bricks.png") '
            "projectUV(0) Wall. | top: set(material.opacity, 0.5) set(material.metallic, 0.3) "
            "set(material.roughness, 0.2) set(material.color.r, 0) set(material.shininess, 12) Roof. "
            "| volume: Mass. }\n")
    m = derive(text, tmp_path)
    path = m.save(tmp_path / "m.glb")
    data = path.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    (image,) = doc["images"]
    assert image["mimeType"] == "image/png" and "bufferView" in image  # embedded by default
    textured = [mat for mat in doc["materials"] if "baseColorTexture" in mat["pbrMetallicRoughness"]]
    assert len(textured) == 1 and textured[0]["pbrMetallicRoughness"]["baseColorFactor"] == [1.0, 1.0, 1.0, 1.0]
    roof = [mat for mat in doc["materials"] if mat.get("alphaMode") == "BLEND"]
    assert len(roof) == 1
    pbr = roof[0]["pbrMetallicRoughness"]
    assert pbr["metallicFactor"] == 0.3 and pbr["roughnessFactor"] == 0.2
    assert pbr["baseColorFactor"][0] == 0.0 and pbr["baseColorFactor"][3] == pytest.approx(128 / 255, abs=1e-6)
    assert roof[0]["extras"]["cga"] == {"shininess": 12.0}
    prims = [p for mesh in doc["meshes"] for p in mesh["primitives"]]
    with_uv = [p for p in prims if "TEXCOORD_0" in p["attributes"]]
    assert with_uv and all(doc["materials"][p["material"]] is textured[0] for p in with_uv)
    assert all("TEXCOORD_0" not in p["attributes"] for p in prims if p not in with_uv)
    # read back as an ordinary trimesh user does: one watertight body of the derived volume
    loaded = trimesh.load(path).to_mesh()
    welded = trimesh.Trimesh(loaded.vertices, loaded.faces)
    assert welded.is_watertight and welded.body_count == 1
    assert welded.volume == pytest.approx(m.manifold.volume(), rel=1e-4)
    # and the texture coordinates a reader sees are the model's, v flipped to glTF's convention
    geoms = [g for g in trimesh.load(path).geometry.values() if getattr(g.visual, "uv", None) is not None]
    assert geoms
    uv = np.concatenate([g.visual.uv for g in geoms])
    assert np.nanmax(np.abs(uv)) < 6


def test_textures_can_be_referenced_by_a_relative_uri(tmp_path, png):
    m = derive('Lot --> extrude(6) comp(f) { side: setupProjection(0, scope.xy, 2, 3) texture("bricks.png") '
               "projectUV(0) Wall. | volume: Mass. }\n", tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    path = m.save(out / "m.gltf", textures="reference")
    doc = json.loads(path.read_text())
    assert doc["images"] == [{"uri": "../bricks.png", "name": "bricks.png"}]
    scene = trimesh.load(path)  # trimesh resolves the URI beside the file
    assert any(getattr(g.visual, "material", None) is not None for g in scene.geometry.values())
    with pytest.raises(ValueError, match="textures must be"):
        m.save(out / "x.glb", textures="inline")


def test_a_missing_texture_warns_and_exports_the_colour_only(tmp_path):
    m = derive('Lot --> extrude(6) comp(f) { side: setupProjection(0, scope.xy, 2, 3) texture("nope.jpg") '
               "projectUV(0) Wall. | volume: Mass. }\n", tmp_path)
    assert any("texture file not found: " in w and "nope.jpg" in w for w in m.warnings)
    path = m.save(tmp_path / "m.glb")
    data = path.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    assert "images" not in doc
    assert any(mat["extras"].get("missing_texture", "").endswith("nope.jpg") for mat in doc["materials"])


def test_bad_texturing_input_is_reported_where_it_is():
    with pytest.raises(GrammarError, match="setupProjection") as e:
        derive("Lot --> setupProjection(0, scope.xw, 2, 2) X.\n")
    assert e.value.span.line == 1
    with pytest.raises(DerivationError, match="texture size must not be 0"):
        derive("Lot --> setupProjection(0, scope.xy, 0, 2) X.\n")
    with pytest.raises(DerivationError, match="uv set must be an integer"):
        derive("Lot --> setupProjection(12, scope.xy, 1, 2) X.\n")
    with pytest.raises(DerivationError, match=r"set\(material.opacity"):
        derive("Lot --> set(material.opacity, 3) X.\n")
    # a uv operation on a set without coordinates changes nothing (CityEngine's behaviour):
    # a warning naming the set, and the model is still built
    m = derive("Lot --> setupProjection(0, scope.xy, 1, 1) projectUV(0) scaleUV(1, 2, 2) tileUV(1, 2, 2) X.\n")
    assert sum("no texture coordinates in uv set 1" in w for w in m.warnings) >= 1
    assert m.triangle_count > 0
    m = derive("Lot --> projectUV(0) X.\n")  # CGA leaves the shape without UVs: a warning says so
    assert any("projectUV(0) without setupProjection(0" in w for w in m.warnings)


def test_texturing_grammar_round_trips_through_the_printer():
    from grammarkit import parse
    from grammarkit.printer import print_grammar

    text = ('Lot --> setupProjection(2, world.xz, 1.5, scope.sy / 2, 0.25, 0) projectUV(2) '
            'texture("a.png") set(material.colormap, "b.jpg") translateUV(2, 0.5, 0) X.\n')
    g = parse(text)
    again = parse(print_grammar(g))
    assert print_grammar(again) == print_grammar(g)
    assert "setupProjection(2, world.xz, 1.5, scope.sy / 2, 0.25, 0)" in print_grammar(g)
    assert "set(material.colormap, \"b.jpg\")" in print_grammar(g)


def test_untextured_models_are_unchanged():
    m = derive("Lot --> extrude(6) comp(f) { side: color(\"#aa3322\") Wall. | volume: Mass. }\n")
    assert m.triangle_uvs is None and m.surface_uvs is None
    assert all(t.texturing is None for t in m.tags)
    assert math.isclose(m.manifold.volume(), 10 * 8 * 6, rel_tol=1e-2)


def test_the_cli_writes_textured_glb(tmp_path, png):
    from click.testing import CliRunner

    from grammarkit.cli import main

    (tmp_path / "t.grammar").write_text(
        'Lot --> extrude(6) comp(f) { side: setupProjection(0, scope.xy, 2, 3) texture("bricks.png") projectUV(0) '
        "Wall. | volume: Mass. }\n")
    out = tmp_path / "out.glb"
    # CityEngine's open-face output keeps the textured look (TEXCOORD_0, with vertex seams)
    res = CliRunner().invoke(main, ["derive", str(tmp_path / "t.grammar"), "-o", str(out), "--surfaces", "cga"])
    assert res.exit_code == 0, res.output
    data = out.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    assert doc["images"][0]["mimeType"] == "image/png"
    assert any("TEXCOORD_0" in p["attributes"] for m in doc["meshes"] for p in m["primitives"])
    # the default: one seamless primitive, watertight as trimesh reads it, the image named only
    res = CliRunner().invoke(main, ["derive", str(tmp_path / "t.grammar"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    data = out.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    assert "images" not in doc
    assert all("TEXCOORD_0" not in p["attributes"] for m in doc["meshes"] for p in m["primitives"])
    prim_materials = [mat for m in doc["meshes"] for p in m["primitives"]
                      for mat in p.get("extras", {}).get("grammarkit", {}).get("materials", [])]
    assert any(mat["extras"].get("colormap") == "bricks.png" for mat in prim_materials + doc["materials"])
    assert trimesh.load(out, force="mesh").is_watertight
