"""Issue 31: a grammarkit GLB edited elsewhere (a part node moved to the scene root, as a
trimesh or Blender edit does, keeping its world placement) reads every part, or is refused
naming the node it cannot place; never a silent loss."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

from grammarkit.dsl import load
from grammarkit.errors import ShapeError
from grammarkit.tiling import read_assembly, validate

EXAMPLES = Path(__file__).resolve().parents[2] / "grammars" / "tiling"


def _glb_json(path: Path) -> tuple[dict, bytes]:
    raw = path.read_bytes()
    length, = struct.unpack("<I", raw[12:16])
    return json.loads(raw[20:20 + length]), raw[20 + length:]


def _write_glb(path: Path, doc: dict, rest: bytes) -> None:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    path.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


def _matrix(node: dict) -> np.ndarray:
    from grammarkit.tiling.io import _node_matrix  # the reader's own node-matrix rule

    return _node_matrix(node)


def _moved_to_root(src: Path, dst: Path, name: str, *, drop_mesh: bool = False) -> None:
    doc, rest = _glb_json(src)
    nodes = doc["nodes"]
    scene = doc["scenes"][doc.get("scene", 0)]
    root = scene["nodes"][0]
    k = next(i for i, n in enumerate(nodes) if n.get("name") == name)
    nodes[root]["children"].remove(k)
    world = _matrix(nodes[root]) @ _matrix(nodes[k])
    for key in ("translation", "rotation", "scale"):
        nodes[k].pop(key, None)
    nodes[k]["matrix"] = [float(x) for x in world.T.ravel()]
    if drop_mesh:  # a node that cannot be a part: its mesh reference points nowhere useful
        nodes[k]["mesh"] = len(doc["meshes"]) + 5
    scene["nodes"].append(k)
    _write_glb(dst, doc, rest)


def test_a_part_moved_to_the_scene_root_is_read_in_place(tmp_path):
    src = EXAMPLES / "castle" / "castle_large.glb"
    original = read_assembly(src)
    moved = tmp_path / "edited.glb"
    _moved_to_root(src, moved, "Wall.3")
    edited = read_assembly(moved)
    assert len(edited) == len(original) == 33
    a = {p.id: p for p in original.parts}["Wall.3"]
    b = {p.id: p for p in edited.parts}["Wall.3"]
    assert b.type == "Wall"
    assert np.allclose(np.sort(a.mesh.vertices, axis=0), np.sort(b.mesh.vertices, axis=0), atol=1e-5)
    assert np.allclose(a.transform, b.transform, atol=1e-6)
    assert validate(load(EXAMPLES / "castle" / "castle.grammar"), edited).ok


def test_a_stray_node_that_cannot_be_placed_is_refused_by_name(tmp_path):
    moved = tmp_path / "broken.glb"
    _moved_to_root(EXAMPLES / "castle" / "castle_small.glb", moved, "Tower.2", drop_mesh=True)
    with pytest.raises(ShapeError, match="Tower.2"):
        read_assembly(moved)
