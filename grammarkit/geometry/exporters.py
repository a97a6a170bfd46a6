"""Model writers for GLB, glTF, OBJ, STL and PLY, registered as the `core-exporters` plugin.

Every writer turns a split `Model`, a tiling `Assembly`, a trimesh Scene or a Trimesh into
bytes (`encode_*`); the run layer's writer (`grammarkit.fileio.write_files`) writes them
atomically. All formats share one intermediate form, a list of `Solid`s: one vertex set each
(never split at colour seams), its triangles grouped into named groups, each triangle with a
material (a name and an sRGB colour).

glTF / GLB (the layout is described for users in docs/derive.md, "Files"):

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
  part `Type.N`); below a split model's node, one node per terminal name (`Window`, `Glass`,
  `Wall`...) whose `extras` hold the terminal, its rules, their source lines (`file:line`),
  object types, roles, materials and the label index.
- **Closed solids are one primitive.** A closed solid's triangles are ONE primitive over its
  one vertex set (no attribute seams), so every reader, `trimesh.load(path, force="mesh")`
  with nothing else included, gets the watertight manifold, one body per mass. glTF has no
  per-face attributes, so the terminals are per-face data in extras: the terminal nodes hold
  no mesh but their `faces` ranges, and the primitive's `extras.grammarkit` holds `runs`
  ([terminal node, material, first face, count]) and the `materials` they index (see
  `_one_primitive`); the primitive's own material is the most used one (what other viewers
  show). The surface layer (open faces, `--surfaces cga`) and textured solids (TEXCOORD_0
  needs seams) are exempt: they keep one mesh per terminal with a primitive per material,
  all indexing one shared POSITION accessor.
- **Per-face labels.** Triangles are written grouped by label in the order of
  `extras.grammarkit.labels`; `face_labels(path)` in `meshio` reads the label of every face.

OBJ writes one `o`/`g` group per solid, `usemtl`-free vertex colours (`v x y z r g b`, sRGB,
split at colour seams: OBJ readers weld by position) and a `# extras {...}` line; PLY one
mesh with face colours; STL one mesh. All in the model's Z-up frame.
"""
from __future__ import annotations

import base64
import json
import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ..errors import ShapeError
from ..jsonable import to_jsonable
from ..registry import ExporterSpec

__all__ = ["OutputError", "Solid", "Material", "atomic_output", "encode", "encode_with", "export",
           "exporter_for", "known_formats", "scene_from_parts", "solids_of", "to_scene",
           "grammarkit_exporters", "srgb_to_linear", "GLTF_FORMAT", "Z_UP_TO_Y_UP"]

# The atomic writer is shared by every command that writes files (fileio.py has no heavy imports).
from ..fileio import OutputError, atomic_output  # noqa: E402

# Version of grammarkit's glTF layout, stored in the root node's extras (1: the old layout, no
# rotation, no marker; 2: a primitive per terminal and material; 3: this one, a closed solid
# as one primitive with its per-face data in extras). The readers read 2 and 3.
GLTF_FORMAT = 3
# glTF quaternion (x, y, z, w) for -90 degrees about X: (x, y, z) -> (x, z, -y), Z-up to Y-up.
Z_UP_TO_Y_UP = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))
Z_UP_TO_Y_UP_MATRIX = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])

DEFAULT_RGBA = (200, 200, 200, 255)


# ------------------------------------------------------------------------------------------
# The intermediate form
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Material:
    """A PBR material: `name` (the grammar's material name or the colour) and sRGB bytes."""

    name: str | None
    rgba: tuple[int, int, int, int]
    # surfaces (open faces, see docs/language.md "Solids and surfaces") are seen from both sides
    double_sided: bool = False
    # CGA materials (docs/cga.md, "Texturing"): the colour texture's file (absolute path), PBR
    # factors, and the other material attributes as sorted (key, value) pairs (kept in extras)
    texture: str | None = None
    metallic: float | None = None
    roughness: float | None = None
    extras: tuple = ()

    @property
    def label(self) -> str:
        return self.name or "#{:02x}{:02x}{:02x}".format(*self.rgba[:3])


