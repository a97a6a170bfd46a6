"""Reading meshes from files with errors that name the file (`load_mesh`).

Used by the split engine's `i("part.glb")` and the tiling readers. GLB/glTF node extras come
back as the scene graph edge's `metadata` (trimesh 5); OBJ files are parsed here (trimesh
merges `o` groups into one mesh) so every `o`/`g` group becomes its own scene node, and the
`# extras {...}` comment grammarkit writes restores the node extras.

Meshes written by `grammarkit.geometry.exporters` with colour seams split are welded back:
vertices at the same position are merged while face colours are kept, so parts read as
watertight again.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import trimesh

from ..errors import ShapeError

__all__ = ["MESH_SUFFIXES", "flatten", "load_mesh", "weld"]

MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".stl", ".ply", ".off")


def weld(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Merge vertices at equal positions (to ~1e-9 of the mesh size), keeping face colours."""
    if len(mesh.faces) == 0:
        return mesh
    colors = np.asarray(mesh.visual.face_colors, dtype=np.uint8) \
        if mesh.visual.kind in ("face", "vertex") else None
    v = np.asarray(mesh.vertices, dtype=np.float64)
    scale = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) or 1.0
    quant = np.round((v - v.min(axis=0)) / (scale * 1e-9)).astype(np.int64)
    _, first, inv = np.unique(quant, axis=0, return_index=True, return_inverse=True)
    faces = inv.reshape(-1)[np.asarray(mesh.faces)]
    out = trimesh.Trimesh(v[first], faces, process=False, metadata=dict(mesh.metadata))
    if colors is not None:
        out.visual.face_colors = colors
    return out


def flatten(scene: trimesh.Scene) -> trimesh.Trimesh:
    """All mesh nodes of `scene` as one Trimesh in world coordinates; face colours are kept
    when any part has colours (uncoloured parts get trimesh's default grey)."""
    verts, faces, colors = [], [], []
    offset, any_color = 0, False
    for node in scene.graph.nodes_geometry:
        matrix, name = scene.graph[node]
        mesh = scene.geometry.get(name)
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        m = np.asarray(matrix, dtype=np.float64)
        v = np.asarray(mesh.vertices, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]
        f = np.asarray(mesh.faces, dtype=np.int64)
        if np.linalg.det(m[:3, :3]) < 0:  # a mirroring node flips the winding
            f = f[:, ::-1]
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
        colored = mesh.visual.kind in ("face", "vertex")
        any_color |= colored
        colors.append(np.asarray(mesh.visual.face_colors, dtype=np.uint8) if colored
                      else np.tile(np.array([200, 200, 200, 255], np.uint8), (len(f), 1)))
    if not faces:
        return trimesh.Trimesh()
    out = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    if any_color:
        out.visual.face_colors = np.concatenate(colors)
    return out


def _check(mesh: trimesh.Trimesh, path: Path, what: str) -> None:
    if len(mesh.faces) == 0:
        raise ShapeError(f"{path}: {what} has no triangles")
    if not np.isfinite(np.asarray(mesh.vertices)).all():
        raise ShapeError(f"{path}: {what} has NaN or infinite vertex coordinates")
    if len(mesh.vertices) and (np.asarray(mesh.faces) >= len(mesh.vertices)).any():
        raise ShapeError(f"{path}: {what} has faces referring to missing vertices")


