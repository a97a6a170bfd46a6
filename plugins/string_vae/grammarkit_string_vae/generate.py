"""The `string-vae` back end's work: sample latent points, decode, keep new valid graphs, and,
with an edge-category model, instantiate them in 3D.

Without `--option categories=...` results are data only (`Result.model` is None: the string and
its graph, in the manifest). With it, each new graph's edge categories are predicted (voting
over several strings) and the graph is instantiated (instantiate.py); a graph that cannot be
instantiated within the tries is skipped and counted with its reason, never written half.
"""
from __future__ import annotations

import re
import time

import numpy as np
from typing import Iterator

from grammarkit.errors import GrammarkitError
from grammarkit.run import Request, Result

from .requires import require_learning


def generate(request: Request) -> Iterator[Result]:
    require_learning("the string-vae back end")
    import torch

    # decoding runs one latent point at a time (batch 1, a 192-unit GRU step): intra-op threads
    # cannot help, and on a shared machine their spin-waits made a step 17.7 ms instead of
    # 0.32 ms (2 threads against 1 at load average 11); the run's workers parallelise instead
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        stats = yield from _generate(request)
    finally:
        torch.set_num_threads(threads)
    return stats


# long: one loop over samples with its bookkeeping (skips, where graphs were lost, instantiation
# statistics, stopping rules); split up it would pass a dozen counters around
def _generate(request: Request) -> Iterator[Result]:
    from .graphs import GraphSet
    from .modelfile import load_vae
    from .sampling import Sampler, SamplingSettings
    from .strings import convert

    opts = shipped_defaults(request.options, request.grammar.name)
    t0 = time.perf_counter()
    vae = load_vae(opts.model, grammar=request.grammar)
    settings = SamplingSettings(decoding=opts.decoding, temperature=opts.temperature,
                                magnitude=opts.magnitude, steps=opts.steps,
                                local_magnitude=opts.local_magnitude, points=opts.points,
                                path_length=opts.path_length, batch=opts.batch, max_tokens=opts.max_tokens,
                                max_length=opts.max_length, min_length=opts.min_length)
    if opts.decoding == "placed" and not opts.categories:
        raise GrammarkitError("--option decoding=placed needs edge categories: --option categories=FILE.edges "
                              "(or builtin:castle)")
    if opts.decoding == "placed":  # seconds per point: small batches, so the time budget is polled often
        settings = SamplingSettings(**{**settings.__dict__, "batch": min(opts.batch, 2)})
    sampler = Sampler(vae, settings, seed=request.seed)
    limit = opts.max_decodes or 200 * max(1, request.n)
    # placed decoding takes seconds per latent point: the sampler polls the graceful budget and
    # the hard deadline between points (the hard one then raises at the loop's check below)
    sampler.stop = lambda: (request.time_is_up() or (request.deadline is not None and time.monotonic() > request.deadline)
                            or sampler.decoded_points >= limit)
    train = GraphSet()
    for g in sampler.train_graphs:
        train.add(g)
    seen = GraphSet()
    if opts.search_past_known:  # perturbation grows its offset past training graphs and repeats
        sampler.known = lambda g: (not opts.include_training and g in train) or g in seen
        sampler.novel_only = opts.novel_search
    sampler.per_point = opts.per_point
    em = inst = None
    if opts.categories:
        from .edgemodel import load_edge_model
        from .instantiate import Instantiator

        from .consistent import ConsistentDecoder

        em = load_edge_model(opts.categories, request.grammar)
        inst = Instantiator(request.grammar, em.categories, budget=opts.budget)
        decoder = ConsistentDecoder(inst, beam=opts.beam)
        if opts.decoding == "placed":
            from .placed import PlacedDecoder

            sampler.placed = PlacedDecoder(vae, inst, expansions=opts.placed_steps, width=opts.width,
                                           slack=opts.slack, temperature=opts.temperature, reach=opts.reach,
                                           max_open=opts.max_open_rings, finish_check=opts.finish_check)
    failures: dict[str, int] = {}
    inst_stats = {"instantiated": 0, "failed": 0, "tries": 0, "monte_carlo": 0, "seconds": 0.0}
    advance = request.progress("string-vae", request.n)
    index = 0
    last_new = 0  # decoded points when the last shape was yielded (the patience rule)

    def on_point() -> None:  # the bar moves per decoded latent point, not only per shape
        advance(0, decoded=sampler.decoded_points, made=index, lost=sampler.decoded_points - index)
    sampler.on_point = on_point
    skipped = {"invalid": 0, "training": 0, "duplicate": 0, "too large": 0}
    stages = {"decoding": 0, "categories": 0, "3D placement": 0, "novelty": 0}  # where the graphs that were not built failed
    stopped = None
    while index < request.n and sampler.decoded_points < limit and stopped is None:
        request.check_deadline()
        if request.time_is_up():  # the sampler stops early then and yields nothing: stop here too
            stopped = "time limit"
            break
        if sampler.decoded_points - last_new >= opts.patience:
            stopped = "patience"
            break
        for s in sampler.run(opts.mode, 1):
            if index >= request.n:
                break
            if request.time_is_up():
                stopped = "time limit"
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
            if opts.max_parts is not None and len(g) > opts.max_parts:
                skipped["too large"] += 1
                continue
            model = None
            extra_inst: dict = {}
            if s.decoded.placement is not None:  # placed decoding: the shape is already laid out
                res, predicted = build_placed(inst, g, s.decoded.placement), {}
            elif inst is not None:
                gseed = int(request.seed) * 1_000_003 + sampler.decoded_points
                res, predicted = instantiate_graph(em, inst, decoder, g, opts, gseed, request.deadline)
            if inst is not None:
                inst_stats["tries"] += res.tries
                inst_stats["seconds"] += res.seconds
                if not res.ok:
                    inst_stats["failed"] += 1
                    # group failures by kind: the reason without part numbers and distances
                    why = (res.reason or "?").split("most often: ")[-1]
                    key = re.sub(r"\d+(\.\d+)?", "N", why.split(": placing")[0].split(" puts ")[0])[:90]
                    failures[key] = failures.get(key, 0) + 1
                    # the consistent search found no labelling: the categories; else the shape
                    stages["3D placement" if s.decoded.placement is not None or "finished shape" in why
                           else "categories"] += 1
                    continue
                inst_stats["instantiated"] += 1
                inst_stats["monte_carlo"] += res.monte_carlo
                model = res.assembly
                model.name = f"{request.grammar.name}_string_{index:05d}"
                extra_inst = {"categories": token_categories(s.text, vae.alphabet, em.categories, res.categories),
                              "predicted": token_categories(s.text, vae.alphabet, em.categories,
                                                            {e: r[0] for e, r in predicted.items() if r}),
                              "instantiation": {"tries": res.tries, "insertions": res.insertions,
                                                "monte_carlo": res.monte_carlo, "seconds": round(res.seconds, 3)}}
            rid = f"{request.grammar.name}_string_{index:05d}"
            yield Result(
                id=rid, index=index, model=model, seed=request.seed,
                parents=tuple(f"train:{p}" for p in s.parents),
                metrics={"parts": len(g), "cycles": g.cycle_rank, "repaired": s.decoded.repaired},
                extra={"string": s.text,
                       "string2shape": convert(s.text, vae.alphabet, target="string2shape"),
                       "graph": {"nodes": [{"id": i, "type": t} for i, t in enumerate(g.types)],
                                 "edges": [list(e) for e in g.edges]},
                       "histogram": g.histogram(), "mode": opts.mode, "decoding": opts.decoding,
                       "novel": g not in train, **extra_inst})
            index += 1
            last_new = sampler.decoded_points
            elapsed = time.perf_counter() - t0
            advance(1, decoded=sampler.decoded_points,
                    eta=f"{elapsed / index * (request.n - index):.0f}s")
    stats = {"decoded": sampler.decoded_points, "valid": sampler.valid_points,
             "validity": round(sampler.valid_points / max(1, sampler.decoded_points), 4),
             "yielded": index, "skipped": skipped, "mode": opts.mode, "decoding": opts.decoding,
             "seconds": round(time.perf_counter() - t0, 2)}
    if inst is not None:
        stats["instantiation"] = {**inst_stats, "seconds": round(inst_stats["seconds"], 2), "failures": failures}
    for key, c in sampler.lost.items():  # latent points that decoded to nothing usable
        stages[key] = stages.get(key, 0) + c
    # valid graphs the run could not use: training graphs and graphs made already
    # (and those the perturbation search moved past, counted by the sampler)
    stages["novelty"] = stages.get("novelty", 0) + skipped["training"] + skipped["duplicate"]
    stats["lost"] = stages
    if index < request.n:
        why = {"time limit": "the time limit was reached",
               "patience": f"no new shape in the last {opts.patience} latent points (--option patience=N)",
               None: f"the decoding limit was reached ({limit} latent points: --option max-decodes=N)"}[stopped]
        worst = max(stages, key=stages.get)
        neck = (f"; the bottleneck is {worst} ({stages[worst]} of {sum(stages.values())} graphs lost there: "
                f"{', '.join(f'{k} {v}' for k, v in stages.items())})" if any(stages.values()) else "")
        stats["shortfall"] = (f"{why} after decoding {sampler.decoded_points} latent "
                              f"points{neck}; skipped {skipped}"
                              + (f"; {inst_stats['failed']} could not be instantiated ({failures})" if inst else ""))
    return stats


