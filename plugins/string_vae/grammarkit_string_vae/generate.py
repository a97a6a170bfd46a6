"""The `string-vae` back end's work: sample latent points, decode, keep new valid graphs.

Results are data only (`Result.model` is None: a string and its graph, in the manifest) until
an edge-category model is given (instantiation in 3D, instantiate.py).
"""
from __future__ import annotations

import time
from typing import Iterator

from grammarkit.errors import GrammarkitError
from grammarkit.run import Request, Result

from .requires import require_learning


def generate(request: Request) -> Iterator[Result]:
    require_learning("the string-vae back end")
    from .graphs import GraphSet
    from .modelfile import load_vae
    from .sampling import Sampler, SamplingSettings
    from .strings import convert

    opts = request.options
    t0 = time.perf_counter()
    vae = load_vae(opts.model, grammar=request.grammar)
    settings = SamplingSettings(decoding=opts.decoding, temperature=opts.temperature,
                                magnitude=opts.magnitude, steps=opts.steps,
                                local_magnitude=opts.local_magnitude, points=opts.points,
                                path_length=opts.path_length, batch=opts.batch)
    sampler = Sampler(vae, settings, seed=request.seed)
    train = GraphSet()
    for g in sampler.train_graphs:
        train.add(g)
    seen = GraphSet()
    limit = opts.max_decodes or 200 * max(1, request.n)
    advance = request.progress("string-vae", request.n)
    index = 0
    skipped = {"invalid": 0, "training": 0, "duplicate": 0}
    while index < request.n and sampler.decoded_points < limit:
        request.check_deadline()
        for s in sampler.run(opts.mode, 1):
            if index >= request.n:
                break
            if not s.valid:
                skipped["invalid"] += 1
                continue
            g = s.decoded.graph
            if not opts.include_training and g in train:
                skipped["training"] += 1
                continue
            if not seen.add(g):
                skipped["duplicate"] += 1
                continue
            rid = f"{request.grammar.name}_string_{index:05d}"
            yield Result(
                id=rid, index=index, model=None, seed=request.seed,
                parents=tuple(f"train:{p}" for p in s.parents),
                metrics={"parts": len(g), "cycles": g.cycle_rank, "repaired": s.decoded.repaired},
                extra={"string": s.text,
                       "string2shape": convert(s.text, vae.alphabet, target="string2shape"),
                       "graph": {"nodes": [{"id": i, "type": t} for i, t in enumerate(g.types)],
                                 "edges": [list(e) for e in g.edges]},
                       "histogram": g.histogram(), "mode": opts.mode, "decoding": opts.decoding,
                       "novel": g not in train})
            index += 1
            advance(1, decoded=sampler.decoded_points)
    stats = {"decoded": sampler.decoded_points, "valid": sampler.valid_points,
             "validity": round(sampler.valid_points / max(1, sampler.decoded_points), 4),
             "yielded": index, "skipped": skipped, "mode": opts.mode, "decoding": opts.decoding,
             "seconds": round(time.perf_counter() - t0, 2)}
    if index < request.n:
        stats["shortfall"] = (f"{index} new graphs after decoding {sampler.decoded_points} latent points "
                              f"(limit {limit}: --option max-decodes=N); skipped {skipped}")
    return stats


__all__ = ["generate", "GrammarkitError"]