def _load_obj(path: Path) -> trimesh.Scene:
    """Minimal OBJ reader: v (optionally with r g b), f (polygons fanned, v/vt/vn, negative
    indices), o/g groups as nodes, grammarkit's `# extras {json}` comment."""
    verts: list[list[float]] = []
    colors: list[list[float] | None] = []
    groups: list[tuple[str, dict, list[list[int]]]] = []
    current: tuple[str, dict, list[list[int]]] | None = None
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except UnicodeDecodeError as exc:
        raise ShapeError(f"{path}: not a text OBJ file ({exc.reason})") from None
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("# extras "):
            if current is not None:
                try:
                    current[1].update(json.loads(line[len("# extras "):]))
                except json.JSONDecodeError as exc:
                    raise ShapeError(f"{path}:{lineno}: bad extras JSON: {exc.msg}") from None
            continue
        if line[0] == "#":
            continue
        tag, _, rest = line.partition(" ")
        try:
            if tag == "v":
                nums = [float(x) for x in rest.split()]
                if len(nums) < 3:
                    raise ValueError("a vertex needs 3 coordinates")
                verts.append(nums[:3])
                colors.append(nums[3:6] if len(nums) >= 6 else None)
            elif tag in ("o", "g"):
                name = rest.strip() or f"group{len(groups)}"
                if current is not None and not current[2] and tag == "g":
                    continue  # `g` right after `o` (as grammarkit writes): the `o` names it
                taken = {g[0] for g in groups}
                unique, k = name, 1
                while unique in taken:  # a name reused later in the file: keep both parts
                    unique, k = f"{name}_{k}", k + 1
                current = (unique, {}, [])
                groups.append(current)
            elif tag == "f":
                idx = []
                for token in rest.split():
                    i = int(token.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                if len(idx) < 3:
                    raise ValueError("a face needs at least 3 vertices")
                if current is None:
                    current = (path.stem, {}, [])
                    groups.append(current)
                current[2].extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
        except ValueError as exc:
            raise ShapeError(f"{path}:{lineno}: cannot read OBJ line {raw.strip()[:60]!r}: "
                             f"{exc}") from None
    V = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
    has_color = bool(colors) and all(c is not None for c in colors)
    scene = trimesh.Scene()
    for name, extras, faces in groups:
        if not faces:
            continue
        F = np.asarray(faces, dtype=np.int64)
        if (F < 0).any() or (F >= len(V)).any():
            raise ShapeError(f"{path}: group {name!r} has faces referring to missing vertices")
        used, inv = np.unique(F, return_inverse=True)
        mesh = trimesh.Trimesh(V[used], inv.reshape(-1, 3), process=False)
        if has_color:
            c = np.asarray(colors, dtype=np.float64)[used]
            c = np.clip(np.round(c * 255.0 if c.max() <= 1.0 else c), 0, 255).astype(np.uint8)
            mesh.visual.vertex_colors = np.column_stack([c, np.full(len(c), 255, np.uint8)])
        scene.add_geometry(mesh, node_name=name, geom_name=name, metadata=extras or None)
    return scene


def load_mesh(path: str | Path, *, weld_vertices: bool = True,
              single: bool = False) -> trimesh.Trimesh | trimesh.Scene:
    """Read a mesh file: a Trimesh for single-mesh formats (STL, PLY, OFF), a Scene for GLB,
    glTF and OBJ (a node per part), or always one Trimesh in world coordinates with
    `single=True` (e.g. for `i("part.glb")`). Raises `ShapeError` naming the file when it is
    missing, not a mesh, empty, or has NaN/inf coordinates."""
    path = Path(path)
    if not path.exists():
        raise ShapeError(f"{path}: mesh file not found")
    if not path.is_file():
        raise ShapeError(f"{path}: not a file")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ShapeError(f"{path}: unsupported mesh format {suffix or '(no suffix)'!r}; "
                         f"expected one of {', '.join(MESH_SUFFIXES)}")
    if path.stat().st_size == 0:
        raise ShapeError(f"{path}: the file is empty")
    if suffix == ".obj":
        loaded: trimesh.Trimesh | trimesh.Scene = _load_obj(path)
    else:
        try:
            loaded = trimesh.load(str(path), file_type=suffix[1:], process=False, force=None)
        except ShapeError:
            raise
        except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds; all mean "bad file"
            raise ShapeError(f"{path}: cannot read as {suffix[1:].upper()}: "
                             f"{type(exc).__name__}: {exc}") from None
    if isinstance(loaded, trimesh.Scene):
        meshes = {name: g for name, g in loaded.geometry.items()
                  if isinstance(g, trimesh.Trimesh)}
        if not meshes or all(len(g.faces) == 0 for g in meshes.values()):
            raise ShapeError(f"{path}: the file contains no triangle meshes")
        for name, g in meshes.items():
            _check(g, path, f"mesh {name!r}")
            if weld_vertices:
                loaded.geometry[name] = weld(g)
        if single:
            mesh = flatten(loaded)
            return weld(mesh) if weld_vertices else mesh
        return loaded
    if not isinstance(loaded, trimesh.Trimesh):
        raise ShapeError(f"{path}: the file contains a {type(loaded).__name__}, not a "
                         "triangle mesh")
    _check(loaded, path, "the mesh")
    return weld(loaded) if weld_vertices else loaded
