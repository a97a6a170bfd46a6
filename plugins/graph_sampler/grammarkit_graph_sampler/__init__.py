"""grammarkit graph sampler: new valid tiling assemblies from examples (Kalojanov et al. 2019, s. 4).

Python API::

    from grammarkit_graph_sampler import sampler
    for assembly in sampler.sample(grammar, n=200, iterations=4, seed=7):
        ...

CLI: ``grammarkit derive castle.grammar --backend graph-sampler -n 200 --iterations 4 --seed 7 -o out/``
(the back end is the default for tiling grammars). See docs/graph-sampler.md.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["GraphSampler", "SamplerOptions", "sample", "sampler"]


def __getattr__(name: str) -> Any:
    # Imported on first use: the plugin manager imports `.plugin` (and so this package) for
    # every `grammarkit` command, which must not pay for trimesh and manifold3d.
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module = import_module(f"{__name__}.sampler")
    value = module if name == "sampler" else getattr(module, name)
    globals()[name] = value
    return value
