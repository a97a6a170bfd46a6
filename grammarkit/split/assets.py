"""Inserted assets (`i("part.glb")`) as manifold3d solids, with a disk cache.

Reading a mesh file needs trimesh (and, through it, scipy): about 0.7 s of imports, more than
the derivation of a building. The solid of an asset is therefore also kept on disk, as the
arrays of its mesh (numpy's .npz, next to the parser tables in `grammarkit.dsl.parser.cache_dir()`),
keyed by the file's bytes and the versions of what turned them into a solid. A later process
rebuilds the identical solid from the arrays with manifold3d alone (a test derives the same
GLB bytes from a cold and a warm cache). A missing, unreadable or read-only cache folder only
means reading the file every time; a broken cache file is ignored and rewritten.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import manifold3d
import numpy as np

from .. import confine
from ..registry import BUILTIN_ASSET_NAMES

__all__ = ["ASSET_CACHE_VERSION", "BUILTINS", "asset_cache_path", "builtin_asset", "load_asset",
           "load_asset_mesh", "load_asset_solid"]

# Bump when the way a file becomes a solid changes (it is part of every cache key).
ASSET_CACHE_VERSION = 1


@lru_cache(maxsize=1)
def _reader_versions() -> str:
    """Versions of the libraries that read the file and build the solid (looked up only when
    an asset is loaded; trimesh's without importing it)."""
    from importlib.metadata import PackageNotFoundError, version

    out = [f"asset-cache={ASSET_CACHE_VERSION}", f"manifold3d={getattr(manifold3d, '__version__', '?')}"]
    for dist in ("trimesh", "grammarkit"):
        try:
            out.append(f"{dist}={version(dist)}")
        except PackageNotFoundError:
            out.append(f"{dist}=?")
    return ";".join(out)


def asset_cache_path(data: bytes) -> Path:
    from ..dsl.parser import cache_dir

    digest = hashlib.sha256(_reader_versions().encode() + b"\0" + data).hexdigest()[:32]
    return cache_dir() / "assets" / f"{digest}.npz"


@confine.guarded("mesh file")
@lru_cache(maxsize=64)
def load_asset_mesh(path: str) -> Any:
    """The asset as one trimesh (a Scene's nodes in world coordinates), read once per process."""
    from ..geometry.meshio import load_mesh

    mesh = load_mesh(path)
    if not hasattr(mesh, "faces"):  # a Scene (GLB, OBJ): all its nodes in world coordinates
        import trimesh
        mesh = trimesh.util.concatenate(mesh.dump()) if mesh.geometry else None
        if mesh is None:
            raise ValueError(f"i(): {path} contains no mesh")
    return mesh


def _from_arrays(vert_properties: np.ndarray, tri_verts: np.ndarray) -> manifold3d.Manifold:
    mesh = manifold3d.Mesh(vert_properties=np.array(vert_properties, dtype=np.float32, copy=True),
                           tri_verts=np.array(tri_verts, dtype=np.uint32, copy=True))
    return manifold3d.Manifold(mesh)


def _read_cache(path: Path) -> manifold3d.Manifold | None:
    try:
        with np.load(path, allow_pickle=False) as npz:
            solid = _from_arrays(npz["vert_properties"], npz["tri_verts"])
    except (OSError, ValueError, KeyError, EOFError, TypeError):
        return None  # missing, truncated or not ours: read the file instead
    return solid if solid.status() == manifold3d.Error.NoError and not solid.is_empty() else None


def _write_cache(path: Path, vert_properties: np.ndarray, tri_verts: np.ndarray) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, vert_properties=vert_properties, tri_verts=tri_verts)
            os.replace(tmp, path)  # readers see a whole file or none
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
    except OSError:
        pass  # a read-only or missing cache folder: nothing is cached


