"""Reading and writing segmented models (assemblies), and building a grammar's example assemblies.

File conventions (reading and writing agree, so written assemblies read back as inputs):
- GLB / glTF: one scene node per part. The node name is the part id (`Tower.3`); the part type
  is the node's `extras.type`, or else the name up to its first dot (`Tower.3` -> `Tower`).
  Written files store each part's geometry in its own frame with the node transform
  `Part.transform`, and parts with identical local geometry share one glTF mesh (instancing),
  which keeps example files small.
- OBJ: each `o` or `g` group is a part, named like a glTF node (the type comes from the name).
  Written OBJ files hold world coordinates (OBJ has no transforms) and one `o` per part.
- A folder: every mesh file in it (glb, gltf, obj, stl, ply, off) is one part, its file stem
  being the part id (`Tower.3.obj`).

Checks, each a `ShapeError` naming the file and part: not a mesh file, a part with no
triangles, NaN/infinite vertices, a degenerate part (all triangles of zero area), an unknown
part type (when a grammar is given), duplicate part ids. Open or non-manifold parts are
accepted (scans are like that; contacts work on surfaces) and reported with a `ShapeWarning`
and in `assembly.meta["warnings"]`.
"""
from __future__ import annotations

import json
import os
import re
import struct
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from .. import confine
from ..errors import ShapeError
from .assembly import Assembly, Part

if TYPE_CHECKING:  # pragma: no cover
    from ..ir import Grammar

__all__ = [
    "MESH_SUFFIXES", "ShapeWarning", "check_part_mesh", "load_examples", "part_prototype",
    "read_assembly", "type_from_name", "write_assembly",
]

MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".stl", ".ply", ".off")
# Resource guard: models beyond this many triangles in total are refused (contacts and frames
# hold a few arrays per triangle; 20 million is several GB).
MAX_TRIANGLES = 20_000_000


class ShapeWarning(UserWarning):
    """A usable but suspicious input (open or non-manifold part meshes)."""


