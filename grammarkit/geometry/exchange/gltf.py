"""GLB and glTF writers (the layout is described for users in docs/derive.md, "Files"):

- **+Y up.** Coordinates inside the file are the model's own (Z up, metres). The scene's one
  root node carries the rotation (x, y, z) -> (x, z, -y) that glTF's +Y-up convention asks
  for, and `extras.grammarkit = {"format": 2, "up": "+Z", ...}` so that grammarkit's readers
  (`meshio.load_mesh`, `tiling.read_assembly`) undo it and read back in the Z-up frame.
- **Materials.** One PBR material per distinct (material name, colour): `baseColorFactor` is
  the colour converted from sRGB to linear (glTF's colour factors are linear), metallic 0,
  roughness 0.8 (0.1 for glass), named after the grammar's `material("...")` or, when the
  terminal has none, after the colour. There are no vertex colours: a triangle's colour is its
  primitive's material, so nothing forces vertices apart.
- **Structure.** Below the root, one node per solid (a split model's building, an assembly's
  part `Type.N`), no two of them and the root with the same name (`paris (2)`, a root
  `paris (scene)` above a one-building `paris`); below a split model's node, one node per terminal name (`Window`, `Glass`,
  `Wall`...) whose `extras` hold the terminal, its rules, their source lines (`file:line`),
  object types, roles, materials and the label index.
- **Closed solids are one primitive.** A closed solid's triangles are ONE primitive over its
  one vertex set (no attribute seams), so every reader, `trimesh.load(path, force="mesh")`
  with nothing else included, gets the watertight manifold, one body per mass. glTF has no
  per-face attributes, so the terminals are per-face data in extras: the terminal nodes hold
  no mesh but their `faces` ranges, and the primitive's `extras.grammarkit` holds `runs`
  ([terminal node, material, first face, count]) and the `materials` they index (see
  `_one_primitive`); the primitive's own material is the most used one (what other viewers
  show). A textured closed solid is written the same way, untextured (its materials keep
  their colours and name their image in `extras.colormap`): TEXCOORD_0 needs a vertex per
  (position, uv) pair, and those seams make trimesh and three.js read the solid as open
  pieces. `texture_seams=True` writes textured solids with TEXCOORD_0 and seams instead (what
  a viewer textures). The surface layer (open faces, `--surfaces cga`) and, with
  `texture_seams=True`, textured solids keep one mesh per terminal with a primitive per
  material, all indexing one shared POSITION accessor.
- **Per-face labels.** Triangles are written grouped by label in the order of
  `extras.grammarkit.labels`; `face_labels(path)` in `meshio` reads the label of every face.
"""
from __future__ import annotations

import base64
import json
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ... import confine
from ...errors import ShapeError
from ...jsonable import to_jsonable
from .scene import DEFAULT_RGBA, Material, Scene, Solid, solids_of, srgb_to_linear

# Version of grammarkit's glTF layout, stored in the root node's extras (1: the old layout, no
# rotation, no marker; 2: a primitive per terminal and material; 3: a closed solid may be one
# primitive with its per-face data in extras). A file is marked 3 only when it holds such a
# solid, so files of the old layout (assemblies, one-material parts) keep their bytes; the
# readers read 2 and 3.
GLTF_FORMAT = 3
_GLTF_FORMAT_PER_PRIMITIVE = 2
# glTF quaternion (x, y, z, w) for -90 degrees about X: (x, y, z) -> (x, z, -y), Z-up to Y-up.
Z_UP_TO_Y_UP = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))
Z_UP_TO_Y_UP_MATRIX = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])


_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _USHORT, _UINT = 5126, 5123, 5125


