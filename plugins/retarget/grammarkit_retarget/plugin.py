"""The retargeter plugin, registered through the `grammarkit` entry-point group.

- `grammarkit_cli_commands`: the `grammarkit retarget` command (cli.py).
- `grammarkit_insert_fits`: `fit=retarget` for split grammars, `i("fence.glb", fit=retarget)`:
  the asset is retargeted to the scope instead of scaled into it.

Importing this module stays light (click and grammarkit's registry only); the method's modules
load when a command or fit runs.
"""
from __future__ import annotations

from grammarkit import hookimpl
from grammarkit.registry import FitSpec

from .cli import retarget_command


def fit_retarget(mesh, size):
    """`FitSpec.fit`: the asset (a Trimesh with its bounding box's minimum corner at the origin)
    retargeted to the scope `size`, bounding box exactly `size`, same frame.

    Along principal offsets the asset gains or loses whole repeats and the remainder (under
    half a repeat) is scaled; along the other axes it is scaled (the scope must be filled).
    A scope size of 0 on an axis keeps the asset's own size there. An asset without repetitive
    structure is scaled (as `fit=scale`)."""
    import numpy as np

    from .retargeting import prepare_mesh, retarget_report

    name = str((getattr(mesh, "metadata", None) or {}).get("file_name")
               or (getattr(mesh, "metadata", None) or {}).get("name") or "inserted asset")
    mesh = prepare_mesh(mesh, name)
    ext = np.asarray(mesh.extents, dtype=np.float64)
    target = np.array([s if s > 1e-12 else e for s, e in zip(size, ext)], dtype=np.float64)
    report = retarget_report(mesh, target, allow_scale=True, exact=True, name=name)
    out = report.mesh
    out.apply_translation(-np.asarray(out.bounds[0]))
    return out


FIT = FitSpec(name="retarget", fit=fit_retarget,
              doc="retarget the asset to the scope: repeated elements are added or removed "
                  "along its principal offsets instead of stretched (Wu et al.)")


@hookimpl
def grammarkit_cli_commands():
    return [retarget_command]


@hookimpl
def grammarkit_insert_fits():
    return [FIT]
