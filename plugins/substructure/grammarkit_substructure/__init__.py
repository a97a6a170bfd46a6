"""grammarkit substructure search: replaceable substructures (Liu et al. 2015).

Python API::

    from grammarkit_substructure import substructure
    ops = substructure.enumerate(assembly, rules)      # every normalised operation
    variant = substructure.apply(assembly, ops[0])     # the assembly after one of them

CLI: ``grammarkit derive castle.grammar --backend substructure -n 200 --seed 7 -o variants/``
and ``grammarkit substructures castle_small.glb --grammar castle.grammar``. See docs/substructure.md.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["Operation", "SubstructureOptions", "apply", "enumerate", "substructure"]


def __getattr__(name: str) -> Any:
    # Imported on first use: the plugin manager imports `.plugin` (and so this package) for
    # every `grammarkit` command, which must not pay for numpy, trimesh and manifold3d.
    if name == "substructure":
        value = import_module(f"{__name__}.api")
    elif name == "SubstructureOptions":
        value = import_module(f"{__name__}.options").SubstructureOptions
    elif name == "Operation":
        value = import_module(f"{__name__}.search").Operation
    elif name in ("apply", "enumerate"):
        value = getattr(import_module(f"{__name__}.api"), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value