def type_from_name(name: str) -> str:
    """The part type a name encodes: everything before the first dot (`Tower.3` -> `Tower`,
    `Wall.left` -> `Wall`); a name without a dot is its own type."""
    head = name.split(".", 1)[0].strip()
    return head or name


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------
def read_assembly(path: str | os.PathLike, *, grammar: "Grammar | None" = None,
                  name: str | None = None, max_triangles: int = MAX_TRIANGLES) -> Assembly:
    """Read a segmented model (GLB/glTF/OBJ file or a folder of part meshes).

    With `grammar`, part types the grammar does not know are an error. Models with more than
    `max_triangles` triangles in total are refused (ShapeError)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ShapeError(f"read_assembly: expected a file or folder path, got {type(path).__name__}")
    path = Path(path)
    confine.check(path, what="mesh file")
    if not path.exists():
        raise ShapeError(f"{path}: no such file or folder")
    if path.is_dir():
        parts = _read_folder(path)
    else:
        suffix = path.suffix.lower()
        if suffix == ".obj":
            parts = _read_obj(path)
        elif suffix in (".glb", ".gltf"):
            parts = _read_gltf(path)
        elif suffix in MESH_SUFFIXES:
            parts = [_single_part(path)]
        else:
            raise ShapeError(f"{path}: not a mesh file (expected one of {', '.join(MESH_SUFFIXES)} "
                             "or a folder of part meshes)")
    if not parts:
        raise ShapeError(f"{path}: the file holds no mesh parts")
    total = sum(len(p.mesh.faces) for p in parts)
    if total > max_triangles:
        raise ShapeError(f"{path}: {total} triangles in {len(parts)} parts exceed the limit of "
                         f"{max_triangles} (read_assembly(max_triangles=...))")
    from .orientation import normalize_mirrored

    # A mirrored node transform of a mirror-symmetric part is the same solid as a turned copy:
    # stored as one, its frame corresponds to every other copy's (see orientation.py).
    parts = [normalize_mirrored(p) for p in parts]
    asm = Assembly(parts, name=name or path.stem, meta={"source": str(path)})
    finish_assembly(asm, str(path), grammar)
    return asm


def finish_assembly(asm: Assembly, where: str, grammar: "Grammar | None" = None) -> None:
    """Check ids, geometry and types of a freshly read/built assembly (in place)."""
    seen: dict[str, int] = {}
    for p in asm.parts:
        seen[p.id] = seen.get(p.id, 0) + 1
    dup = sorted(k for k, v in seen.items() if v > 1)
    if dup:
        raise ShapeError(f"{where}: duplicate part ids: {', '.join(dup[:5])}")
    for p in asm.parts:
        check_part_mesh(p.mesh, f"{where}: part {p.id!r} (type {p.type})")
    if grammar is not None:
        from .rules import known_types

        known = known_types(grammar)
        if known:
            for p in asm.parts:
                if p.type not in known:
                    raise ShapeError(
                        f"{where}: part {p.id!r} has type {p.type!r}, which the grammar "
                        f"{grammar.name!r} does not know (known: {', '.join(sorted(known))})")
    open_parts = _open_parts(asm.parts)
    if open_parts:
        msg = (f"{where}: {len(open_parts)} part(s) are open or non-manifold meshes "
               f"(used as surfaces for contacts): {', '.join(open_parts[:5])}"
               f"{' ...' if len(open_parts) > 5 else ''}")
        asm.meta.setdefault("warnings", []).append(msg)
        warnings.warn(msg, ShapeWarning, stacklevel=3)


def check_part_mesh(mesh: object, where: str) -> None:
    if not isinstance(mesh, trimesh.Trimesh):
        raise ShapeError(f"{where}: has no triangle geometry (got {type(mesh).__name__})")
    faces = np.asarray(mesh.faces)
    verts = np.asarray(mesh.vertices)
    if len(faces) == 0 or len(verts) == 0:
        raise ShapeError(f"{where}: has no geometry (no triangles)")
    if not np.isfinite(verts).all():
        bad = int(np.flatnonzero(~np.isfinite(verts).all(axis=1))[0])
        raise ShapeError(f"{where}: vertex {bad} has NaN or infinite coordinates")
    if faces.min() < 0 or faces.max() >= len(verts):
        raise ShapeError(f"{where}: a triangle refers to a vertex that does not exist")
    tri = verts[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    size = float(np.linalg.norm(verts.max(axis=0) - verts.min(axis=0)))
    if size <= 0 or not (area > 1e-12 * size * size).any():
        raise ShapeError(f"{where}: is degenerate (all {len(faces)} triangles have zero area)")


def _open_parts(parts: list[Part]) -> list[str]:
    """Ids of parts whose mesh has an edge not shared by exactly two triangles (one numpy pass)."""
    if not parts:
        return []
    faces, offs = [], 0
    for p in parts:
        faces.append(np.asarray(p.mesh.faces, dtype=np.int64) + offs)
        offs += len(p.mesh.vertices)
    F = np.concatenate(faces)
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    face_owner = np.repeat(np.arange(len(parts)), [len(f) for f in faces])
    own = np.concatenate([face_owner] * 3)
    _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    bad_edge = counts[inverse.ravel()] != 2
    bad = np.unique(own[bad_edge])
    return [parts[i].id for i in bad]


def _read_gltf(path: Path) -> list[Part]:
    from ..geometry.meshio import read_gltf_solids

    confine.check(path, what="mesh file")  # also each file of a folder (a link may point out)

    solids = read_gltf_solids(path)  # grammarkit's own layout (format 2), in the Z-up frame
    if solids is not None:
        # a file edited elsewhere may hold parts outside the marked root (trimesh and Blender
        # move a node to the scene root keeping its world placement): read those too
        strays = _stray_parts(path, {s.name for s in solids})
        parts = []
        for s in solids:
            ptype = s.extras.get("type") if isinstance(s.extras, dict) else None
            ptype = str(ptype) if ptype else type_from_name(s.name)
            used, inv = np.unique(s.faces, return_inverse=True)
            mesh = trimesh.Trimesh(s.vertices[used], inv.reshape(-1, 3), process=False)
            check_part_mesh(mesh, f"{path}: part {s.name!r}")
            mesh.apply_transform(s.matrix)
            meta = {"source": str(path)}
            parts.append(Part(s.name, ptype, mesh, s.matrix.copy(), meta))
        return parts + strays
    from ..geometry.meshio import check_external_files

    check_external_files(path)  # its external buffers and images (a named pipe; outside the folder)
    try:
        scene = trimesh.load(str(path), force="scene")
    except Exception as exc:  # noqa: BLE001 - any parser failure means "not a mesh file"
        raise ShapeError(f"{path}: not a readable mesh file ({type(exc).__name__}: {exc})") from None
    extras = _gltf_node_extras(path)
    parent_edge = {child: data for (_, child), data in scene.graph.transforms.edge_data.items()}
    parts = []
    for node in sorted(scene.graph.nodes_geometry):
        matrix, geom_name = scene.graph.get(node)
        geometry = scene.geometry.get(geom_name)
        where = f"{path}: part {node!r}"
        if not isinstance(geometry, trimesh.Trimesh):
            raise ShapeError(f"{where}: has no triangle geometry (got {type(geometry).__name__})")
        meta_extras = extras.get(node) or parent_edge.get(node, {}).get("metadata") or {}
        ptype = meta_extras.get("type") if isinstance(meta_extras, dict) else None
        ptype = str(ptype) if ptype else type_from_name(node)
        mesh = trimesh.Trimesh(np.asarray(geometry.vertices, dtype=np.float64).copy(),
                               np.asarray(geometry.faces).copy(), process=False)
        check_part_mesh(mesh, where)
        mesh.apply_transform(matrix)
        parts.append(Part(node, ptype, mesh, np.asarray(matrix, dtype=np.float64).copy(),
                          {"source": str(path)}))
    # keep the file's node order (deterministic and what the author wrote)
    order = {n: i for i, n in enumerate(extras)}
    parts.sort(key=lambda p: (order.get(p.id, len(order)), p.id))
    return parts


def _gltf_node_extras(path: Path) -> dict[str, dict]:
    """node name -> extras, read straight from the glTF JSON (trimesh does not expose them)."""
    out: dict[str, dict] = {}
    for node in _gltf_doc(path).get("nodes", []):
        if isinstance(node, dict) and "name" in node:
            out[node["name"]] = node.get("extras") or {}
    return out


def _node_matrix(node: dict) -> np.ndarray:
    """A glTF node's local matrix (column-major `matrix`, or translation/rotation/scale)."""
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
    T = np.eye(4)
    x, y, z, w = node.get("rotation", (0.0, 0.0, 0.0, 1.0))
    T[:3, :3] = trimesh.transformations.quaternion_matrix((w, x, y, z))[:3, :3]
    T[:3, :3] = T[:3, :3] * np.asarray(node.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)
    T[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return T


def _stray_parts(path: Path, read: set[str]) -> list[Part]:
    """The mesh nodes of a grammarkit glTF that are not below its marked root (the layout
    `read_gltf_solids` reads), placed in the model's Z-up frame (their world placement with the
    root's own placement undone). A node that cannot be placed (no triangles, a name a part
    already has, a node with several parents) is an error naming it: no part is dropped."""
    try:
        doc = _gltf_doc(path)
        nodes = doc["nodes"]
        tops = list(doc["scenes"][doc.get("scene", 0)]["nodes"])
        root = tops[0]
    except (KeyError, IndexError, TypeError):
        return []
    world: dict[int, np.ndarray] = {}
    bad: list[str] = []
    stack = [(k, np.eye(4)) for k in tops]
    while stack:  # every node of the scene with its world matrix (glTF scenes are trees)
        k, parent = stack.pop()
        if not isinstance(k, int) or not 0 <= k < len(nodes) or k in world:
            bad.append(f"node {k}")
            continue
        world[k] = parent @ _node_matrix(nodes[k])
        stack.extend((c, world[k]) for c in nodes[k].get("children", []))
    below = set(nodes[root].get("children", []))
    below |= {c for k in below for c in nodes[k].get("children", [])}  # a part's label groups
    stray = [k for k in sorted(world) if "mesh" in nodes[k] and k != root and k not in below]
    if not stray and not bad:
        return []
    try:
        scene = trimesh.load(str(path), force="scene")
    except Exception:  # noqa: BLE001 - the stray nodes cannot be read: named below
        scene = trimesh.Scene()
    to_model = np.linalg.inv(world[root])
    extras = _gltf_node_extras(path)
    parts = []
    for k in stray:
        name = str(nodes[k].get("name", f"node{k}"))
        try:
            _, geom_name = scene.graph.get(name)
            geometry = scene.geometry.get(geom_name)
        except (KeyError, ValueError, TypeError):
            geometry = None
        if name in read or not isinstance(geometry, trimesh.Trimesh):
            bad.append(repr(name))
            continue
        matrix = to_model @ world[k]
        mesh = trimesh.Trimesh(np.asarray(geometry.vertices, dtype=np.float64).copy(),
                               np.asarray(geometry.faces).copy(), process=False)
        check_part_mesh(mesh, f"{path}: part {name!r}")
        mesh.apply_transform(matrix)
        ptype = (extras.get(name) or {}).get("type")
        parts.append(Part(name, str(ptype) if ptype else type_from_name(name), mesh, matrix,
                          {"source": str(path), "placed": "outside the grammarkit root node"}))
        read.add(name)
    if bad:
        raise ShapeError(f"{path}: cannot place the mesh node(s) {', '.join(bad)} outside the grammarkit "
                         "root node (no triangle geometry, a repeated part name, or a broken node tree); "
                         "move them back under the root node or remove them")
    return parts


def _gltf_doc(path: Path) -> dict:
    """The glTF JSON document of a .glb/.gltf file ({} when it cannot be read)."""
    try:
        raw = path.read_bytes()
        if raw[:4] == b"glTF":
            length, kind = struct.unpack("<II", raw[12:20])
            if kind != 0x4E4F534A:  # "JSON"
                return {}
            doc = json.loads(raw[20:20 + length])
        else:
            doc = json.loads(raw.decode("utf-8"))
    except (OSError, ValueError, struct.error, UnicodeDecodeError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _read_obj(path: Path) -> list[Part]:
    """A small OBJ reader that keeps `o`/`g` groups as parts and reports file:line on errors."""
    from ..geometry.meshio import weld

    confine.check(path, what="mesh file")  # also each file of a folder (a link may point out)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ShapeError(f"{path}: not a mesh file (binary data in an .obj file)") from None
    verts: list[tuple[float, float, float]] = []
    groups: dict[str, list[list[int]]] = {}
    group_types: dict[str, str] = {}
    current = path.stem
    for lineno, line in enumerate(text.splitlines(), 1):
        if line.startswith("# extras "):  # grammarkit's OBJ writer: the part's type and id
            try:
                extras = json.loads(line[len("# extras "):])
            except ValueError:
                extras = {}
            if isinstance(extras, dict) and extras.get("type"):
                group_types[current] = str(extras["type"])
            continue
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        key = fields[0]
        try:
            if key == "v":
                verts.append((float(fields[1]), float(fields[2]), float(fields[3])))
            elif key in ("o", "g"):
                current = " ".join(fields[1:]) or path.stem
            elif key == "f":
                idx = []
                for tok in fields[1:]:
                    i = int(tok.split("/")[0])
                    i = i - 1 if i > 0 else len(verts) + i
                    if not 0 <= i < len(verts):
                        raise ShapeError(f"{path}:{lineno}: face refers to vertex {tok.split('/')[0]}, "
                                         f"but only {len(verts)} vertices are defined so far")
                    idx.append(i)
                if len(idx) < 3:
                    raise ShapeError(f"{path}:{lineno}: a face needs at least 3 vertices")
                tris = groups.setdefault(current, [])
                for k in range(1, len(idx) - 1):  # fan triangulation of polygons
                    tris.append([idx[0], idx[k], idx[k + 1]])
        except (ValueError, IndexError):
            raise ShapeError(f"{path}:{lineno}: cannot read {key!r} line: {line.strip()[:60]!r}") from None
    if not verts:
        raise ShapeError(f"{path}: not a mesh file (no vertices)")
    V = np.asarray(verts, dtype=np.float64)
    parts = []
    for name, tris in groups.items():
        F = np.asarray(tris, dtype=np.int64)
        used, inverse = np.unique(F, return_inverse=True)
        # OBJ writers (grammarkit's included) repeat vertices at colour seams: weld by position
        mesh = trimesh.Trimesh(V[used], inverse.reshape(-1, 3), process=False)
        if np.isfinite(mesh.vertices).all():  # NaN is reported by finish_assembly, naming the part
            mesh = weld(mesh)
        parts.append(Part(name, group_types.get(name) or type_from_name(name), mesh, np.eye(4),
                          {"source": str(path)}))
    return parts


def _single_part(path: Path) -> Part:
    confine.check(path, what="mesh file")  # also each file of a folder (a link may point out)
    try:
        loaded = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # noqa: BLE001
        raise ShapeError(f"{path}: not a readable mesh file ({type(exc).__name__}: {exc})") from None
    name = path.name
    for suffix in MESH_SUFFIXES:
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
    if not isinstance(loaded, trimesh.Trimesh):
        raise ShapeError(f"{path}: part {name!r} has no triangle geometry")
    mesh = trimesh.Trimesh(np.asarray(loaded.vertices, dtype=np.float64), np.asarray(loaded.faces),
                           process=False)
    return Part(name, type_from_name(name), mesh, np.eye(4), {"source": str(path)})


def _read_folder(path: Path) -> list[Part]:
    # natural order (Wall.2 before Wall.10), so a written folder reads back in a stable order
    files = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in MESH_SUFFIXES),
                   key=lambda p: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)])
    if not files:
        raise ShapeError(f"{path}: the folder holds no mesh files ({', '.join(MESH_SUFFIXES)})")
    parts = []
    for f in files:
        if f.suffix.lower() in (".glb", ".gltf", ".obj"):
            sub = _read_gltf(f) if f.suffix.lower() != ".obj" else _read_obj(f)
            if len(sub) == 1:
                p = sub[0]
                name = f.name[: -len(f.suffix)]
                # the file stem is the id; the type is the node's extras.type if it has one,
                # else derived from the stem (`Tower.3.glb` -> Tower)
                parts.append(Part(name, p.type if p.type != type_from_name(p.id) else type_from_name(name),
                                  p.mesh, p.transform, p.meta))
                continue
            for p in sub:
                check_part_mesh(p.mesh, f"{f}: part {p.id!r}")
            mesh = trimesh.util.concatenate([p.mesh for p in sub])
            name = f.name[: -len(f.suffix)]
            parts.append(Part(name, type_from_name(name), mesh, np.eye(4), {"source": str(f)}))
        else:
            parts.append(_single_part(f))
    return parts


# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------
def write_assembly(assembly: Assembly, path: str | os.PathLike) -> Path:
    """Write `assembly` as GLB/glTF/OBJ/STL/PLY (by suffix) or, for a path without suffix, a
    folder of GLB part files, through the exporter registry (grammarkit.geometry.exporters: one
    node per part with its type in the extras, a colour per part type, +Y up) and the one
    atomic writer (grammarkit.fileio.write_files)."""
    from ..geometry.exporters import encode_with, exporter_for
    from ..fileio import write_files

    path = Path(path)
    if not assembly.parts:
        raise ShapeError(f"{path}: refusing to write an empty assembly")
    if path.suffix == "":
        spec = exporter_for("part.glb")
        files = {path / f"{p.id}.glb": encode_with(spec, Assembly([p], name=p.id)) for p in assembly.parts}
    else:
        try:
            spec = exporter_for(path)
        except ShapeError:
            raise ShapeError(f"{path}: cannot write assemblies as {path.suffix!r} (use .glb, .gltf, .obj, "
                             ".stl, .ply or a folder)") from None
        files = {path: encode_with(spec, assembly)}
    write_files(files)
    return path


def _atomic_write(path: Path, data: bytes) -> None:
    """Write `data` to `path` atomically (grammarkit.fileio.atomic_output: temp +
    rename, file-system failures as ShapeError naming the path)."""
    from ..fileio import atomic_output

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ShapeError(f"{path}: cannot create folder {path.parent}: {exc.strerror or exc}") from None
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)


