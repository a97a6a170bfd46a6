"""Reading meshes from files with errors that name the file (`load_mesh`).

Used by the split engine's `i("part.glb")`, `grammarkit render` and the tiling readers.

- GLB/glTF written by grammarkit (format 2 or 3, marked in the root node's extras): read here
  (`read_gltf_solids`): the root's Z-up -> Y-up rotation is undone, so meshes come back in the
  model's Z-up frame; each solid's groups (terminal names) are merged back through their shared
  POSITION accessor into one closed mesh with face colours from the materials, and the per-face
  labels in `mesh.face_attributes["label"]` (names in `mesh.metadata["labels"]`).
- Other GLB/glTF files (including grammarkit's older ones, which had no rotation): trimesh;
  node extras come back as the scene graph edge's `metadata` (trimesh 5).
- OBJ files are parsed here (trimesh merges `o` groups into one mesh) so every `o`/`g` group
  becomes its own scene node, and the `# extras {...}` comment grammarkit writes restores the
  node extras.

Meshes with vertices split at colour seams (OBJ, other writers) are welded back: vertices at
the same position are merged while face colours are kept, so parts read as watertight again.
"""
from __future__ import annotations

import base64
import json
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from .. import confine
from ..errors import ShapeError

__all__ = ["MESH_SUFFIXES", "GltfSolid", "face_labels", "flatten", "gltf_root_extras", "load_mesh",
           "read_gltf_solids", "weld"]

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
    for key, value in mesh.face_attributes.items():  # e.g. the per-face "label" of grammarkit GLBs
        out.face_attributes[key] = value
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


# --------------------------------------------------------------------------------------------
# grammarkit's own glTF layout (formats 2 and 3: see grammarkit.geometry.exporters)
# --------------------------------------------------------------------------------------------
_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


@dataclass
class GltfSolid:
    """One solid of a grammarkit GLB/glTF (format 2 or 3): a node below the root, its groups merged
    back into one mesh through the shared POSITION accessor (so it is closed as derived)."""

    name: str
    matrix: np.ndarray  # placement in the model's Z-up frame (the root's rotation undone)
    vertices: np.ndarray  # float64, the solid's own frame
    faces: np.ndarray
    face_colors: np.ndarray  # sRGB bytes from the materials
    face_labels: np.ndarray  # index into `labels`
    labels: list[str]
    extras: dict = field(default_factory=dict)


def _gltf_json(path: Path) -> tuple[dict, bytes | None] | None:
    """(JSON document, binary chunk) of a .glb/.gltf file, or None if it is not one."""
    try:
        raw = path.read_bytes()
        if raw[:4] == b"glTF":
            length, kind = struct.unpack_from("<II", raw, 12)
            if kind != 0x4E4F534A:  # "JSON"
                return None
            doc = json.loads(raw[20:20 + length])
            rest = 20 + length
            binary = None
            if len(raw) >= rest + 8:
                blen, bkind = struct.unpack_from("<II", raw, rest)
                if bkind == 0x004E4942:  # "BIN\0"
                    binary = raw[rest + 8:rest + 8 + blen]
            return doc, binary
        return json.loads(raw.decode("utf-8")), None
    except (OSError, ValueError, struct.error, UnicodeDecodeError):
        return None


def _check_external_files(path: Path) -> None:
    """Refuse a glTF whose external buffers or images are not regular files: reading a named
    pipe blocks forever and a device such as /dev/zero never ends (issue 19)."""
    import stat as stat_mod
    from urllib.parse import unquote

    loaded = _gltf_json(path)
    if loaded is None:
        return
    doc = loaded[0]
    for kind in ("buffers", "images"):
        items = doc.get(kind) if isinstance(doc, dict) else None
        for item in items if isinstance(items, list) else ():
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:") or "://" in uri:
                continue  # embedded data; URLs are refused by the loader itself
            target = path.parent / uri
            for name in {uri, unquote(uri)}:  # loaders may read the URI percent-decoded
                confine.check(name, base=path.parent, what=f"the external {kind[:-1]} file of {path.name}")
            try:
                mode = os.stat(target).st_mode
            except (OSError, ValueError):
                continue  # missing: the loader reports it
            if not stat_mod.S_ISREG(mode):
                raise ShapeError(f"{path}: the external file {uri!r} of its {kind} is not a "
                                 "regular file (a named pipe, a device or a folder)")


check_external_files = _check_external_files  # public: the tiling reader refuses the same files


