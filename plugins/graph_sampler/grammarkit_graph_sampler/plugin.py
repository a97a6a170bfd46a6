"""The `graph-sampler` back end, registered through the `grammarkit` entry-point group.

`grammarkit derive castle.grammar [--backend graph-sampler] -n 200 --seed 7 -o out/`
runs `run(request)`: it yields up to `n` new valid variants sampled from the grammar's examples,
iterating until `n` are made, the iteration cap (`--option max-iterations=64`, or `--iterations`
if larger), an iteration that finds nothing new, or the graceful `--time-limit` (the summary's
`stopped` says which; every variant passes `validate` before it is written)
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


# runs asking for at least this many variants start the executor's workers at once (about
# 10 s of work at the castle's rate, far more than a worker's start-up)
WARM_N = 100


def run(request: Request) -> Iterator[Result]:
    """Yield new variants; return the run's statistics (growth table, attempts, outcomes)."""
    from .sampler import GraphSampler

    t0 = time.perf_counter()
    warm = getattr(request.executor, "warm", None)
    if warm is not None and request.n >= WARM_N:
        # a long run: the workers start while the examples are read and checked here
        warm()
    sampler = GraphSampler(request.grammar, seed=request.seed, executor=request.executor,
                           options=request.options)
    cap = max(request.iterations, sampler.options.max_iterations)
    index = -1
    # every shape the sampler yields has passed `grammarkit validate` (option final_check:
    # inside the attempt, so in the workers, before it can be kept)
    for shape in sampler.run(request.n, cap, progress=request.progress, time_is_up=request.time_is_up):
        request.check_deadline()
        assembly = sampler.to_assembly(shape)
        index += 1
        if index < request.start:
            continue  # already written by an interrupted run; the sampler must still make it
        yield Result(id=shape.key, index=index, seed=request.seed, model=assembly,
                     parents=tuple(shape.parents),
                     metrics={"parts": len(shape), "iteration": shape.iteration,
                              "residual": float(shape.operation.get("residual", 0.0))},
                     extra={"histogram": shape.histogram(),
                            "graph": {"nodes": [{"id": i, "type": t} for i, t in zip(shape.ids, shape.types)],
                                      "edges": [[shape.ids[a], shape.ids[b]] for a, b in shape.edges]},
                            "operation": assembly.meta["graph_sampler"]["operation"],
                            "dedupe": sampler.options.dedupe})
    return summary(sampler, time.perf_counter() - t0, request, cap)


def summary(sampler, elapsed: float, request: Request, cap: int | None = None) -> dict:
    attempts = sum(s.attempts for s in sampler.stats)
    valid = sum(s.outcomes["valid"] for s in sampler.stats)
    made = sampler.counter
    dropped = sum(s.outcomes["final-check"] for s in sampler.stats)
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
    stopped = sampler.stopped if made < request.n else "n"
    # `stopped_by` is the machine-readable cause ("n", "time", "iterations", "exhausted"),
    # `stopped` the same in words
    out["stopped_by"] = stopped
    out["stopped"] = {"n": f"made the {request.n} asked for", "time": "the time limit was reached",
                      "iterations": f"the iteration cap ({cap or request.iterations}) was reached",
                      "exhausted": "an iteration found no new variant"}.get(stopped, stopped)
    out["dropped_by_final_check"] = dropped
    if made < request.n and stopped != "time":
        # the time case has no sentence of the back end's own: the run layer, which owns the
        # budget, says it (with the limit in seconds); nothing else explains the shortfall
        last = sampler.stats[-1] if sampler.stats else None
        if stopped == "exhausted" and last is not None:
            why = (f"iteration {last.iteration} found no new variant in "
                   f"{last.attempts} attempts ({', '.join(f'{k} {v}' for k, v in last.outcomes.items() if v)}); "
                   "other options (--option max-subgraph-fraction=..., tolerance=...) may find more"
                   + count_note(sampler))
        else:
            why = (f"the iteration cap ({cap or request.iterations}) was reached; "
                   "a larger --iterations or --option max-iterations=... may find more")
        out["shortfall"] = why
    return out


def count_note(sampler) -> str:
    """Why the count range (option counts="examples") may be what ran the pool dry."""
    dropped = sum(s.outcomes["counts"] for s in sampler.stats)
    if not dropped or not sampler.count_range:
        return ""
    ranges = ", ".join(f"{t} {lo}..{hi}" for t, (lo, hi) in sampler.count_range.items())
    return (f"; {dropped} attempts had part counts outside the examples' range ({ranges}), which "
            "admits few variants: --option counts=grammar keeps any count the grammar allows")


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