class _GltfBuilder:
    """glTF 2.0 JSON + one binary buffer, written by hand: the layout above needs shared
    accessors across primitives, node extras and a root transform, which trimesh's exporter
    does not offer, and doing it directly is several times faster."""

    def __init__(self, ambiguous: set[str] = frozenset(), textures: str = "embed",
                 base: Path | None = None, texture_seams: bool = False) -> None:
        self.texture_seams = texture_seams  # textured closed solids with TEXCOORD_0 and seams
        self.ambiguous = ambiguous  # material names used with several colours
        self.textures = textures  # "embed" (image in the buffer) or "reference" (relative URI)
        self.base = base  # the output file's folder, for "reference"
        self.images: list[dict] = []
        self.gl_textures: list[dict] = []
        self.samplers: list[dict] = []
        self.image_index: dict[str, int | None] = {}
        self.chunks: list[bytes] = []
        self.size = 0
        self.views: list[dict] = []
        self.accessors: list[dict] = []
        self.materials: list[dict] = []
        self.material_index: dict[tuple[Material, bool], int] = {}
        self.meshes: list[dict] = []
        self.nodes: list[dict] = []

    def _view(self, data: bytes, target: int | None) -> int:
        pad = (-self.size) % 4
        if pad:
            self.chunks.append(b"\0" * pad)
            self.size += pad
        view = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:  # image data has no target
            view["target"] = target
        self.views.append(view)
        self.chunks.append(data)
        self.size += len(data)
        return len(self.views) - 1

    def positions(self, vertices: np.ndarray) -> int:
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        view = self._view(v.tobytes(), _ARRAY_BUFFER)
        self.accessors.append({"bufferView": view, "componentType": _FLOAT, "count": len(v), "type": "VEC3",
                               "min": [float(x) for x in v.min(axis=0)],
                               "max": [float(x) for x in v.max(axis=0)]})
        return len(self.accessors) - 1

    def indices(self, faces: np.ndarray, n_vertices: int) -> int:
        dtype, ctype = (np.uint16, _USHORT) if n_vertices < 65535 else (np.uint32, _UINT)
        f = np.ascontiguousarray(faces, dtype=dtype).reshape(-1)
        view = self._view(f.tobytes(), _ELEMENT_ARRAY_BUFFER)
        self.accessors.append({"bufferView": view, "componentType": ctype, "count": len(f), "type": "SCALAR"})
        return len(self.accessors) - 1

    def material(self, mat: Material, untextured: bool = False) -> int:
        idx = self.material_index.get((mat, untextured))
        if idx is None:
            self.materials.append(self.material_entry(mat, untextured))
            idx = self.material_index[(mat, untextured)] = len(self.materials) - 1
        return idx

    def material_entry(self, mat: Material, untextured: bool = False) -> dict:
        """The glTF material object of `mat` (not yet part of the document); `untextured`:
        without its baseColorTexture (a seamless solid has no TEXCOORD_0), the image named in
        `extras.colormap` only."""
        lin = srgb_to_linear(np.asarray(mat.rgba[:3], dtype=np.float64) / 255.0)
        glassy = bool(mat.name) and "glass" in mat.name.lower()
        name = mat.label
        if mat.texture is not None and not mat.name:  # a textured material is named by its image
            name = f"{Path(mat.texture).name} #{mat.rgba[0]:02x}{mat.rgba[1]:02x}{mat.rgba[2]:02x}"
        if mat.name in self.ambiguous:
            name = "{} #{:02x}{:02x}{:02x}".format(mat.name, *mat.rgba[:3])
        entry = {"name": name,
                 "pbrMetallicRoughness": {
                     "baseColorFactor": [round(float(x), 6) for x in lin] + [round(mat.rgba[3] / 255.0, 6)],
                     "metallicFactor": 0.0, "roughnessFactor": 0.1 if glassy else 0.8},
                 "extras": {"srgb": mat.label if not mat.name else "#{:02x}{:02x}{:02x}".format(*mat.rgba[:3])}}
        if mat.metallic is not None:
            entry["pbrMetallicRoughness"]["metallicFactor"] = round(float(mat.metallic), 6)
        if mat.roughness is not None:
            entry["pbrMetallicRoughness"]["roughnessFactor"] = round(float(mat.roughness), 6)
        if mat.texture is not None:
            tex = None if untextured else self.texture(mat.texture)
            if tex is not None:
                entry["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex}
            elif not untextured:  # (a seamless solid does not read its images at all)
                entry["extras"]["missing_texture"] = mat.texture
            entry["extras"]["colormap"] = Path(mat.texture).name
        if mat.extras:
            entry["extras"]["cga"] = {k: v for k, v in mat.extras}
        if mat.rgba[3] < 255:
            entry["alphaMode"] = "BLEND"
        if mat.double_sided:
            entry["doubleSided"] = True
            entry["extras"]["surface"] = True
            name = entry["name"] = f"{name} (surface)"
        if mat.name:
            entry["extras"]["material"] = mat.name
        return entry

    def has_texture(self, mat: Material) -> bool:
        """Whether `mat`'s primitives carry TEXCOORD_0 (its texture file can be written)."""
        return mat.texture is not None and self.texture(mat.texture) is not None

    def texture(self, path: str) -> int | None:
        """The glTF texture of an image file (embedded in the buffer, or referenced by a URI
        relative to the output file), or None when the file cannot be used: not found, or not
        PNG/JPEG (the only image formats of core glTF)."""
        if path in self.image_index:
            return self.image_index[path]
        mime = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}.get(Path(path).suffix.lower())
        file = Path(path)
        if not path.startswith("builtin:"):
            confine.check(path, what="texture file")  # the image is read into the file: not from outside
        if mime is None or path.startswith("builtin:") or not file.is_file():
            self.image_index[path] = None
            return None
        if self.textures == "reference":
            import os
            from urllib.parse import quote

            rel = os.path.relpath(file.resolve(), (self.base or Path(".")).resolve())
            image: dict = {"uri": quote(rel.replace(os.sep, "/")), "name": file.name}
        else:
            image = {"bufferView": self._view(file.read_bytes(), None), "mimeType": mime, "name": file.name}
        self.images.append(image)
        if not self.samplers:  # CGA textures tile: repeat in both directions
            self.samplers.append({"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497})
        self.gl_textures.append({"source": len(self.images) - 1, "sampler": 0})
        self.image_index[path] = idx = len(self.gl_textures) - 1
        return idx

    def texcoords(self, uv: np.ndarray) -> int:
        # glTF's uv origin is the image's top left, CGA's its bottom left: v -> 1 - v
        t = np.ascontiguousarray(np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]), dtype=np.float32)
        view = self._view(t.tobytes(), _ARRAY_BUFFER)
        self.accessors.append({"bufferView": view, "componentType": _FLOAT, "count": len(t), "type": "VEC2"})
        return len(self.accessors) - 1

    def node(self, entry: dict) -> int:
        self.nodes.append(entry)
        return len(self.nodes) - 1

    def document(self, scene: Scene, root_children: list[int]) -> dict:
        root_extras = dict(scene.extras)
        root_extras["grammarkit"] = {"format": GLTF_FORMAT, "up": "+Z",
                                     "note": "this node rotates the model's Z-up frame to glTF's +Y up"}
        taken = _unique_node_names(self.nodes, root_children)
        root_name = scene.name if scene.name not in taken else f"{scene.name} (scene)"
        root = self.node({"name": root_name, "rotation": [float(x) for x in Z_UP_TO_Y_UP],
                          "children": root_children, "extras": root_extras})
        doc: dict[str, Any] = {
            "asset": {"version": "2.0", "generator": "grammarkit"},
            "scene": 0, "scenes": [{"name": scene.name, "nodes": [root]}],
            "nodes": self.nodes, "meshes": self.meshes, "materials": self.materials,
            "accessors": self.accessors, "bufferViews": self.views,
            "buffers": [{"byteLength": self.size}],
        }
        if self.images:
            doc.update(images=self.images, textures=self.gl_textures, samplers=self.samplers)
        return doc