@dataclass
class Solid:
    """One closed (or at least one-vertex-set) mesh with its triangles in named groups.

    `face_group[i]` indexes `groups` (node name, extras); `face_material[i]` indexes
    `materials`. `matrix` places the solid under the root (model frame). `key`, when set,
    lets solids with equal keys share one glTF mesh (instancing of identical part geometry)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    face_group: np.ndarray
    groups: list[tuple[str, dict]]
    face_material: np.ndarray
    materials: list[Material]
    matrix: np.ndarray | None = None
    extras: dict = field(default_factory=dict)
    key: bytes | None = None
    # texture coordinates at the corners of every face, (n, 3, 2), NaN where a face has none;
    # written (as TEXCOORD_0) for the faces whose material has a texture
    uv: np.ndarray | None = None

    def face_rgba(self) -> np.ndarray:
        palette = np.array([m.rgba for m in self.materials] or [DEFAULT_RGBA], dtype=np.uint8)
        return palette[self.face_material]

    def world_vertices(self) -> np.ndarray:
        v = np.asarray(self.vertices, dtype=np.float64)
        if self.matrix is None:
            return v
        m = np.asarray(self.matrix, dtype=np.float64)
        return v @ m[:3, :3].T + m[:3, 3]

    def world_faces(self) -> np.ndarray:
        f = np.asarray(self.faces, dtype=np.int64)
        if self.matrix is not None and np.linalg.det(np.asarray(self.matrix)[:3, :3]) < 0:
            f = f[:, ::-1]  # a mirroring placement flips the winding
        return f


@dataclass
class Scene:
    """What a file holds: solids, the root's name and extras."""

    name: str
    solids: list[Solid]
    extras: dict = field(default_factory=dict)


def srgb_to_linear(c: np.ndarray | Sequence[float]) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear light (IEC 61966-2-1), as glTF's factors want."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _materials_from_colors(rgba: np.ndarray) -> tuple[np.ndarray, list[Material]]:
    """Per-face material indices for per-face colours (one unnamed material per colour).

    Colours are packed into one uint32 key: 1-D np.unique is ~25x faster than axis=0."""
    rgba = np.ascontiguousarray(rgba, dtype=np.uint8).reshape(-1, 4)
    keys = rgba.view(np.uint32).reshape(-1)
    uniq, inv = np.unique(keys, return_inverse=True)
    mats = [Material(None, tuple(int(x) for x in u)) for u in uniq.view(np.uint8).reshape(-1, 4)]
    return inv.reshape(-1).astype(np.int64), mats


def _trimesh_solid(mesh: Any, name: str, matrix: np.ndarray | None, extras: dict) -> Solid:
    if mesh.visual.kind in ("face", "vertex"):
        face_material, materials = _materials_from_colors(mesh.visual.face_colors)
    else:
        face_material, materials = np.zeros(len(mesh.faces), np.int64), [Material(None, DEFAULT_RGBA)]
    return Solid(name, np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64),
                 np.zeros(len(mesh.faces), np.int64), [(name, {})], face_material, materials,
                 matrix, dict(extras))


def _scene_solids(scene: Any) -> list[Solid]:
    import trimesh

    out = []
    graph = scene.graph
    for node in graph.nodes_geometry:
        matrix, gname = graph[node]
        mesh = scene.geometry.get(gname)
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        parent = graph.transforms.parents.get(node)
        extras = graph.transforms.edge_data.get((parent, node), {}).get("metadata") or {}
        m = np.asarray(matrix, dtype=np.float64)
        out.append(_trimesh_solid(mesh, str(node), None if np.allclose(m, np.eye(4)) else m,
                                  to_jsonable(dict(extras))))
    return out


# A colour per part type, so that assemblies show their segmentation (a qualitative palette,
# Okabe & Ito's colour-blind-safe eight plus darker and lighter variants).
TYPE_PALETTE = ("#e69f00", "#56b4e9", "#009e73", "#f0e442", "#0072b2", "#d55e00", "#cc79a7",
                "#999999", "#8c5a00", "#2b7fb0", "#006b4f", "#b8ac2e", "#004c7a", "#9c4500",
                "#8f5477", "#5e5e5e")


def _hex_rgba(h: str) -> tuple[int, int, int, int]:
    h = h.lstrip("#")
    return (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16), 255)