@confine.guarded("mesh file")
@lru_cache(maxsize=64)
def load_asset_solid(path: str) -> manifold3d.Manifold:
    """The closed solid of a mesh file (ShapeError naming the file if it is not one)."""
    from ..errors import ShapeError

    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ShapeError(f"{path}: cannot read the mesh file: {exc.strerror or exc}") from None
    cached = asset_cache_path(data)
    solid = _read_cache(cached)
    if solid is not None:
        return solid
    from ..geometry.convert import to_manifold

    built = to_manifold(load_asset_mesh(path), what=path)
    mesh = built.to_mesh()
    vp = np.array(mesh.vert_properties, dtype=np.float32, copy=True)
    tv = np.array(mesh.tri_verts, dtype=np.uint32, copy=True)
    _write_cache(cached, vp, tv)
    # the solid as a later process rebuilds it from the cache: results never depend on
    # whether the cache was warm
    return _from_arrays(vp, tv)


# -- open meshes and built-in primitives ------------------------------------------------------
# CGA inserts open meshes as they are (most real assets are: a window pane, a leaf, a sign).
# A file whose mesh is not a closed manifold becomes a surface part
# (grammarkit.geometry.surfaces.SurfaceMesh): moved, scaled and split like a solid, emitted in
# the model's surface layer, never in a boolean, so the solid stays watertight.

BUILTINS = BUILTIN_ASSET_NAMES  # one list: the registry floor has it, for the file functions
BUILTIN_SEGMENTS = 16  # circular primitives: segments around (CGA's primitiveCylinder default)


@lru_cache(maxsize=None)
def builtin_asset(name: str) -> Any:
    """A built-in primitive in the unit box [0, 1]^3 (`i("builtin:cube")`, as CGA's
    `builtin:` assets): solids for cube, cylinder (axis z; `cylinder:y` axis y), cone (apex
    up z), sphere; open surfaces for quad (the unit square at z = 0, normal +z) and disk."""
    from ..geometry.surfaces import SurfaceMesh

    key = name[len("builtin:"):] if name.startswith("builtin:") else name
    M = manifold3d.Manifold
    n = BUILTIN_SEGMENTS
    if key in ("cube", "cube:notex"):
        return M.cube((1.0, 1.0, 1.0))
    if key == "cylinder":
        return M.cylinder(1.0, 0.5, 0.5, n).translate((0.5, 0.5, 0.0))
    if key == "cylinder:y":  # CGA's y-up cylinder in a face's frame
        return M.cylinder(1.0, 0.5, 0.5, n).rotate((-90.0, 0.0, 0.0)).translate((0.5, 0.0, 0.5))
    if key == "cone":
        return M.cylinder(1.0, 0.5, 0.0, n).translate((0.5, 0.5, 0.0))
    if key == "sphere":
        return M.sphere(0.5, 2 * n).translate((0.5, 0.5, 0.5))
    if key == "quad":
        V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
        return SurfaceMesh(V, np.array([[0, 1, 2], [0, 2, 3]]))
    if key == "disk":
        a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        V = np.column_stack([0.5 + 0.5 * np.cos(a), 0.5 + 0.5 * np.sin(a), np.zeros(n)])
        V = np.vstack([[0.5, 0.5, 0.0], V])
        F = np.array([[0, 1 + k, 1 + (k + 1) % n] for k in range(n)])
        return SurfaceMesh(V, F)
    raise ValueError(f"i(): unknown built-in primitive {name!r}; known: "
                     + ", ".join("builtin:" + b for b in BUILTINS))


@confine.guarded("mesh file")
@lru_cache(maxsize=64)
def load_asset(path: str) -> Any:
    """The asset of `i(path)`: a manifold3d solid when the mesh is closed (cached on disk, see
    `load_asset_solid`), else a SurfaceMesh of its triangles. Read once per process."""
    if path.startswith("builtin:"):
        return builtin_asset(path)
    from ..errors import ShapeError

    try:
        return load_asset_solid(path)
    except ShapeError as exc:
        if "not a closed manifold" not in str(exc):
            raise
    from ..geometry.surfaces import SurfaceMesh

    mesh = load_asset_mesh(path)
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int64)
    if len(F) == 0:
        raise ShapeError(f"{path}: the mesh has no triangles")
    return SurfaceMesh(V, F)