def _unique_node_names(nodes: list[dict], solid_nodes: list[int]) -> set[str]:
    """Give the solid nodes (the root's children) names no other solid node has, in file order
    (`paris`, `paris (2)`, ...), and return them: a viewer's outline or an animation target
    then names one node. Terminal nodes keep their terminal's name (unique within their solid,
    the label grammarkit's readers take), as the glTF spec allows; the root node gets a name of
    its own when a solid has the scene's (a one-building model is named after its grammar)."""
    taken: set[str] = set()
    for k in solid_nodes:
        name = base = str(nodes[k].get("name", ""))
        copy = 1
        while name in taken:
            copy += 1
            name = f"{base} ({copy})"
        nodes[k]["name"] = name
        taken.add(name)
    return taken


def _build_gltf(scene: Scene, textures: str = "embed", base: Path | None = None,
                texture_seams: bool = False) -> tuple[dict, bytes]:
    if textures not in ("embed", "reference"):
        raise ShapeError(f"textures must be 'embed' or 'reference', got {textures!r}")
    colours_of: dict[str, set] = {}
    for solid in scene.solids:
        for mat in solid.materials:
            if mat.name:
                colours_of.setdefault(mat.name, set()).add(mat.rgba)
    texture_seams = texture_seams or scene.texture_seams
    b = _GltfBuilder({n for n, c in colours_of.items() if len(c) > 1}, textures, base, texture_seams)
    children: list[int] = []
    shared_mesh: dict[bytes, int] = {}
    all_labels: list[str] = []
    one_primitive_solids = 0
    for solid in scene.solids:
        F = np.asarray(solid.faces, dtype=np.int64)
        if len(F) == 0:
            continue
        node_entry: dict[str, Any] = {"name": solid.name}
        if solid.matrix is not None:
            node_entry["matrix"] = [float(x) for x in np.asarray(solid.matrix, dtype=np.float64).T.reshape(-1)]
        if solid.extras:
            node_entry["extras"] = to_jsonable(solid.extras)
        if solid.key is not None and solid.key in shared_mesh:
            node_entry["mesh"] = shared_mesh[solid.key]
            children.append(b.node(node_entry))
            continue
        pos = b.positions(solid.vertices)
        nv = len(solid.vertices)
        # Triangles sorted by (group, material): each run becomes a primitive. Stable sort,
        # so the order within a run is the model's and the file is deterministic.
        n_mat = max(len(solid.materials), 1)
        key = np.asarray(solid.face_group, dtype=np.int64) * n_mat + np.asarray(solid.face_material, dtype=np.int64)
        order = np.argsort(key, kind="stable")
        skey = key[order]
        cuts = np.flatnonzero(np.diff(skey)) + 1
        starts = np.concatenate([[0], cuts])
        ends = np.concatenate([cuts, [len(skey)]])
        textured_solid = solid.uv is not None and any(m.texture for m in solid.materials)
        seamless = not solid.extras.get("surface") and not (textured_solid and texture_seams)
        if seamless and (len(starts) > 1 or textured_solid):
            # a closed solid in several groups/materials: ONE primitive (see _one_primitive)
            node_entry.update(_one_primitive(b, solid, F[order], pos, skey, starts, ends, n_mat, all_labels))
            one_primitive_solids += 1
            if solid.key is not None:
                shared_mesh[solid.key] = node_entry["mesh"]
            children.append(b.node(node_entry))
            continue
        prims_by_group: dict[int, list[dict]] = {}
        textured: list[tuple[int, int, np.ndarray]] = []  # (group, material, face indices)
        for s, e in zip(starts.tolist(), ends.tolist()):
            k = int(skey[s])
            g, m = divmod(k, n_mat)
            mat = solid.materials[m] if solid.materials else Material(None, DEFAULT_RGBA)
            if solid.uv is not None and b.has_texture(mat):
                textured.append((g, m, order[s:e]))
                continue
            acc = b.indices(F[order[s:e]], nv)
            prim = {"attributes": {"POSITION": pos}, "indices": acc, "mode": 4, "material": b.material(mat)}
            prims_by_group.setdefault(g, []).append(prim)
        if textured:
            _textured_primitives(b, solid, F, textured, prims_by_group)
        node_entry.update(_per_terminal_meshes(b, solid, prims_by_group, all_labels))
        if solid.key is not None and "mesh" in node_entry:
            shared_mesh[solid.key] = node_entry["mesh"]
        children.append(b.node(node_entry))
    if not b.meshes:
        raise ShapeError("nothing to export: the model has no triangles")
    doc = b.document(scene, children)
    marker = doc["nodes"][-1]["extras"]["grammarkit"]
    marker["labels"] = all_labels
    if not one_primitive_solids:
        marker["format"] = _GLTF_FORMAT_PER_PRIMITIVE
    pad = (-b.size) % 4
    binary = b"".join(b.chunks) + b"\0" * pad
    doc["buffers"][0]["byteLength"] = b.size
    return doc, binary