def type_colors(types: Iterable[str]) -> dict[str, tuple[int, int, int, int]]:
    """A deterministic colour per part type (sorted type names take palette entries in turn)."""
    return {t: _hex_rgba(TYPE_PALETTE[i % len(TYPE_PALETTE)]) for i, t in enumerate(sorted(set(types)))}


def _assembly_solids(parts: Sequence[Any]) -> list[Solid]:
    """One solid per part: its geometry in its own frame with `transform` as the node matrix
    (identical local geometry shares one glTF mesh), type in the extras, a colour per type."""
    colors = type_colors(str(p.type) for p in parts)
    out = []
    for p in parts:
        mesh = p.mesh
        T = np.asarray(getattr(p, "transform", np.eye(4)), dtype=np.float64)
        if T.shape != (4, 4) or not np.isfinite(T).all() or abs(np.linalg.det(T[:3, :3])) < 1e-12:
            T = np.eye(4)
        V = np.asarray(mesh.vertices, dtype=np.float64)
        if not np.allclose(T, np.eye(4)):
            inv = np.linalg.inv(T)
            V = V @ inv[:3, :3].T + inv[:3, 3]
        F = np.asarray(mesh.faces, dtype=np.int64)
        extras = {"type": str(p.type), "id": str(p.id)}
        meta = getattr(p, "meta", None) or {}
        extras.update({k: v for k, v in to_jsonable(dict(meta)).items() if k not in extras})
        key = np.round(V, 6).astype(np.float32).tobytes() + F.tobytes() + str(p.type).encode()
        out.append(Solid(str(p.id), V, F, np.zeros(len(F), np.int64), [(str(p.id), {})],
                         np.zeros(len(F), np.int64), [Material(str(p.type), colors[str(p.type)])],
                         None if np.allclose(T, np.eye(4)) else T, extras, key))
    return out


def scene_from_parts(parts: Iterable[Any]) -> Any:
    """A trimesh.Scene with one node per part, named by the part id with its type in the node
    extras. `parts`: objects with `.id`, `.type`, `.mesh` (world coordinates) and optional
    `.meta`, or `(id, type, mesh[, meta])` tuples."""
    import trimesh

    scene = trimesh.Scene()
    for part in parts:
        if isinstance(part, tuple):
            pid, ptype, mesh, *rest = part
            meta = rest[0] if rest else {}
        else:
            pid, ptype, mesh = part.id, part.type, part.mesh
            meta = getattr(part, "meta", {}) or {}
        extras = {"type": str(ptype), "id": str(pid)}
        extras.update({k: v for k, v in to_jsonable(dict(meta)).items() if k not in extras})
        scene.add_geometry(mesh, node_name=str(pid), geom_name=str(pid), metadata=extras)
    return scene


def to_scene(obj: Any) -> Any:
    """A trimesh.Scene from a Scene, a Trimesh, a model (`.to_scene()`) or an assembly."""
    import trimesh

    if isinstance(obj, trimesh.Scene):
        return obj
    if isinstance(obj, trimesh.Trimesh):
        name = str(obj.metadata.get("name") or "mesh") if obj.metadata else "mesh"
        scene = trimesh.Scene()
        scene.add_geometry(obj, node_name=name, geom_name=name)
        return scene
    if callable(getattr(obj, "to_scene", None)):
        return to_scene(obj.to_scene())
    if hasattr(obj, "parts") and not isinstance(obj, (str, bytes)):
        return scene_from_parts(obj.parts)
    raise ShapeError(f"cannot export a {type(obj).__name__}: expected a trimesh.Scene, a "
                     "trimesh.Trimesh, a model or an assembly")


def _trimesh_scene(obj: Any) -> Scene | None:
    """The intermediate form of a trimesh Trimesh or Scene, else None. An object can only be
    one of those if trimesh is loaded: a split Model is encoded without importing trimesh (and
    scipy behind it), which a one-building derive would otherwise pay on start-up."""
    import sys

    trimesh = sys.modules.get("trimesh")
    if trimesh is None:
        return None
    if isinstance(obj, trimesh.Trimesh):
        name = str((obj.metadata or {}).get("name") or "mesh")
        return Scene(name, [_trimesh_solid(obj, name, None, {})])
    if isinstance(obj, trimesh.Scene):
        return Scene(str(obj.metadata.get("name") or "scene"), _scene_solids(obj),
                     to_jsonable({k: v for k, v in obj.metadata.items() if k != "name"}))
    return None