def gltf_root_extras(path: str | Path) -> dict:
    """The `extras.grammarkit` block of a GLB/glTF's root node ({} for other files)."""
    loaded = _gltf_json(Path(path))
    if loaded is None:
        return {}
    doc = loaded[0]
    try:
        roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
        extras = doc["nodes"][roots[0]].get("extras") or {}
    except (KeyError, IndexError, TypeError):
        return {}
    marker = extras.get("grammarkit") if isinstance(extras, dict) else None
    return marker if isinstance(marker, dict) else {}


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
    m = np.eye(4)
    if "scale" in node:
        m = np.diag([*node["scale"], 1.0]) @ m
    if "rotation" in node:
        x, y, z, w = node["rotation"]
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        rot = np.eye(4)
        rot[:3, :3] = r
        m = rot @ m
    if "translation" in node:
        t = np.eye(4)
        t[:3, 3] = node["translation"]
        m = t @ m
    return m


def read_gltf_solids(path: str | Path) -> list[GltfSolid] | None:
    """The solids of a GLB/glTF written by grammarkit (format 2 or 3), in the model's Z-up frame,
    or None for any other glTF file (read those with trimesh). Raises ShapeError naming the
    file when a grammarkit file is damaged."""
    path = Path(path)
    loaded = _gltf_json(path)
    if loaded is None:
        return None
    doc, binary = loaded
    try:
        root = doc["nodes"][doc["scenes"][doc.get("scene", 0)]["nodes"][0]]
        marker = (root.get("extras") or {}).get("grammarkit")
    except (KeyError, IndexError, TypeError, AttributeError):
        return None
    if not isinstance(marker, dict) or int(marker.get("format", 0)) < 2:
        return None
    try:
        return _solids_from_doc(doc, binary, root, path)
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        raise ShapeError(f"{path}: damaged grammarkit glTF file ({type(exc).__name__}: {exc})") from None