def _per_terminal_meshes(b: _GltfBuilder, solid: Solid, prims_by_group: dict[int, list[dict]],
                         all_labels: list[str]) -> dict:
    """The solid node's mesh (one group) or its terminal child nodes, each with a mesh of one
    primitive per material: the layout of surfaces, textured solids and one-material parts."""
    if len(prims_by_group) == 1 and len(solid.groups) == 1:
        (prims,) = prims_by_group.values()
        b.meshes.append({"name": solid.name, "primitives": prims})
        all_labels.append(solid.groups[0][0])
        return {"mesh": len(b.meshes) - 1}
    kids = []
    for g, prims in sorted(prims_by_group.items()):
        gname, gextras = solid.groups[g]
        b.meshes.append({"name": gname, "primitives": prims})
        extras = dict(gextras)
        extras["label"] = len(all_labels)
        all_labels.append(gname)
        kids.append(b.node({"name": gname, "mesh": len(b.meshes) - 1, "extras": to_jsonable(extras)}))
    return {"children": kids}


def _one_primitive(b: _GltfBuilder, solid: Solid, faces: np.ndarray, pos: int, skey: np.ndarray,
                   starts: np.ndarray, ends: np.ndarray, n_mat: int, all_labels: list[str]) -> dict:
    """The mesh and terminal nodes of a closed solid: its triangles (sorted by group, then
    material) as one primitive over the solid's one vertex set, so that every glTF reader,
    trimesh's `load(path, force="mesh")` included, gets the watertight manifold without
    welding anything. glTF has no per-face attributes and any per-vertex one (a colour, a
    feature id) would split vertices at its seams, so the per-face data rides in extras:

    - the primitive's `extras.grammarkit.runs`: `[group, material, first face, face count]` for
      each run of triangles, `group` indexing the solid node's `children`, `material` the
      primitive's `extras.grammarkit.materials` (glTF material objects, kept in the extras:
      a material no primitive uses would be an unused object, and indices into the file's
      own list would break when files are merged); grammarkit's readers colour every face
      from them. The primitive's own material is the one covering most triangles (what other
      viewers show);
    - one child node per terminal without a mesh, its `extras` as before (terminal, rules,
      sources, ..., `label`) plus `faces`: its `[first face, face count]` ranges."""
    face_mat = skey % n_mat
    counts = np.bincount(face_mat, minlength=n_mat)
    main = int(np.argmax(counts))  # ties: the first material, so the file is deterministic
    palette = solid.materials or [Material(None, DEFAULT_RGBA)]
    used = sorted(set((skey[starts] % n_mat).tolist()))
    material_of = {m: i for i, m in enumerate(used)}
    runs, ranges = [], {}  # ranges: group -> [[first face, count], ...]
    for s, e in zip(starts.tolist(), ends.tolist()):
        g, m = divmod(int(skey[s]), n_mat)
        ranges.setdefault(g, []).append([s, e - s])
    kids = []
    position_of = {}
    for g in sorted(ranges):
        gname, gextras = solid.groups[g]
        extras = dict(gextras)
        extras["label"] = len(all_labels)
        extras["faces"] = ranges[g]
        all_labels.append(gname)
        position_of[g] = len(kids)
        kids.append(b.node({"name": gname, "extras": to_jsonable(extras)}))
    for s, e in zip(starts.tolist(), ends.tolist()):
        g, m = divmod(int(skey[s]), n_mat)
        runs.append([position_of[g], material_of[m], s, e - s])
    acc = b.indices(faces, len(solid.vertices))
    # no TEXCOORD_0 here (it would need seams): textured materials are written untextured
    prim = {"attributes": {"POSITION": pos}, "indices": acc, "mode": 4,
            "material": b.material(palette[main], untextured=True),
            "extras": {"grammarkit": {"materials": [b.material_entry(palette[m], untextured=True) for m in used],
                                      "runs": runs}}}
    b.meshes.append({"name": solid.name, "primitives": [prim]})
    return {"mesh": len(b.meshes) - 1, "children": kids}


