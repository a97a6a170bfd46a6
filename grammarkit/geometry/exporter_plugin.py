"""The built-in exporters' plugin registration (entry point `core-exporters`).

Kept apart from `exporters.py` so that loading plugins (which every `grammarkit` command
does) does not import trimesh; the writers are imported on first use.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

from ..hookspecs import hookimpl
from ..registry import ExporterSpec


class _Lazy:
    """Calls `grammarkit.geometry.exporters.<name>` on first use (a picklable trampoline)."""

    def __init__(self, name: str):
        self.name = name

    def __call__(self, *args: Any) -> Any:
        return getattr(import_module("grammarkit.geometry.exporters"), self.name)(*args)


def check_glb(data: bytes) -> str | None:
    """A GLB starts with the magic 'glTF', version 2 and its own total length."""
    import struct

    if len(data) < 20 or data[:4] != b"glTF":
        return "no GLB header"
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2 or length != len(data):
        return f"GLB header says version {version}, {length} bytes; got {len(data)} bytes"
    return None


def check_gltf(data: bytes) -> str | None:
    import json

    try:
        doc = json.loads(data)
    except ValueError as exc:
        return f"not JSON: {exc}"
    return None if isinstance(doc, dict) and "asset" in doc else "no glTF asset block"


def check_obj(data: bytes) -> str | None:
    return None if b"\nf " in data and b"\nv " in data else "no vertices or faces"


def check_stl(data: bytes) -> str | None:
    import struct

    if len(data) < 84:
        return "shorter than an STL header"
    (count,) = struct.unpack_from("<I", data, 80)
    return None if len(data) == 84 + 50 * count and count > 0 else "size does not match the triangle count"


def check_ply(data: bytes) -> str | None:
    return None if data.startswith(b"ply") and b"end_header" in data[:4096] else "no PLY header"


SPECS: tuple[ExporterSpec, ...] = (
    ExporterSpec("glb", (".glb",), "binary glTF, +Y up (rotated root): a PBR material per (material, "
                 "colour), a node per terminal name or part with extras, one closed vertex set per solid",
                 _Lazy("encode_glb"), check_glb),
    ExporterSpec("gltf", (".gltf",), "text glTF with the buffer embedded; same content as glb",
                 _Lazy("encode_gltf"), check_gltf),
    ExporterSpec("obj", (".obj",), "Wavefront OBJ (Z up): an o/g group per solid, vertex colours, extras comment",
                 _Lazy("encode_obj"), check_obj),
    ExporterSpec("stl", (".stl",), "binary STL (Z up): all solids as one mesh, no colours or names",
                 _Lazy("encode_stl"), check_stl),
    ExporterSpec("ply", (".ply",), "binary PLY (Z up): all solids as one mesh with face colours",
                 _Lazy("encode_ply"), check_ply),
)


@hookimpl
def grammarkit_exporters() -> list[ExporterSpec]:
    return list(SPECS)
