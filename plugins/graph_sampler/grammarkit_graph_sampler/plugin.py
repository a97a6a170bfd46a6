"""The `graph-sampler` back end, registered through the `grammarkit` entry-point group.

`grammarkit derive castle.grammar [--backend graph-sampler] -n 200 --iterations 4 --seed 7 -o out/`
runs `run(request)`: it yields up to `n` new valid variants sampled from the grammar's examples
as `grammarkit.run.Result`s (the assembly, its parents, and the operation that made it); the
run layer writes them (`out/variant_NNNNN.glb`, `manifest.jsonl`). Options (`--option key=value`)
are the fields of `SamplerOptions` (tolerance, dock-tolerance, dedupe=histogram|isomorphism, ...).
"""
from __future__ import annotations

import time
from typing import Iterator

from grammarkit import hookimpl
from grammarkit.run import BackendSpec, Request, Result

from .options import SamplerOptions


def run(request: Request) -> Iterator[Result]:
    """Yield new variants; return the run's statistics (growth table, attempts, outcomes)."""
    from .sampler import GraphSampler

    t0 = time.perf_counter()
    sampler = GraphSampler(request.grammar, seed=request.seed, executor=request.executor,
                           options=request.options)
    for index, shape in enumerate(sampler.run(request.n, request.iterations,
                                              progress=request.progress)):
        request.check_deadline()
        if index < request.start:
            continue  # already written by an interrupted run; the sampler must still make it
        assembly = sampler.to_assembly(shape)
        yield Result(id=shape.key, index=index, seed=request.seed, model=assembly,
                     parents=tuple(shape.parents),
                     metrics={"parts": len(shape), "iteration": shape.iteration,
                              "residual": float(shape.operation.get("residual", 0.0))},
                     extra={"histogram": shape.histogram(),
                            "graph": {"nodes": [{"id": i, "type": t} for i, t in zip(shape.ids, shape.types)],
                                      "edges": [[shape.ids[a], shape.ids[b]] for a, b in shape.edges]},
                            "operation": assembly.meta["graph_sampler"]["operation"],
                            "dedupe": sampler.options.dedupe})
    return summary(sampler, time.perf_counter() - t0, request)


def summary(sampler, elapsed: float, request: Request) -> dict:
    attempts = sum(s.attempts for s in sampler.stats)
    valid = sum(s.outcomes["valid"] for s in sampler.stats)
    made = sampler.counter
    out = {
        "examples": len(sampler.examples),
        "workers": sampler.workers,
        "dedupe": sampler.options.dedupe,
        "attempts": attempts,
        "valid": valid,
        "new": made,
        "attempts_per_variant": round(attempts / made, 2) if made else None,
        "seconds": round(elapsed, 3),
        "variants_per_minute": round(60.0 * made / elapsed, 1) if elapsed > 0 else None,
        "growth": sampler.growth_table(),
        "iterations": [s.row() for s in sampler.stats],
    }
    if made < request.n:
        last = sampler.stats[-1] if sampler.stats else None
        if last is not None and last.new == 0:
            why = (f"iteration {last.iteration} found no new variant in {last.attempts} attempts "
                   f"({', '.join(f'{k} {v}' for k, v in last.outcomes.items() if v)})")
        else:
            why = f"{request.iterations} iteration(s) made {made} new variants"
        out["shortfall"] = why + "; more --iterations or other options may find more"
    return out


BACKEND = BackendSpec(
    name="graph-sampler",
    summary="new valid assemblies by subgraph replacement between examples (Kalojanov 2019, s. 4)",
    families=frozenset({"tiling"}),
    run=run,
    options=SamplerOptions,
    default_for=frozenset({"tiling"}),
)


@hookimpl
def grammarkit_backends():
    return [BACKEND]