def _textured_primitives(b: _GltfBuilder, solid: Solid, F: np.ndarray, textured: list,
                         prims_by_group: dict) -> None:
    """Primitives of textured materials: their own vertex set, one vertex per (position, uv)
    pair (a vertex on a texture seam needs two uvs), with POSITION values copied bit for bit
    from the solid's vertices, so a reader welding by position still gets the closed solid."""
    uv = np.nan_to_num(np.asarray(solid.uv, dtype=np.float64), nan=0.0)
    faces = np.concatenate([f for _, _, f in textured])
    corner_v = F[faces].reshape(-1)
    corner_uv = np.ascontiguousarray(uv[faces].reshape(-1, 2), dtype=np.float32)
    # key: the vertex index and the uv's float32 bits (exact: equal floats weld)
    bits = corner_uv.view(np.uint32).astype(np.uint64)
    keys = np.column_stack([corner_v.astype(np.uint64), bits[:, 0], bits[:, 1]])
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    first = np.zeros(len(uniq), dtype=np.int64)
    first[inv[::-1]] = np.arange(len(inv))[::-1]
    V = np.asarray(solid.vertices)[uniq[:, 0].astype(np.int64)]
    pos = b.positions(V)
    tc = b.texcoords(corner_uv[first].astype(np.float64))
    new_faces = inv.reshape(-1, 3)
    at = 0
    for g, m, f in textured:
        n = len(f)
        acc = b.indices(new_faces[at:at + n], len(V))
        at += n
        prim = {"attributes": {"POSITION": pos, "TEXCOORD_0": tc}, "indices": acc, "mode": 4,
                "material": b.material(solid.materials[m])}
        prims_by_group.setdefault(g, []).append(prim)


