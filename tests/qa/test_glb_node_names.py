"""Issue 32: no two structural nodes of a GLB share a name (a derived paris GLB had its root
and its building both named `paris`): the root and every solid node have names of their own,
terminal nodes are unique within their solid, the file reads back with the same solids and
labels, and Khronos' validator (when installed) still reports nothing."""
from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path

import grammarkit
from grammarkit.geometry.meshio import read_gltf_solids

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "js"))
from _node import validate_gltf

TWO_NAMED_ALIKE = """grammar twins
Lot --> footprint(rect(8, 6)) extrude(3) Mass
Mass --> comp(f) { top: Roof. | side: Wall. | bottom: NIL | volume: Mass. }
"""


def glb_json(path: Path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])


def structure(doc: dict) -> tuple[dict, list[dict]]:
    root = doc["nodes"][doc["scenes"][doc.get("scene", 0)]["nodes"][0]]
    return root, [doc["nodes"][k] for k in root.get("children", [])]


def test_the_paris_glb_names_every_structural_node_once(tmp_path):
    path = grammarkit.derive(ROOT / "grammars" / "paris.grammar", seed=0).save(tmp_path / "paris.glb")
    doc = glb_json(path)
    root, solids = structure(doc)
    names = [root["name"]] + [s["name"] for s in solids]
    assert len(names) == len(set(names)), names
    assert root["name"] == "paris (scene)" and "paris" in names
    for solid in solids:  # terminals: one node each within their solid
        kids = [doc["nodes"][k]["name"] for k in solid.get("children", [])]
        assert len(kids) == len(set(kids)), kids
    assert [n for n, c in Counter(x["name"] for x in doc["nodes"]).items() if c > 1] == []
    assert [s.name for s in read_gltf_solids(path)] == ["paris"]


def test_solids_with_one_name_get_numbered_and_read_back(tmp_path):
    from grammarkit.geometry.exchange.gltf import _unique_node_names

    nodes = [{"name": "Tower.0"}, {"name": "paris"}, {"name": "paris"}, {"name": "paris (2)"},
             {"name": "Window"}]
    taken = _unique_node_names(nodes, [0, 1, 2, 3])
    assert [n["name"] for n in nodes] == ["Tower.0", "paris", "paris (2)", "paris (2) (2)", "Window"]
    assert taken == {"Tower.0", "paris", "paris (2)", "paris (2) (2)"}
    model = grammarkit.derive(TWO_NAMED_ALIKE, seed=0)
    path = model.save(tmp_path / "twins.glb")
    root, solids = structure(glb_json(path))
    assert root["name"] == "twins (scene)" and [s["name"] for s in solids] == ["twins"]
    back = read_gltf_solids(path)
    assert [s.name for s in back] == ["twins"] and set(back[0].labels) <= {"Roof", "Wall", "Mass"}


def test_khronos_validator_still_reports_nothing(tmp_path):
    path = grammarkit.derive(ROOT / "grammars" / "paris.grammar", seed=0).save(tmp_path / "paris.glb")
    (report,) = validate_gltf([path]).values()
    assert (report["errors"], report["warnings"], report["infos"], report["hints"]) == (0, 0, 0, 0), \
        json.dumps(report["messages"], indent=1)
