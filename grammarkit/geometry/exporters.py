"""Model writers for GLB, glTF, OBJ, STL and PLY, registered as the `core-exporters` plugin.

Convention (docs/rendering.md, ARCHITECTURE.md): one scene node per part, named after the
part id `Type.N`, with `{"type": Type, "id": Type.N, ...}` in the node's glTF `extras`
(trimesh 5 reads these back as the graph edge's `metadata`); OBJ files get one `o`/`g` group
per part with the same name. PLY and STL have no node structure: the parts are written as one
mesh in world coordinates (PLY keeps face colours, STL keeps nothing but triangles).

Colours: GLB/glTF and OBJ only carry per-vertex colours, so a part whose faces have several
colours gets its vertices duplicated along colour boundaries before writing (each face's
colour then survives exactly; `grammarkit.geometry.meshio.load_mesh` welds them back so the
part reads as watertight again).

Every writer goes through `atomic_output`: the file appears complete or not at all.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np
import trimesh

from ..errors import ShapeError
from ..jsonable import to_jsonable
from ..registry import ExporterSpec

__all__ = ["OutputError", "atomic_output", "export", "exporter_for", "known_formats", "scene_from_parts",
           "to_scene", "grammarkit_exporters"]


# The atomic writer is shared by every command that writes files (fileio.py has no heavy imports).
from ..fileio import OutputError, atomic_output  # noqa: E402


# ------------------------------------------------------------------------------------------
# Building scenes with the part convention
# ------------------------------------------------------------------------------------------
def scene_from_parts(parts: Iterable[Any]) -> trimesh.Scene:
    """A Scene with one node per part, named by the part id with its type in the node extras.

    `parts`: objects with `.id`, `.type`, `.mesh` (world coordinates) and optional `.meta`
    (e.g. `grammarkit.tiling.assembly.Part`), or `(id, type, mesh[, meta])` tuples.
    """
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


def to_scene(obj: Any) -> trimesh.Scene:
    """A Scene from a Scene, a Trimesh, a model (`.to_scene()`) or an assembly (`.parts`)."""
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


def _nodes(scene: trimesh.Scene) -> list[tuple[str, trimesh.Trimesh, np.ndarray, dict]]:
    """(node name, mesh, world matrix, node extras) for every mesh node."""
    out = []
    graph = scene.graph
    for node in graph.nodes_geometry:
        matrix, gname = graph[node]
        mesh = scene.geometry.get(gname)
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        parent = graph.transforms.parents.get(node)
        extras = graph.transforms.edge_data.get((parent, node), {}).get("metadata") or {}
        out.append((str(node), mesh, np.asarray(matrix, dtype=np.float64), dict(extras)))
    if not out:
        raise ShapeError("nothing to export: the model has no triangles")
    return out


def _split_color_seams(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Vertex-coloured copy of `mesh` whose vertices are not shared between faces of
    different colours, so per-face colours survive formats that only store vertex colours."""
    if mesh.visual.kind not in ("face", "vertex"):
        return mesh
    fc = np.asarray(mesh.visual.face_colors, dtype=np.uint8)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    _, color_id = np.unique(fc, axis=0, return_inverse=True)
    color_id = color_id.reshape(-1)
    # one new vertex per (old vertex, colour) pair in use
    pairs = np.column_stack([faces.ravel(), np.repeat(color_id, 3)])
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    new_faces = inv.reshape(-1, 3)
    vcolors = np.zeros((len(uniq), 4), dtype=np.uint8)
    vcolors[new_faces.ravel()] = np.repeat(fc, 3, axis=0)
    return trimesh.Trimesh(verts[uniq[:, 0]], new_faces, vertex_colors=vcolors, process=False,
                           metadata=dict(mesh.metadata))


def _prepared_scene(scene: trimesh.Scene) -> trimesh.Scene:
    """A flat copy (every node a child of the root, world matrices) with colour seams split."""
    out = trimesh.Scene()
    for name, mesh, matrix, extras in _nodes(scene):
        out.add_geometry(_split_color_seams(mesh), node_name=name, geom_name=name,
                         transform=matrix, metadata=to_jsonable(extras) or None)
    return out


def _world_mesh(scene: trimesh.Scene) -> trimesh.Trimesh:
    """All parts as one mesh in world coordinates, face colours kept when present."""
    verts, faces, colors = [], [], []
    offset = 0
    any_color = False
    for _name, mesh, matrix, _extras in _nodes(scene):
        v = np.asarray(mesh.vertices, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        verts.append(v)
        faces.append(np.asarray(mesh.faces, dtype=np.int64) + offset)
        offset += len(v)
        if mesh.visual.kind in ("face", "vertex"):
            any_color = True
            colors.append(np.asarray(mesh.visual.face_colors, dtype=np.uint8))
        else:
            colors.append(np.full((len(mesh.faces), 4), 200, dtype=np.uint8))
    mesh = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    if any_color:
        mesh.visual.face_colors = np.concatenate(colors)
    return mesh


# ------------------------------------------------------------------------------------------
# Writers
# ------------------------------------------------------------------------------------------
def encode_glb(obj: Any) -> bytes:
    return _prepared_scene(to_scene(obj)).export(file_type="glb")


def encode_gltf(obj: Any) -> bytes:
    from trimesh.exchange.gltf import export_gltf

    files = export_gltf(_prepared_scene(to_scene(obj)), embed_buffers=True)
    text = files.get("model.gltf") or next(iter(files.values()))
    return text if isinstance(text, bytes) else str(text).encode("utf-8")


def encode_obj(obj: Any) -> bytes:
    """OBJ with one `o`/`g` group per part (vertex colours as `v x y z r g b`) and the part's
    extras as a `# extras {...}` comment line that `load_mesh` reads back."""
    lines = ["# written by grammarkit", ""]
    offset = 1
    for name, mesh, matrix, extras in _nodes(to_scene(obj)):
        mesh = _split_color_seams(mesh)
        v = np.asarray(mesh.vertices, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        lines.append(f"o {name}")
        lines.append(f"g {name}")
        if extras:
            lines.append("# extras " + json.dumps(to_jsonable(extras), sort_keys=True))
        if mesh.visual.kind == "vertex":
            c = np.asarray(mesh.visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
            lines.extend(f"v {a:.9g} {b:.9g} {d:.9g} {r:.4g} {g:.4g} {bl:.4g}"
                         for (a, b, d), (r, g, bl) in zip(v.tolist(), c.tolist()))
        else:
            lines.extend(f"v {a:.9g} {b:.9g} {d:.9g}" for a, b, d in v.tolist())
        f = np.asarray(mesh.faces, dtype=np.int64) + offset
        lines.extend(f"f {a} {b} {d}" for a, b, d in f.tolist())
        offset += len(v)
        lines.append("")
    return "\n".join(lines).encode("utf-8")


def encode_stl(obj: Any) -> bytes:
    return _world_mesh(to_scene(obj)).export(file_type="stl")


def encode_ply(obj: Any) -> bytes:
    return _world_mesh(to_scene(obj)).export(file_type="ply", encoding="binary")


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
    from ..run.writer import write_files

    path = Path(path)
    spec = exporter_for(path, format)
    write_files({path: encode_with(spec, obj)})
    return path
