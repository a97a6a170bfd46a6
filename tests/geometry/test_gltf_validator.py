"""Khronos' glTF validator (npm `gltf-validator`, run under node) reports no errors, warnings,
infos or hints on the GLB and glTF files grammarkit writes for every example grammar and for a
tiling assembly, and the files carry what docs/derive.md promises (root rotation, linear PBR
materials, one primitive per closed solid, a node per terminal with extras)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import grammarkit
from grammarkit.dsl import load
from grammarkit.geometry.exporters import Z_UP_TO_Y_UP, srgb_to_linear

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "js"))
from _node import ROOT, validate_gltf  # noqa: E402

GRAMMARS = ROOT / "grammars"
EXAMPLES = sorted(p for p in GRAMMARS.glob("*.grammar") if load(p).rules)


def _glb_json(path: Path) -> dict:
    data = path.read_bytes()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20:20 + length])


SURFACE_MODELS = {
    "faces_only": "Lot --> extrude(4) comp(f) { side: color(\"#aa3322\") Wall. | top: Roof. }\n",
    "hybrid": ("Lot --> [ extrude(3) comp(f) { side: Wall. | volume: Mass. } ] t(0, 0, 3) extrude(2) "
               "comp(f) { side: split(x) { ~1: Panel. | 1: recess(0.2) material(\"glass\") Glass. "
               "| ~1: Panel. } }\n"),
}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("gltf")
    files = []
    for path in EXAMPLES:
        m = grammarkit.derive(path, seed=0)
        files += [m.save(out / f"{path.stem}.glb"), m.save(out / f"{path.stem}.gltf")]
    # the surface layer: a model of faces only, and a solid with surfaces beside it
    for name, text in SURFACE_MODELS.items():
        m = grammarkit.derive(text, seed=0, surfaces="cga")  # CGA's open faces: a surface layer
        files += [m.save(out / f"{name}.glb"), m.save(out / f"{name}.gltf")]
    from grammarkit.tiling import load_examples, write_assembly

    tiling = grammarkit.parse(GRAMMARS / "tiling" / "castle" / "castle.grammar") \
        if (GRAMMARS / "tiling" / "castle" / "castle.grammar").exists() else None
    if tiling is not None:
        asm = load_examples(tiling)[0]
        files += [write_assembly(asm, out / "castle_example.glb"), write_assembly(asm, out / "castle_example.gltf")]
    return files


def test_validator_reports_nothing(written):
    reports = validate_gltf(written)
    assert set(reports) == {str(f) for f in written}
    for f, r in reports.items():
        assert (r["errors"], r["warnings"], r["infos"], r["hints"]) == (0, 0, 0, 0), \
            f"{f}: {json.dumps(r['messages'], indent=1)}"


def test_the_validator_does_catch_a_broken_file(tmp_path, written):
    # the check can fail: a GLB whose accessor points past its buffer view is reported
    src = next(f for f in written if f.suffix == ".gltf")
    doc = json.loads(src.read_text())
    doc["accessors"][0]["count"] += 10
    bad = tmp_path / "bad.gltf"
    bad.write_text(json.dumps(doc))
    (report,) = validate_gltf([bad]).values()
    assert report["errors"] > 0


def test_layout_root_rotation_materials_and_terminal_nodes(written):
    paris = next(f for f in written if f.name == "paris.glb")
    doc = _glb_json(paris)
    root = doc["nodes"][doc["scenes"][0]["nodes"][0]]
    assert np.allclose(root["rotation"], Z_UP_TO_Y_UP)
    assert root["extras"]["grammarkit"]["up"] == "+Z"
    # a closed solid is one primitive: its materials ride in the primitive's extras
    materials = doc["materials"] + [m for mesh in doc["meshes"] for p in mesh["primitives"]
                                    for m in p.get("extras", {}).get("grammarkit", {}).get("materials", [])]
    (building,) = [doc["nodes"][i] for i in root["children"]]
    palette = doc["meshes"][building["mesh"]]["primitives"][0]["extras"]["grammarkit"]["materials"]
    names = [m["name"] for m in palette]
    assert len(set(names)) == len(names)  # one material per (name, colour), each named
    assert "zinc" in names and any(n.startswith("glass") for n in names)
    assert {m["extras"].get("material") for m in palette} >= {"glass", "zinc", "limestone"}
    for m in materials:
        pbr = m["pbrMetallicRoughness"]
        assert pbr["metallicFactor"] == 0.0 and 0.0 < pbr["roughnessFactor"] <= 1.0
        srgb = m["extras"]["srgb"]
        expected = srgb_to_linear(np.array([int(srgb[k:k + 2], 16) for k in (1, 3, 5)]) / 255.0)
        assert np.allclose(pbr["baseColorFactor"][:3], expected, atol=1e-6)
    assert not any("COLOR_0" in p["attributes"] for mesh in doc["meshes"] for p in mesh["primitives"])
    (building,) = [doc["nodes"][i] for i in root["children"]]
    groups = {doc["nodes"][i]["name"]: doc["nodes"][i]["extras"] for i in building["children"]}
    model = grammarkit.derive(GRAMMARS / "paris.grammar", seed=0)
    assert set(groups) == set(model.face_labels())
    glass = next(e for e in groups.values() if "glass" in e["materials"])
    assert glass["rules"] and all(":" in s for s in glass["sources"]) and glass["roles"]
    # ONE primitive for the whole building over one vertex set: it is stored closed, and every
    # reader gets it closed without welding (issue 32); the terminal nodes hold no mesh, their
    # faces are ranges of that primitive, and the primitive's runs colour every face
    assert all("mesh" not in doc["nodes"][i] for i in building["children"])
    (prim,) = doc["meshes"][building["mesh"]]["primitives"]
    runs = prim["extras"]["grammarkit"]["runs"]
    n_faces = doc["accessors"][prim["indices"]]["count"] // 3
    assert sum(r[3] for r in runs) == n_faces == len(model.faces)
    assert [r[2] for r in runs] == sorted(r[2] for r in runs)
    ranges = sorted(tuple(f) for i in building["children"] for f in doc["nodes"][i]["extras"]["faces"])
    assert ranges == [(r[2], r[3]) for r in runs]
    assert {palette[r[1]]["extras"].get("material") for r in runs} >= {"glass", "zinc", "limestone"}


def test_surface_layer_is_its_own_flagged_node(written):
    hybrid = next(f for f in written if f.name == "hybrid.glb")
    doc = _glb_json(hybrid)
    root = doc["nodes"][doc["scenes"][0]["nodes"][0]]
    solid, surface = [doc["nodes"][i] for i in root["children"]]
    assert "surface" not in (solid.get("extras") or {})
    assert surface["extras"]["surface"] is True and surface["name"].endswith("surfaces")
    kids = [doc["nodes"][i] for i in surface["children"]]
    assert {k["name"] for k in kids} == {"Panel", "Glass"}  # the Glass terminal tags its reveal
    assert all(k["extras"]["surface"] is True for k in kids)
    mats = {p["material"] for k in kids for p in doc["meshes"][k["mesh"]]["primitives"]}
    assert all(doc["materials"][m]["doubleSided"] and doc["materials"][m]["extras"]["surface"] for m in mats)
    # the solid's materials are single-sided; it is one primitive (the surface layer is not)
    (sprim,) = [p for n in [solid] + [doc["nodes"][i] for i in solid.get("children", [])] if "mesh" in n
                for p in doc["meshes"][n["mesh"]]["primitives"]]
    smats = sprim.get("extras", {}).get("grammarkit", {}).get("materials", []) + [doc["materials"][sprim["material"]]]
    assert not any(m.get("doubleSided") for m in smats)
    # read back: the solid alone is watertight, the surface layer is separate
    from grammarkit.geometry.meshio import read_gltf_solids

    solids = read_gltf_solids(hybrid)
    assert [bool(s.extras.get("surface")) for s in solids] == [False, True]
