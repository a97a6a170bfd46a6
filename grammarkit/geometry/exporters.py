"""Model writers for GLB, glTF, OBJ, STL and PLY, registered as the `core-exporters` plugin.

Every writer turns a split `Model`, a tiling `Assembly`, a trimesh Scene or a Trimesh into
bytes (`encode_*`); the run layer's writer (`grammarkit.fileio.write_files`) writes them
atomically. All formats share one intermediate form, a list of `Solid`s: one vertex set each
(never split at colour seams), its triangles grouped into named groups, each triangle with a
material (a name and an sRGB colour).

The writers live one module per format in `grammarkit.geometry.exchange` (`gltf`, `obj`,
`stl`, `ply`) on one scene model (`exchange.scene`); this module re-exports them and holds the
exporter lookup (`exporter_for`, `encode`, `encode_with`, `export`), so that
`grammarkit.geometry.exporters` keeps its public names.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from ..errors import ShapeError
from ..registry import ExporterSpec
from .exchange.gltf import (  # noqa: F401 - re-exported
    GLTF_FORMAT, Z_UP_TO_Y_UP, Z_UP_TO_Y_UP_MATRIX, _build_gltf, _GltfBuilder, _one_primitive,
    encode_glb, encode_gltf,
)
from .exchange.obj import encode_obj  # noqa: F401 - re-exported
from .exchange.ply import encode_ply  # noqa: F401 - re-exported
from .exchange.scene import (  # noqa: F401 - re-exported
    DEFAULT_RGBA, TYPE_PALETTE, Material, Scene, Solid, scene_from_parts, solids_of, srgb_to_linear,
    to_scene, type_colors, world_mesh as _world_mesh,
)
from .exchange.stl import encode_stl  # noqa: F401 - re-exported

__all__ = ["OutputError", "Solid", "Material", "atomic_output", "encode", "encode_with", "export",
           "exporter_for", "known_formats", "scene_from_parts", "solids_of", "to_scene",
           "grammarkit_exporters", "srgb_to_linear", "GLTF_FORMAT", "Z_UP_TO_Y_UP"]

# The atomic writer is shared by every command that writes files (fileio.py has no heavy imports).
from ..fileio import OutputError, atomic_output  # noqa: E402


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