def _json_bytes(doc: dict) -> bytes:
    return json.dumps(doc, separators=(",", ":"), sort_keys=False, allow_nan=False).encode("utf-8")


def encode_glb(obj: Any, textures: str = "embed", base: Path | None = None,
               texture_seams: bool = False) -> bytes:
    """GLB bytes. Texture images are embedded (`textures="embed"`) or referenced by URIs
    relative to the folder `base` the file will be written to (`"reference"`). Textured
    closed solids are written seamless and untextured unless `texture_seams` (module doc)."""
    doc, binary = _build_gltf(solids_of(obj), textures, base, texture_seams)
    js = _json_bytes(doc)
    js += b" " * ((-len(js)) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return b"".join([struct.pack("<4sII", b"glTF", 2, total),
                     struct.pack("<I4s", len(js), b"JSON"), js,
                     struct.pack("<I4s", len(binary), b"BIN\0"), binary])


def encode_gltf(obj: Any, textures: str = "embed", base: Path | None = None,
                texture_seams: bool = False) -> bytes:
    doc, binary = _build_gltf(solids_of(obj), textures, base, texture_seams)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binary).decode("ascii")
    doc["buffers"][0]["byteLength"] = len(binary)
    return json.dumps(doc, indent=1, allow_nan=False).encode("utf-8")
