"""One GLB of many: the items of a batch (a city's buildings) merged into one file.

    from grammarkit.run.merge import merge_glb

    merge_glb([("lot-1", "city/lot-1.glb"), ("lot-2", "city/lot-2.glb")], "city.glb")

The items' GLB files (grammarkit's layout, format 2: see grammarkit.geometry.exporters) are
merged at the glTF level: their binary chunks are concatenated and the indices of buffer views,
accessors, meshes, materials and nodes are offset. Nothing is decoded and encoded again, so
the merge is exact (every material, node extra and face label of every building survives) and
costs little more than reading the files; identical materials are shared.

Layout of the merged file: one root node (the same Z-up -> Y-up rotation as every item, and
`extras.grammarkit` with the concatenated face labels), below it one node per item's solid,
named after the item (`lot-1`, or `lot-1/name` when an item has several solids), whose extras
hold the item's id, seed, attrs and bindings; below those, the items' own group nodes
(terminal names). `grammarkit.geometry.meshio.load_mesh` reads it back as one solid per item.
"""
from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Iterable

from ..errors import GrammarkitError

__all__ = ["merge_glb", "MergeError"]

_JSON, _BIN = 0x4E4F534A, 0x004E4942


class MergeError(GrammarkitError):
    """An item's file cannot be merged (not a grammarkit GLB, damaged)."""


def _read_glb(path: Path) -> tuple[dict, bytes]:
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MergeError(f"{path}: cannot read it for the merge: {exc.strerror or exc}") from None
    try:
        magic, version, _ = struct.unpack_from("<4sII", raw, 0)
        if magic != b"glTF" or version != 2:
            raise ValueError("not a GLB 2.0 file")
        jlen, jkind = struct.unpack_from("<II", raw, 12)
        if jkind != _JSON:
            raise ValueError("the first chunk is not JSON")
        doc = json.loads(raw[20:20 + jlen])
        rest = 20 + jlen
        binary = b""
        if len(raw) >= rest + 8:
            blen, bkind = struct.unpack_from("<II", raw, rest)
            if bkind == _BIN:
                binary = raw[rest + 8:rest + 8 + blen]
    except (struct.error, ValueError) as exc:
        raise MergeError(f"{path}: not a readable GLB file ({exc})") from None
    buffers = doc.get("buffers", [])
    if len(buffers) > 1 or any("uri" in b for b in buffers):
        raise MergeError(f"{path}: has external or several buffers; only self-contained GLB files "
                         "are merged")
    return doc, binary + b"\0" * ((-len(binary)) % 4)


def _root(doc: dict, path: Path) -> dict:
    try:
        root = doc["nodes"][doc["scenes"][doc.get("scene", 0)]["nodes"][0]]
    except (KeyError, IndexError, TypeError):
        raise MergeError(f"{path}: has no scene root node") from None
    marker = (root.get("extras") or {}).get("grammarkit")
    if not isinstance(marker, dict) or int(marker.get("format", 0)) < 2:
        raise MergeError(f"{path}: not a GLB written by this grammarkit (format 2); re-run the batch "
                         "with --overwrite to rewrite it")
    return root


def _placement(node: dict) -> dict:
    return {k: node[k] for k in ("matrix", "rotation", "translation", "scale") if k in node}


def merge_glb(items: Iterable[tuple[str, str | Path]], path: str | Path) -> Path:
    """Merge the GLB files of `items` ((item id, file) pairs) into `path`, atomically."""
    from .writer import write_files

    path = Path(path)
    merged = _Merged()
    for item_id, file in items:
        merged.add(item_id, Path(file))
    write_files({path: merged.glb(path)})
    return path