# per shipped model, the placed-decoding settings measured for it (docs/string-vae.md)
SHIPPED_SETTINGS: dict[str, dict] = {"castle": {"max_length": 56, "min_length": 41, "max_open_rings": 2}}


def shipped_defaults(opts, grammar_name: str):  # noqa: ANN001, ANN201
    """The options with the shipped models filled in when no model is given: the grammar's
    `builtin:` VAE, its edge categories (unless given), placed decoding, the length prior of
    training strings of 41-56 tokens and at most two open rings (unless given), the settings
    docs/string-vae.md measures.
    A grammar without shipped weights is told what ships and how to train one."""
    from .modelfile import WEIGHTS

    decoding = opts.decoding or "masked"
    if opts.model is not None:
        return opts.model_copy(update={"decoding": decoding})
    shipped = sorted(p.stem for p in WEIGHTS.glob("*.vae"))
    if grammar_name not in shipped:
        raise GrammarkitError(
            f"the string-vae back end needs --option model=FILE.vae: no model ships for grammar {grammar_name!r} "
            f"(shipped: {', '.join(shipped) or 'none'}); make one with `grammarkit dataset` and `grammarkit train "
            "string-vae` (docs/string-vae.md, \"Training data\")")
    update = {"model": f"builtin:{grammar_name}"}
    if opts.categories is None and (WEIGHTS / f"{grammar_name}.edges").is_file():
        update["categories"] = f"builtin:{grammar_name}"
    cats = update.get("categories", opts.categories)
    update["decoding"] = opts.decoding or ("placed" if cats else "masked")
    tuned = SHIPPED_SETTINGS.get(grammar_name, {})
    if update["decoding"] == "placed" and opts.max_length is None and opts.max_tokens is None:
        # the measured setting (docs/string-vae.md): for the castle, budgets of the training
        # strings of 41-56 tokens (smaller castles are nearly all known); the other examples'
        # small models use the plain length prior (the start string's length)
        if "max_length" in tuned:
            update["max_length"] = tuned["max_length"]
            if opts.min_length is None:
                update["min_length"] = tuned["min_length"]
    if update["decoding"] == "placed" and opts.max_open_rings is None and "max_open_rings" in tuned:
        update["max_open_rings"] = tuned["max_open_rings"]
    return opts.model_copy(update=update)