# --------------------------------------------------------------------------------------------
# a grammar's parts and examples
# --------------------------------------------------------------------------------------------
def _base_dir(grammar: "Grammar", node: object = None) -> Path:
    """The folder a statement's relative file names start from: the file the statement was
    written in (an imported grammar's own folder), else the grammar's, else the working
    directory."""
    span = getattr(node, "span", None)
    if span is not None and getattr(span, "file", None):
        return Path(span.file).parent
    return Path(grammar.source_path).parent if grammar.source_path else Path.cwd()


def part_prototype(grammar: "Grammar", type_name: str, *, cache: dict | None = None) -> trimesh.Trimesh:
    """The geometry of `part TYPE = box(w, d, h)` (centred on the origin) or `= mesh("file")`.

    `cache` (a dict) keeps every source file read, by resolved path, so a grammar whose parts
    come from one file reads it once (`rules_from_grammar` passes one per grammar)."""
    from .rules import eval_number

    for pd in grammar.parts:
        if pd.name != type_name:
            continue
        call = pd.geometry
        where = f"{pd.span or grammar.name}: part {type_name}"
        if call.func == "box":
            if len(call.args) != 3:
                raise ShapeError(f"{where}: box(w, d, h) takes 3 sizes, got {len(call.args)}", pd.span)
            size = [eval_number(a, grammar) for a in call.args]
            if min(size) <= 0:
                raise ShapeError(f"{where}: box sizes must be positive, got {size}", pd.span)
            return trimesh.creation.box(extents=size)
        if call.func == "mesh":
            from ..ir.expr import Str

            if not call.args or not all(isinstance(a, Str) for a in call.args) or len(call.args) > 2:
                raise ShapeError(f'{where}: mesh("file") or mesh("file", "PartId") takes file names', pd.span)
            f = Path(call.args[0].value)
            f = f if f.is_absolute() else _base_dir(grammar, pd) / f
            confine.check(f, what="mesh file", span=pd.span)
            key = str(f.resolve()) if f.exists() else str(f)
            asm = cache.get(key) if cache is not None else None
            if asm is None:
                asm = read_assembly(f)
                if cache is not None:
                    cache[key] = asm
            if len(call.args) == 2:  # one part of a segmented file, in its own frame
                wanted = call.args[1].value
                part = asm.by_id().get(wanted)
                if part is None:
                    raise ShapeError(f"{where}: {f} has no part {wanted!r} "
                                     f"(parts: {', '.join(p.id for p in asm.parts[:8])})", pd.span)
                mesh = part.mesh.copy()
                mesh.apply_transform(np.linalg.inv(part.transform))
                return mesh
            return trimesh.util.concatenate([p.mesh for p in asm.parts]) if len(asm) > 1 else asm.parts[0].mesh.copy()
        raise ShapeError(f"{where}: unknown part geometry {call.func}(...); use box(w, d, h) or mesh(\"file\")",
                         pd.span)
    raise ShapeError(f"grammar {grammar.name!r}: no `part {type_name} = ...` statement gives its geometry")


