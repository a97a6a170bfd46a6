"""grammarkit graph sampler: new valid tiling assemblies from examples (Kalojanov et al. 2019, s. 4).

Python API::

    from grammarkit_graph_sampler import sampler
    for assembly in sampler.sample(grammar, n=200, iterations=4, seed=7):
        ...

CLI: ``grammarkit derive castle.grammar --backend graph-sampler -n 200 --iterations 4 --seed 7 -o out/``
(the back end is the default for tiling grammars). See docs/graph-sampler.md.
"""
from __future__ import annotations

from . import sampler
from .sampler import GraphSampler, SamplerOptions, sample

__all__ = ["GraphSampler", "SamplerOptions", "sample", "sampler"]
