"""The built-in split operations, registered through the `grammarkit_operations` hook.

Specs (names, parameters, block kinds) are the language contract that `grammarkit check`
validates against; each is declared above its implementation in `grammarkit.split.ops`.
"""
from __future__ import annotations

from typing import Any, Iterable

from ..hookspecs import hookimpl
from ..registry import FitSpec, OperationSpec
from . import ops

# The specs stand beside their bodies in grammarkit.split.ops (each operation's @operation(...)
# registration); the package imports its geometry libraries on first use, so loading the specs
# here keeps `grammarkit check` light.
SPECS: tuple[OperationSpec, ...] = ops.SPECS


@hookimpl
def grammarkit_operations() -> Iterable[OperationSpec]:
    return SPECS


def fit_scale(mesh: Any, size: tuple[float, float, float]) -> Any:
    """The built-in fit: the asset scaled (per axis) so its bounding box is `size`."""
    import numpy as np

    ext = mesh.extents
    scale = [s / e if e > 1e-12 else 1.0 for s, e in zip(size, ext)]
    out = mesh.copy()
    out.apply_transform(np.diag([*scale, 1.0]))
    return out


FITS: tuple[FitSpec, ...] = (
    FitSpec("scale", "scale the asset to the scope (a zero scope size keeps its proportion)", fit_scale),
)


@hookimpl
def grammarkit_insert_fits() -> Iterable[FitSpec]:
    return FITS


@hookimpl
def grammarkit_functions() -> Iterable[Any]:
    """CGA's string and list functions (grammarkit/split/strings.py; pure Python, light)."""
    from ..registry import FunctionSpec
    from .strings import STRING_FUNCTIONS

    # CGA's occlusion queries: the split compiler binds them to the shape they are evaluated on
    # (grammarkit/split/occlusion.py), so they have no value-only implementation here
    occlusion = tuple(FunctionSpec(name, 0, 2, f"CGA's {name}(target = \"intra\", label): a query against the "
                                   "model derived so far (split grammars)") for name in ("inside", "overlaps", "touches"))
    return (*STRING_FUNCTIONS, *occlusion)