def load_examples(grammar: "Grammar", *, check_types: bool = True, cache: dict | None = None) -> list[Assembly]:
    """The grammar's `example` statements as assemblies: files are read relative to the grammar
    file; inline examples place each type's `part` geometry (`Type at (x,y,z) rot (rx,ry,rz)`,
    degrees, extrinsic XYZ). `cache` (as for `part_prototype`): files already read for the
    grammar's parts are not read again (used with `check_types=False`)."""
    from .rules import placement_matrix

    out = []
    for ex in grammar.examples:
        if ex.source is not None:
            f = Path(ex.source)
            if not f.is_absolute():
                f = _base_dir(grammar, ex) / f
            confine.check(f, what="example file", span=ex.span)
            key = str(f.resolve()) if f.exists() else str(f)
            known = cache.get(key) if cache is not None and not check_types else None
            if known is not None:
                asm = Assembly(list(known.parts), name=ex.name, meta=dict(known.meta))
            else:
                asm = read_assembly(f, grammar=grammar if check_types else None, name=ex.name)
                if cache is not None and not check_types:
                    cache[key] = asm
        else:
            protos: dict[str, trimesh.Trimesh] = {}
            counts: dict[str, int] = {}
            parts = []
            for ip in ex.parts:
                if ip.type not in protos:
                    protos[ip.type] = part_prototype(grammar, ip.type, cache=cache)
                T = placement_matrix(ip.placement, grammar)
                mesh = protos[ip.type].copy()
                mesh.apply_transform(T)
                k = counts.get(ip.type, 0)
                counts[ip.type] = k + 1
                parts.append(Part(f"{ip.type}.{k}", ip.type, mesh, T, {"example": ex.name}))
            asm = Assembly(parts, name=ex.name, meta={"source": f"{grammar.name}:{ex.name}"})
            if not parts:
                raise ShapeError(f"{ex.span or grammar.name}: example {ex.name!r} has no parts", ex.span)
            finish_assembly(asm, f"example {ex.name}", grammar if check_types else None)
        out.append(asm)
    return out