def build_placed(inst, g, placement):  # noqa: ANN001, ANN201
    """The shape of a placed decoding, checked like any instantiation (`Instantiator.build`:
    the requested graph and `validate` at both tolerances) before it may be yielded."""
    from .instantiate import Instantiation

    t = time.perf_counter()
    if placement.assembly is not None:  # the decoder built and checked it already (finish_check)
        asm, problem = placement.assembly, None
    else:
        asm, problem = inst.build(g, placement.frames, placement.variants)
    out = Instantiation(asm, tries=1, insertions=placement.expansions, categories=dict(placement.categories),
                        reason=problem, seconds=time.perf_counter() - t)
    return out


def instantiate_graph(em, inst, decoder, g, opts, seed: int, deadline: float | None):  # noqa: ANN001, ANN201
    """Instantiate graph `g` as `opts.search` says: (Instantiation, {edge: ranking of its
    categories, the voted one first})."""
    from .consistent import instantiate_consistent

    voting = opts.voting or em.voting
    if opts.search == "backtracking":
        predicted = em.rankings(g, strings=opts.votes, seed=seed, voting=voting)
        return inst.instantiate(g, predicted, seed=seed, max_tries=opts.tries, deadline=deadline), predicted
    # the consistent search's priors are the summed log-probabilities, whatever the model's voting
    pred = em.predict(g, strings=opts.votes, seed=seed, voting="logprob")
    votes = {e: v for e, (_k, v) in pred.items()}
    predicted = {e: [int(c) for c in np.argsort(-v, kind="stable") if v[c] > -1e8] for e, v in votes.items()}
    res = instantiate_consistent(inst, decoder, g, votes, tries=opts.tries, deadline=deadline)
    if res.ok or opts.search == "consistent":
        return res, predicted
    # the beam can lose the right labelling: search again by backtracking over the votes
    back = inst.instantiate(g, predicted, seed=seed, max_tries=opts.tries, deadline=deadline)
    back.insertions += res.insertions
    back.seconds += res.seconds
    return back, predicted


def token_categories(text: str, alphabet, cats, used: dict) -> list:  # noqa: ANN001
    """Per token of `text`: the category of its edge as written (parent -> child, opener ->
    closer), from `used` ({(u, v), u < v: category u -> v}); None for tokens without an edge."""
    from .predictor import string_edges
    from .vocab import Vocab

    out = []
    for e in string_edges(text, Vocab(alphabet, 99)):
        if e is None:
            out.append(None)
            continue
        u, v = e
        k = used.get((min(u, v), max(u, v)))
        out.append(None if k is None else (k if u < v else cats.reverse.get(k, k)))
    return out


__all__ = ["generate", "GrammarkitError"]
