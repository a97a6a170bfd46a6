"""Benchmark of model export (grammarkit.geometry.exporters) against a minimal GLB writer.

For each example building (seed 0) it prints the median wall time of:

- **floor**: a minimal hand-written GLB writer with per-face colours, given the model's
  vertices, faces and per-face colours (already computed): split vertices at colour seams
  with 1-D keys, write POSITION + COLOR_0 + indices. It does the least a GLB with per-face
  colours needs, so it is the baseline (ratio 1.0).
- **glb**: `encode(model, "glb")` with the model's per-triangle tags already computed
  (the layout of docs/derive.md: a node per terminal name, materials, extras).
- **glb + tags**: the same on a fresh model, including `Model.triangle_tags` (painting face
  terminals onto the body), which the floor gets for free.
- **gltf, obj, stl, ply**: the other formats, tags computed.
- **before**: the previous exporter (trimesh's GLB export after splitting colour seams with
  `np.unique(axis=0)`), re-implemented here as it was, for comparison.

The machine is shared: run it on a quiet machine for numbers to quote.

Usage:  python benchmarks/bench_export.py [--runs 15] [--grammars paris,lshape,skyscraper]
"""
from __future__ import annotations

import argparse
import json
import struct
from pathlib import Path

import numpy as np
import trimesh

import grammarkit
from grammarkit.geometry.exporters import encode
from _timing import median_time  # noqa: E402 - benchmarks/ is on sys.path

ROOT = Path(__file__).resolve().parents[1]


def floor_glb(vertices: np.ndarray, faces: np.ndarray, face_rgba: np.ndarray) -> bytes:
    """The least a GLB with per-face colours needs (one mesh, vertex colours, seams split)."""
    keys = np.ascontiguousarray(face_rgba, dtype=np.uint8).view(np.uint32).reshape(-1)
    _, cid = np.unique(keys, return_inverse=True)
    pair = faces.reshape(-1).astype(np.int64) * (int(cid.max()) + 1) + np.repeat(cid.reshape(-1), 3)
    uniq, inv = np.unique(pair, return_inverse=True)
    src = uniq // (int(cid.max()) + 1)
    pos = np.ascontiguousarray(vertices[src], dtype=np.float32)
    col = np.zeros((len(src), 4), dtype=np.uint8)
    col[inv.reshape(-1)] = np.repeat(face_rgba, 3, axis=0)
    idx = inv.astype(np.uint32).reshape(-1)
    blobs = [pos.tobytes(), col.tobytes(), idx.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2}]}],
           "buffers": [{"byteLength": int(offsets[-1])}],
           "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[i]), "byteLength": len(b)}
                           for i, b in enumerate(blobs)],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
                          "min": pos.min(axis=0).tolist(), "max": pos.max(axis=0).tolist()},
                         {"bufferView": 1, "componentType": 5121, "normalized": True, "count": len(col),
                          "type": "VEC4"},
                         {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary = b"".join(blobs)
    binary += b"\0" * (-len(binary) % 4)
    return (struct.pack("<4sII", b"glTF", 2, 28 + len(js) + len(binary)) + struct.pack("<I4s", len(js), b"JSON")
            + js + struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def before_glb(mesh: trimesh.Trimesh) -> bytes:
    """The exporter before this change: colour seams split with np.unique(axis=0), trimesh export."""
    fc = np.asarray(mesh.visual.face_colors, dtype=np.uint8)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    _, color_id = np.unique(fc, axis=0, return_inverse=True)
    pairs = np.column_stack([faces.ravel(), np.repeat(color_id.reshape(-1), 3)])
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    new_faces = inv.reshape(-1, 3)
    vcolors = np.zeros((len(uniq), 4), dtype=np.uint8)
    vcolors[new_faces.ravel()] = np.repeat(fc, 3, axis=0)
    split = trimesh.Trimesh(np.asarray(mesh.vertices)[uniq[:, 0]], new_faces, vertex_colors=vcolors, process=False)
    scene = trimesh.Scene()
    scene.add_geometry(split, node_name="building", geom_name="building")
    return scene.export(file_type="glb")


def fresh(model):
    """The model with its per-triangle tags and trimesh mesh forgotten (as right after derive)."""
    for key in ("triangle_tags", "tags", "mesh"):
        model.__dict__.pop(key, None)
    return model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--grammars", default="paris,lshape,skyscraper")
    args = ap.parse_args()
    print(f"median of {args.runs} runs; ratio = time / floor (the minimal GLB writer)\n")
    print(f"{'model':<11} {'triangles':>9}  {'what':<12} {'ms':>8} {'ratio':>6} {'KiB':>7}")
    for name in args.grammars.split(","):
        model = grammarkit.derive(ROOT / "grammars" / f"{name}.grammar", seed=0)
        mesh = model.mesh  # computes the tags once; the floor gets vertices, faces, colours
        V, F, C = model.vertices, model.faces, np.asarray(mesh.visual.face_colors, dtype=np.uint8)
        rows = [("floor", lambda: floor_glb(V, F, C)),
                ("glb", lambda: encode(model, "glb")),
                ("glb + tags", lambda: encode(fresh(model), "glb")),
                ("gltf", lambda: encode(model, "gltf")),
                ("obj", lambda: encode(model, "obj")),
                ("stl", lambda: encode(model, "stl")),
                ("ply", lambda: encode(model, "ply")),
                ("before", lambda: before_glb(mesh))]
        base = None
        for what, fn in rows:
            size = len(fn()) / 1024  # also warms up
            t = median_time(fn, args.runs)
            base = base or t
            print(f"{name:<11} {model.triangle_count:>9}  {what:<12} {t * 1e3:>8.2f} {t / base:>6.2f} {size:>7.0f}")
        print()


if __name__ == "__main__":
    main()