def solids_of(obj: Any) -> Scene:
    """The intermediate form of a split Model (`.export_scene()`), an assembly (`.parts`), a
    trimesh Scene or a Trimesh."""
    if callable(getattr(obj, "export_scene", None)):
        scene = obj.export_scene()
    else:
        scene = _trimesh_scene(obj)
    if scene is None:
        if hasattr(obj, "parts") and not isinstance(obj, (str, bytes)):
            parts = list(obj.parts)
            colors = type_colors(p.type for p in parts)
            scene = Scene(str(getattr(obj, "name", "") or "assembly"), _assembly_solids(parts),
                          {"kind": "assembly", "part_types": {t: "#{:02x}{:02x}{:02x}".format(*c[:3])
                                                             for t, c in colors.items()}})
        elif callable(getattr(obj, "to_scene", None)):
            return solids_of(obj.to_scene())
        else:
            raise ShapeError(f"cannot export a {type(obj).__name__}: expected a trimesh.Scene, a "
                             "trimesh.Trimesh, a model or an assembly")
    if not any(len(s.faces) for s in scene.solids):
        raise ShapeError("nothing to export: the model has no triangles")
    return scene


# ------------------------------------------------------------------------------------------
# glTF
# ------------------------------------------------------------------------------------------
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _USHORT, _UINT = 5126, 5123, 5125


