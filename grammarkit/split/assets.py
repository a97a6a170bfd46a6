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

__all__ = ["ASSET_CACHE_VERSION", "asset_cache_path", "load_asset_mesh", "load_asset_solid"]

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
