"""The intermediate form every writer reads: a `Scene` of `Solid`s, each one vertex set (never
split at colour seams) with its triangles in named groups, each triangle with a `Material`
(a name and an sRGB colour); and `solids_of`, which builds it from a split `Model`, a tiling
`Assembly`, a trimesh Scene or a Trimesh.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from ...errors import ShapeError
from ...jsonable import to_jsonable

DEFAULT_RGBA = (200, 200, 200, 255)


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
    # glTF: textured closed solids with TEXCOORD_0 and vertex seams (CityEngine's look) rather
    # than seamless and untextured (watertight as read); a CGA open-face model asks for it
    texture_seams: bool = False


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


def world_mesh(obj: Any, surfaces: bool = True) -> Any:
    """All solids as one trimesh in world coordinates with face colours (without a split
    model's surface layer when `surfaces` is False): what STL and PLY write."""
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