class _Merged:
    """The glTF document being merged: each item's buffer views, accessors, meshes and nodes
    appended with their indices shifted, materials shared by value, one root for all items."""

    def __init__(self) -> None:
        self.out: dict = {"asset": {"version": "2.0", "generator": "grammarkit (merged)"}, "scene": 0,
                          "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": []}
        self.chunks: list[bytes] = []
        self.size = 0
        self.labels: list[str] = []
        self.material_index: dict[str, int] = {}
        self.children: list[int] = []
        self.placement: dict | None = None
        self.marker: dict | None = None
        self.first: Path | None = None

    def add(self, item_id: str, file: Path) -> None:
        """Append one item's GLB file."""
        out = self.out
        doc, binary = _read_glb(file)
        root = _root(doc, file)
        if self.placement is None:
            self.placement, self.marker, self.first = (_placement(root),
                                                       dict(root["extras"]["grammarkit"]), file)
        elif _placement(root) != self.placement:
            raise MergeError(f"{file}: its root transform differs from {self.first}'s; cannot merge them")
        view0, acc0, mesh0 = len(out["bufferViews"]), len(out["accessors"]), len(out["meshes"])
        label0 = len(self.labels)
        self.labels.extend(str(x) for x in (root["extras"]["grammarkit"].get("labels") or []))
        for view in doc.get("bufferViews", []):
            view = dict(view, buffer=0, byteOffset=view.get("byteOffset", 0) + self.size)
            out["bufferViews"].append(view)
        for acc in doc.get("accessors", []):
            acc = dict(acc)
            if "bufferView" in acc:
                acc["bufferView"] += view0
            out["accessors"].append(acc)
        self._add_meshes(doc, acc0)
        self._add_nodes(doc, root, item_id, mesh0, label0)
        self.chunks.append(binary)
        self.size += len(binary)

    def _add_meshes(self, doc: dict, acc0: int) -> None:
        out = self.out
        mat_map = {}
        for i, mat in enumerate(doc.get("materials", [])):
            key = json.dumps(mat, sort_keys=True)
            if key not in self.material_index:
                self.material_index[key] = len(out["materials"])
                out["materials"].append(mat)
            mat_map[i] = self.material_index[key]
        for mesh in doc.get("meshes", []):
            prims = []
            for prim in mesh.get("primitives", []):
                prim = dict(prim, attributes={k: v + acc0 for k, v in prim["attributes"].items()})
                if "indices" in prim:
                    prim["indices"] += acc0
                if "material" in prim:
                    prim["material"] = mat_map[prim["material"]]
                prims.append(prim)
            out["meshes"].append(dict(mesh, primitives=prims))

    def _add_nodes(self, doc: dict, root: dict, item_id: str, mesh0: int, label0: int) -> None:
        """Every node but the item's root (the merged file has one root for all items); the
        item's solids are named after it and carry its extras."""
        node0 = len(self.out["nodes"])
        root_index = doc["scenes"][doc.get("scene", 0)]["nodes"][0]
        item_extras = {k: v for k, v in (root.get("extras") or {}).items() if k != "grammarkit"}
        solids = root.get("children", [])
        new_index = {i: node0 + i - (i > root_index) for i in range(len(doc["nodes"])) if i != root_index}
        for i, node in enumerate(doc["nodes"]):
            if i == root_index:
                continue
            node = dict(node)
            if "mesh" in node:
                node["mesh"] += mesh0
            if "children" in node:
                node["children"] = [new_index[c] for c in node["children"]]
            extras = dict(node.get("extras") or {})
            if "label" in extras:
                extras["label"] = extras["label"] + label0
            if i in solids:
                node["name"] = item_id if len(solids) == 1 else f"{item_id}/{node.get('name', i)}"
                extras = {**item_extras, **extras, "item": item_id}
            if extras:
                node["extras"] = extras
            self.out["nodes"].append(node)
        self.children.extend(new_index[c] for c in solids)

    def glb(self, path: Path) -> bytes:
        """The merged GLB's bytes (its root and scene named after `path`)."""
        out = self.out
        if not self.children:
            raise MergeError(f"{path}: nothing to merge (no item was built)")
        marker = dict(self.marker or {})
        marker["labels"] = self.labels
        out["nodes"].append({"name": path.stem, **(self.placement or {}), "children": self.children,
                             "extras": {"grammarkit": marker}})
        out["scenes"] = [{"name": path.stem, "nodes": [len(out["nodes"]) - 1]}]
        out["buffers"] = [{"byteLength": self.size}]
        js = json.dumps(out, separators=(",", ":"), allow_nan=False).encode("utf-8")
        js += b" " * ((-len(js)) % 4)
        total = 12 + 8 + len(js) + 8 + self.size
        return b"".join([struct.pack("<4sII", b"glTF", 2, total), struct.pack("<I4s", len(js), b"JSON"),
                         js, struct.pack("<I4s", self.size, b"BIN\0"), *self.chunks])