# long: one walk of the glTF nodes; accessor reads and their located checks share the buffers
def _solids_from_doc(doc: dict, binary: bytes | None, root: dict, path: Path) -> list[GltfSolid]:
    # One function on purpose: the accessor reader and the colour lookup are closures over this
    # document's buffers and materials, shared by both layouts (formats 2 and 3) read below.
    buffers: list[bytes] = []
    for i, buf in enumerate(doc.get("buffers", [])):
        uri = buf.get("uri")
        if uri is None:
            if binary is None:
                raise ValueError("the GLB has no binary chunk")
            buffers.append(binary)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            confine.check(uri, base=path.parent, what=f"the external buffer file of {path.name}")
            buffers.append((path.parent / uri).read_bytes())
    cache: dict[int, np.ndarray] = {}

    def accessor(i: int) -> np.ndarray:
        if i in cache:
            return cache[i]
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        dtype = np.dtype(_COMPONENTS[acc["componentType"]])
        width = _WIDTH[acc["type"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        stride = view.get("byteStride") or dtype.itemsize * width
        raw = buffers[view["buffer"]]
        count = acc["count"]
        if stride == dtype.itemsize * width:
            arr = np.frombuffer(raw, dtype=dtype, count=count * width, offset=start).reshape(count, width)
        else:
            rows = np.frombuffer(raw, dtype=np.uint8, count=stride * (count - 1) + dtype.itemsize * width,
                                 offset=start)
            arr = np.lib.stride_tricks.as_strided(rows, (count, dtype.itemsize * width), (stride, 1)).copy()
            arr = arr.view(dtype).reshape(count, width)
        cache[i] = arr
        return arr

    materials = doc.get("materials", [])

    def colour(mi: int | None) -> np.ndarray:
        if mi is None:
            return np.array([200, 200, 200, 255], dtype=np.uint8)
        return colour_of(materials[mi])

    def colour_of(mat: dict) -> np.ndarray:
        srgb = (mat.get("extras") or {}).get("srgb")
        alpha = mat.get("pbrMetallicRoughness", {}).get("baseColorFactor", [1, 1, 1, 1])[3]
        if isinstance(srgb, str) and len(srgb) == 7:
            rgb = [int(srgb[k:k + 2], 16) for k in (1, 3, 5)]
        else:  # linear factor back to sRGB
            lin = np.asarray(mat.get("pbrMetallicRoughness", {}).get("baseColorFactor", [1, 1, 1, 1])[:3])
            rgb = np.round(255 * np.where(lin <= 0.0031308, lin * 12.92, 1.055 * lin ** (1 / 2.4) - 0.055))
        return np.array([*[int(v) for v in rgb], int(round(255 * alpha))], dtype=np.uint8)

    nodes = doc["nodes"]
    out = []
    for ci in root.get("children", []):
        node = nodes[ci]
        name = str(node.get("name", f"node{ci}"))
        members = [(name, node)] if "mesh" in node else []
        members += [(str(nodes[k].get("name", f"node{k}")), nodes[k]) for k in node.get("children", [])
                    if "mesh" in nodes[k]]
        pos_offset: dict[int, int] = {}
        verts, faces, colors, labels_of, label_names = [], [], [], [], []
        kid_names = [str(nodes[k].get("name", f"node{k}")) for k in node.get("children", [])]
        for gname, gnode in members:
            label = None  # this member's label index, added when a primitive without runs uses it
            for prim in doc["meshes"][gnode["mesh"]]["primitives"]:
                if prim.get("mode", 4) != 4:
                    continue
                pa = prim["attributes"]["POSITION"]
                if pa not in pos_offset:
                    pos_offset[pa] = sum(len(v) for v in verts)
                    verts.append(accessor(pa).astype(np.float64))
                idx = accessor(prim["indices"]).reshape(-1, 3).astype(np.int64) if "indices" in prim \
                    else np.arange(len(accessor(pa)), dtype=np.int64).reshape(-1, 3)
                faces.append(idx + pos_offset[pa])
                marker = (prim.get("extras") or {}).get("grammarkit") or {}
                if marker.get("runs"):  # one primitive for a whole closed solid: per-face data in its runs
                    palette = [colour_of(m) for m in marker.get("materials") or []]
                    prim_colors, prim_labels = _runs(marker["runs"], len(idx), palette, kid_names, label_names)
                    colors.append(prim_colors)
                    labels_of.append(prim_labels)
                    continue
                if label is None:
                    label = len(label_names)
                    label_names.append(gname)
                colors.append(np.tile(colour(prim.get("material")), (len(idx), 1)))
                labels_of.append(np.full(len(idx), label, dtype=np.int64))

        if not faces:
            continue
        extras = dict(node.get("extras") or {})
        out.append(GltfSolid(name, _node_matrix(node), np.concatenate(verts), np.concatenate(faces),
                             np.concatenate(colors), np.concatenate(labels_of), label_names, extras))
    if not out:
        raise ShapeError(f"{path}: the file contains no triangle meshes")
    return out


def _runs(runs: list, n_faces: int, palette: list[np.ndarray], kid_names: list[str],
          label_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Per-face colours and labels of a one-primitive solid from its `runs` ([child, material,
    first face, face count]; see exporters._one_primitive); `palette` holds the colours of the
    primitive's materials; labels index `label_names`, which gains the children's names."""
    colors = np.zeros((n_faces, 4), dtype=np.uint8)
    labels = np.zeros(n_faces, dtype=np.int64)
    base = len(label_names)
    label_names.extend(kid_names)
    covered = 0
    for child, material, first, count in runs:
        if not (0 <= first and first + count <= n_faces and 0 <= child < len(kid_names)
                and 0 <= material < len(palette)):
            raise ValueError(f"face run {[child, material, first, count]} is out of range")
        colors[first:first + count] = palette[material]
        labels[first:first + count] = base + child
        covered += count
    if covered != n_faces:
        raise ValueError(f"the face runs cover {covered} of {n_faces} faces")
    return colors, labels


def _scene_of_solids(solids: list[GltfSolid]) -> trimesh.Scene:
    scene = trimesh.Scene()
    for s in solids:
        # only the referenced vertices (a solid's accessor may be shared by instanced parts)
        used, inv = np.unique(s.faces, return_inverse=True)
        mesh = trimesh.Trimesh(s.vertices[used], inv.reshape(-1, 3), process=False,
                               face_colors=s.face_colors, metadata={"labels": list(s.labels)})
        mesh.face_attributes["label"] = s.face_labels
        scene.add_geometry(mesh, node_name=s.name, geom_name=s.name, transform=s.matrix,
                           metadata=s.extras or None)
    return scene


def face_labels(path: str | Path) -> list[str]:
    """The label (terminal name, or part id) of every face of a grammarkit GLB/glTF, in the
    order of `load_mesh(path, single=True).faces`."""
    path = Path(path)
    if not path.is_file():
        raise ShapeError(f"{path}: mesh file not found")
    solids = read_gltf_solids(path)
    if solids is None:
        raise ShapeError(f"{path}: not a GLB/glTF written by grammarkit (format 2 or later); no face labels")
    out: list[str] = []
    for s in solids:
        out.extend(s.labels[i] for i in s.face_labels.tolist())
    return out


def load_mesh(path: str | Path, *, weld_vertices: bool = True,
              single: bool = False) -> trimesh.Trimesh | trimesh.Scene:
    """Read a mesh file: a Trimesh for single-mesh formats (STL, PLY, OFF), a Scene for GLB,
    glTF and OBJ (a node per part), or always one Trimesh in world coordinates with
    `single=True` (e.g. for `i("part.glb")`). Raises `ShapeError` naming the file when it is
    missing, not a mesh, empty, or has NaN/inf coordinates."""
    path = Path(path)
    confine.check(path, what="mesh file")
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
    if suffix in (".glb", ".gltf"):
        _check_external_files(path)
    solids = read_gltf_solids(path) if suffix in (".glb", ".gltf") else None
    if solids is not None:
        loaded: trimesh.Trimesh | trimesh.Scene = _scene_of_solids(solids)
    elif suffix == ".obj":
        loaded = _load_obj(path)
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
