"""grammarkit retargeter: resize a model without stretching its repeated elements, by stitching
translated copies of it along its principal offsets (Wu et al., "3D Model Retargeting Using
Offset Statistics").

Python API::

    from grammarkit_retarget import retarget, principal_offsets
    wide = retarget(mesh, (3.0, 1.2, 0.4))          # trimesh.Trimesh in, trimesh.Trimesh out
    offsets = principal_offsets(mesh)                # Offsets: generators, counts, histogram stats

CLI: ``grammarkit retarget bookshelf.glb --size 3.0 1.2 0.4 -o wide_shelf.glb``; in split
grammars: ``i("fence.glb", fit=retarget)``. See docs/retarget.md.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

# name -> module; imported on first use (the plugin manager imports `.plugin`, and so this
# package, for every `grammarkit` command, which must not pay for trimesh, scipy, manifold3d)
_LAZY = {
    "retarget": "retargeting", "retarget_report": "retargeting", "scale_to": "retargeting",
    "RetargetReport": "retargeting",
    "principal_offsets": "offsets", "Offsets": "offsets", "OffsetParams": "offsets",
    "SamplingParams": "features",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