class _GltfBuilder:
    """glTF 2.0 JSON + one binary buffer, written by hand: the layout above needs shared
    accessors across primitives, node extras and a root transform, which trimesh's exporter
    does not offer, and doing it directly is several times faster."""

    def __init__(self, ambiguous: set[str] = frozenset(), textures: str = "embed",
                 base: Path | None = None) -> None:
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
        self.material_index: dict[Material, int] = {}
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

    def material(self, mat: Material) -> int:
        idx = self.material_index.get(mat)
        if idx is None:
            self.materials.append(self.material_entry(mat))
            idx = self.material_index[mat] = len(self.materials) - 1
        return idx

    def material_entry(self, mat: Material) -> dict:
        """The glTF material object of `mat` (not yet part of the document)."""
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
            tex = self.texture(mat.texture)
            if tex is not None:
                entry["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex}
            else:
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
        root = self.node({"name": scene.name, "rotation": [float(x) for x in Z_UP_TO_Y_UP],
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


def _build_gltf(scene: Scene, textures: str = "embed", base: Path | None = None) -> tuple[dict, bytes]:
    if textures not in ("embed", "reference"):
        raise ShapeError(f"textures must be 'embed' or 'reference', got {textures!r}")
    colours_of: dict[str, set] = {}
    for solid in scene.solids:
        for mat in solid.materials:
            if mat.name:
                colours_of.setdefault(mat.name, set()).add(mat.rgba)
    b = _GltfBuilder({n for n, c in colours_of.items() if len(c) > 1}, textures, base)
    children: list[int] = []
    shared_mesh: dict[bytes, int] = {}
    all_labels: list[str] = []
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
        if len(starts) > 1 and not solid.extras.get("surface") and not any(m.texture for m in solid.materials):
            # a closed solid in several groups/materials: ONE primitive (see _one_primitive)
            node_entry.update(_one_primitive(b, solid, F[order], pos, skey, starts, ends, n_mat, all_labels))
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
        single = len(prims_by_group) == 1 and len(solid.groups) == 1
        if single:
            (prims,) = prims_by_group.values()
            b.meshes.append({"name": solid.name, "primitives": prims})
            node_entry["mesh"] = len(b.meshes) - 1
            if solid.key is not None:
                shared_mesh[solid.key] = node_entry["mesh"]
            all_labels.append(solid.groups[0][0])
        else:
            kids = []
            for g, prims in sorted(prims_by_group.items()):
                gname, gextras = solid.groups[g]
                b.meshes.append({"name": gname, "primitives": prims})
                extras = dict(gextras)
                extras["label"] = len(all_labels)
                all_labels.append(gname)
                kids.append(b.node({"name": gname, "mesh": len(b.meshes) - 1, "extras": to_jsonable(extras)}))
            node_entry["children"] = kids
        children.append(b.node(node_entry))
    if not b.meshes:
        raise ShapeError("nothing to export: the model has no triangles")
    doc = b.document(scene, children)
    doc["nodes"][-1]["extras"]["grammarkit"]["labels"] = all_labels
    pad = (-b.size) % 4
    binary = b"".join(b.chunks) + b"\0" * pad
    doc["buffers"][0]["byteLength"] = b.size
    return doc, binary


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
    prim = {"attributes": {"POSITION": pos}, "indices": acc, "mode": 4, "material": b.material(palette[main]),
            "extras": {"grammarkit": {"materials": [b.material_entry(palette[m]) for m in used],
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


def encode_glb(obj: Any, textures: str = "embed", base: Path | None = None) -> bytes:
    """GLB bytes. Texture images are embedded (`textures="embed"`) or referenced by URIs
    relative to the folder `base` the file will be written to (`"reference"`)."""
    doc, binary = _build_gltf(solids_of(obj), textures, base)
    js = _json_bytes(doc)
    js += b" " * ((-len(js)) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return b"".join([struct.pack("<4sII", b"glTF", 2, total),
                     struct.pack("<I4s", len(js), b"JSON"), js,
                     struct.pack("<I4s", len(binary), b"BIN\0"), binary])


def encode_gltf(obj: Any, textures: str = "embed", base: Path | None = None) -> bytes:
    doc, binary = _build_gltf(solids_of(obj), textures, base)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binary).decode("ascii")
    doc["buffers"][0]["byteLength"] = len(binary)
    return json.dumps(doc, indent=1, allow_nan=False).encode("utf-8")


# ------------------------------------------------------------------------------------------
# OBJ, STL, PLY (Z-up, world coordinates)
# ------------------------------------------------------------------------------------------
def _split_color_seams(faces: np.ndarray, face_material: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(vertex index of each new vertex, new faces): one vertex per (vertex, material) pair in
    use, so that per-face colours survive formats that only store vertex colours. 1-D keys."""
    faces = np.asarray(faces, dtype=np.int64)
    n_mat = int(face_material.max()) + 1 if len(face_material) else 1
    keys = faces.reshape(-1) * n_mat + np.repeat(np.asarray(face_material, dtype=np.int64), 3)
    uniq, inv = np.unique(keys, return_inverse=True)
    return uniq // n_mat, inv.reshape(-1, 3)


def _fmt_rows(fmt: str, rows: np.ndarray) -> str:
    """Format a 2-D array as text lines, one `fmt % row` per line, in one call."""
    if len(rows) == 0:
        return ""
    return ((fmt + "\n") * len(rows)) % tuple(rows.reshape(-1).tolist())


def encode_obj(obj: Any) -> bytes:
    """OBJ with one `o`/`g` group per solid (vertex colours as `v x y z r g b`, sRGB in 0..1)
    and the solid's extras as a `# extras {...}` comment line that `load_mesh` reads back."""
    scene = solids_of(obj)
    out = ["# written by grammarkit (Z up, metres)\n"]
    offset = 1
    for solid in scene.solids:
        if len(solid.faces) == 0:
            continue
        src, faces = _split_color_seams(solid.world_faces(), solid.face_material)
        v = solid.world_vertices()[src]
        rgba = solid.face_rgba()
        vcol = np.zeros((len(src), 3), dtype=np.float64)
        vcol[faces.reshape(-1)] = np.repeat(rgba[:, :3], 3, axis=0) / 255.0
        out.append(f"o {solid.name}\ng {solid.name}\n")
        if solid.extras:
            out.append("# extras " + json.dumps(to_jsonable(solid.extras), sort_keys=True) + "\n")
        out.append(_fmt_rows("v %.9g %.9g %.9g %.4g %.4g %.4g", np.column_stack([v, vcol])))
        out.append(_fmt_rows("f %d %d %d", faces + offset))
        offset += len(v)
    return "".join(out).encode("utf-8")


def _world_mesh(obj: Any, surfaces: bool = True) -> Any:
    """All solids as one mesh in world coordinates with face colours (without a split model's
    surface layer when `surfaces` is False)."""
    import trimesh

    scene = solids_of(obj)
    verts, faces, colors = [], [], []
    offset = 0
    chosen = [s for s in scene.solids if surfaces or not s.extras.get("surface")]
    if not chosen:
        raise ShapeError("nothing to export as STL: the model has no solid, only surfaces "
                         "(open faces); write GLB, glTF, OBJ or PLY instead")
    for s in chosen:
        v = s.world_vertices()
        verts.append(v)
        faces.append(s.world_faces() + offset)
        colors.append(s.face_rgba())
        offset += len(v)
    mesh = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    mesh.visual.face_colors = np.concatenate(colors)
    return mesh


def encode_stl(obj: Any) -> bytes:
    # STL is for solids (3D printing): a split model's surface layer is left out
    return _world_mesh(obj, surfaces=False).export(file_type="stl")


def encode_ply(obj: Any) -> bytes:
    return _world_mesh(obj).export(file_type="ply", encoding="binary")


# The specs (and the hookimpl registering them) live in exporter_plugin.py, which stays light.
from .exporter_plugin import SPECS as _SPECS, grammarkit_exporters  # noqa: E402


def _all_specs() -> list[ExporterSpec]:
    """Exporters from every plugin (so third-party formats work too); built-ins if the plugin
    manager is unavailable."""
    try:
        from ..plugins import get_plugin_manager

        specs = get_plugin_manager().exporters()
        specs = list(specs.values()) if isinstance(specs, Mapping) else list(specs)
        if specs:
            return specs
    except Exception:  # noqa: BLE001 - fall back to the built-ins, which always work
        pass
    return list(_SPECS)


def known_formats() -> list[str]:
    return sorted({s.format for s in _all_specs()})


def exporter_for(path: str | Path, format: str | None = None) -> ExporterSpec:
    """The exporter named `format`, or else the one owning `path`'s suffix."""
    specs = _all_specs()
    if format:
        fmt = format.lower().lstrip(".")
        for spec in specs:
            if spec.format == fmt:
                return spec
        raise ShapeError(f"unknown export format {format!r}; known formats: "
                         f"{', '.join(known_formats())}")
    suffix = Path(path).suffix.lower()
    for spec in specs:
        if suffix in spec.suffixes:
            return spec
    raise ShapeError(f"{path}: cannot tell the export format from the suffix {suffix!r}; "
                     f"use one of: {', '.join(sorted(s for sp in specs for s in sp.suffixes))} "
                     "or pass format=")


def encode(obj: Any, format: str) -> bytes:
    """The bytes of `obj` in `format`, checked (never empty, structurally a file of that kind)."""
    spec = exporter_for("", format)
    return encode_with(spec, obj)


def encode_with(spec: ExporterSpec, obj: Any) -> bytes:
    """Run an exporter and check what it produced before anyone writes it anywhere."""
    if spec.encode is None:
        raise ShapeError(f"exporter {spec.format!r} (plugin {spec.plugin!r}) has no encode function")
    data = spec.encode(obj)
    if isinstance(data, str):
        data = data.encode("utf-8")
    if not isinstance(data, (bytes, bytearray)) or not data:
        raise ShapeError(f"exporter {spec.format!r} (plugin {spec.plugin or 'unknown'!r}) produced "
                         f"{'no data' if not data else type(data).__name__}; nothing was written")
    problem = spec.check(bytes(data)) if spec.check is not None else None
    if problem:
        raise ShapeError(f"exporter {spec.format!r} (plugin {spec.plugin or 'unknown'!r}) produced an "
                         f"invalid file ({problem}); nothing was written")
    return bytes(data)


def export(obj: Any, path: str | Path, format: str | None = None) -> Path:
    """Write a Scene / Trimesh / model / assembly to `path` atomically; returns the path."""
    from ..fileio import write_files

    path = Path(path)
    spec = exporter_for(path, format)
    write_files({path: encode_with(spec, obj)})
    return path
