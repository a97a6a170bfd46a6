"""The `graph-sampler` back end, registered through the `grammarkit` entry-point group.

`grammarkit derive castle.grammar [--backend graph-sampler] -n 200 --iterations 4 --seed 7 -o out/`
calls `derive(grammar, request)`: it samples up to `n` new valid variants from the grammar's
examples and writes `out/variant_NNNNN.glb` plus `out/manifest.jsonl`. Options (`--option key=value`)
are the fields of `SamplerOptions` (tolerance, dock-tolerance, dedupe=histogram|isomorphism, ...).
"""
from __future__ import annotations

import time
from pathlib import Path

from grammarkit import hookimpl
from grammarkit.errors import DerivationError
from grammarkit.registry import BackendSpec, DeriveRequest


def derive(grammar, request: DeriveRequest) -> dict:
    from .sampler import GraphSampler, SamplerOptions

    try:
        options = SamplerOptions.from_strings(dict(request.options or {}))
    except (ValueError, TypeError) as exc:
        raise DerivationError(str(exc), getattr(grammar, "span", None)) from None
    if request.out is None:
        raise DerivationError("graph-sampler: an output folder is required (-o DIR)")
    if request.n < 0 or request.iterations < 0:
        raise DerivationError("graph-sampler: -n and --iterations must be >= 0")
    t0 = time.perf_counter()
    sampler = GraphSampler(grammar, seed=request.seed, workers=request.workers, options=options)
    return write_variants(sampler, request, t0)


def write_variants(sampler, request: DeriveRequest, t0: float | None = None) -> dict:
    """Run `sampler` for `request.n` / `request.iterations`, writing GLBs and the manifest."""
    from .output import VariantWriter

    t0 = time.perf_counter() if t0 is None else t0
    options = sampler.options
    try:
        writer = VariantWriter(Path(request.out), dedupe=options.dedupe, seed=sampler.seed)
    except FileExistsError as exc:
        raise DerivationError(str(exc)) from None
    iteration = 0
    try:
        for shape in sampler.run(request.n, request.iterations, progress=request.progress):
            if shape.iteration != iteration:
                writer.flush()
                iteration = shape.iteration
            writer.write(sampler, shape)
    finally:
        manifest = writer.flush()
    elapsed = time.perf_counter() - t0
    return summary(sampler, writer, manifest, elapsed)


def summary(sampler, writer, manifest: Path, elapsed: float) -> dict:
    attempts = sum(s.attempts for s in sampler.stats)
    valid = sum(s.outcomes["valid"] for s in sampler.stats)
    written = len(writer.files)
    return {
        "backend": "graph-sampler",
        "out": str(writer.out),
        "manifest": str(manifest),
        "variants": written,
        "examples": len(sampler.examples),
        "seed": sampler.seed,
        "workers": sampler.workers,
        "dedupe": sampler.options.dedupe,
        "attempts": attempts,
        "valid": valid,
        "attempts_per_variant": round(attempts / written, 2) if written else None,
        "seconds": round(elapsed, 3),
        "variants_per_minute": round(60.0 * written / elapsed, 1) if elapsed > 0 else None,
        "growth": sampler.growth_table(),
        "iterations": [s.row() for s in sampler.stats],
    }


BACKEND = BackendSpec(
    name="graph-sampler",
    summary="new valid assemblies by subgraph replacement between examples (Kalojanov 2019, s. 4)",
    families=frozenset({"tiling"}),
    derive=derive,
    default_for=frozenset({"tiling"}),
)


@hookimpl
def grammarkit_backends():
    return [BACKEND]
