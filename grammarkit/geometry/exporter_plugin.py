"""The built-in exporters' plugin registration (entry point `core-exporters`).

Kept apart from `exporters.py` so that loading plugins (which every `grammarkit` command
does) does not import trimesh; the writers are imported on first use.
"""
from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Any

from ..hookspecs import hookimpl
from ..registry import ExporterSpec


class _LazyWriter:
    """Calls `grammarkit.geometry.exporters.<name>` on first use (a picklable trampoline)."""

    def __init__(self, name: str):
        self.name = name

    def __call__(self, obj: Any, path: Path) -> None:
        return getattr(import_module("grammarkit.geometry.exporters"), self.name)(obj, path)


SPECS: tuple[ExporterSpec, ...] = (
    ExporterSpec("glb", (".glb",), "binary glTF: a node per part (name Type.N, type in extras), "
                 "face colours kept", _LazyWriter("_write_glb")),
    ExporterSpec("gltf", (".gltf",), "text glTF with embedded buffers; same content as glb",
                 _LazyWriter("_write_gltf")),
    ExporterSpec("obj", (".obj",), "Wavefront OBJ: an o/g group per part, vertex colours",
                 _LazyWriter("_write_obj")),
    ExporterSpec("stl", (".stl",), "binary STL: all parts as one mesh, no colours or names",
                 _LazyWriter("_write_stl")),
    ExporterSpec("ply", (".ply",), "binary PLY: all parts as one mesh with face colours",
                 _LazyWriter("_write_ply")),
)


@hookimpl
def grammarkit_exporters() -> list[ExporterSpec]:
    return list(SPECS)
