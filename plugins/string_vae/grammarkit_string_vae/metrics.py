"""Generator metrics (as MOSES / GuacaMol define them, on shape graphs) and the paper's tables.

- validity: valid strings / decoded latent points;
- unique@k: distinct graphs (isomorphism classes) among the first k valid ones, / k;
- novelty: distinct valid graphs not isomorphic to any training graph, / distinct valid graphs;
- internal diversity: mean histogram distance E over pairs of distinct generated graphs
  (1 - mean similarity; the training set's own value beside it for reference);
- nearest-training similarity: mean over generated graphs of 1 - (smallest E to a training graph);
- per sampling mode: decoded points, valid points, and new graphs (not the ones the search
  started from) per decoded point: the paper's yield;
- latent graph statistics (Table 2): components and path weights, latent versus naive.
"""
from __future__ import annotations

import time
from typing import Sequence

import numpy as np

from .graphs import GraphSet, TypedGraph, histogram_distance

__all__ = ["generator_metrics", "internal_diversity", "mode_yields", "table2", "vae_metrics"]


def internal_diversity(graphs: Sequence[TypedGraph], *, max_pairs: int = 20000, seed: int = 0) -> float | None:
    """Mean E over pairs (all pairs, or `max_pairs` random ones)."""
    n = len(graphs)
    if n < 2:
        return None
    hists = [g.histogram() for g in graphs]
    total = n * (n - 1) // 2
    if total <= max_pairs:
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    else:
        rng = np.random.default_rng(seed)
        a = rng.integers(0, n, size=max_pairs)
        b = rng.integers(0, n - 1, size=max_pairs)
        b = b + (b >= a)
        pairs = list(zip(a.tolist(), b.tolist()))
    return float(np.mean([histogram_distance(hists[i], hists[j]) for i, j in pairs]))


def generator_metrics(decoded: Sequence, train: GraphSet, train_graphs: Sequence[TypedGraph], *, k: int = 1000) -> dict:
    """Validity, unique@k, novelty, diversity and nearest-training similarity of decoded samples."""
    valid = [d.graph for d in decoded if d.valid]
    firstk = valid[:k]
    seen = GraphSet()
    unique_k = sum(seen.add(g) for g in firstk)
    uniq = GraphSet()
    distinct: list[TypedGraph] = []
    for g in valid:
        if uniq.add(g):
            distinct.append(g)
    novel = [g for g in distinct if g not in train]
    types = sorted({t for g in train_graphs for t in g.types} | {t for g in distinct for t in g.types})
    snn = None
    if distinct and train_graphs:
        T = np.array([[g.histogram().get(t, 0) for t in types] for g in train_graphs], dtype=np.float64)
        NT = T.sum(axis=1)
        sims = []
        for g in distinct:
            h = np.array([g.histogram().get(t, 0) for t in types], dtype=np.float64)
            d = np.abs(T - h).sum(axis=1) / np.maximum(NT + h.sum(), 1)
            sims.append(1.0 - float(d.min()))
        snn = float(np.mean(sims))
    return {
        "samples": len(decoded), "valid": len(valid),
        "validity": len(valid) / len(decoded) if decoded else None,
        f"unique@{k}": (unique_k / len(firstk)) if firstk else None,
        "unique_valid": len(distinct),
        "novel": len(novel), "novelty": (len(novel) / len(distinct)) if distinct else None,
        "internal_diversity": internal_diversity(distinct),
        "nearest_training_similarity": snn,
        "mean_parts": float(np.mean([len(g) for g in valid])) if valid else None,
        "repaired": {k_: sum(1 for d in decoded if getattr(d, "repaired", None) == k_)
                     for k_ in ("backtrack", "resample", "rules", "failed")},
    }


def mode_yields(vae, *, decoding: str, seeds: int = 128, seed: int = 0, settings=None) -> dict:
    """Per sampling mode: decoded points, valid points, new graphs (relative to the training
    graphs the search started from) and new-to-the-training-set graphs, per decoded point."""
    from dataclasses import replace

    from .sampling import Sampler, SamplingSettings

    base = settings or SamplingSettings()
    base = replace(base, decoding=decoding)
    out = {}
    train = GraphSet()
    for s in Sampler(vae, base, seed=seed).train_graphs:
        train.add(g=s)
    for mode in ("perturb", "interpolate", "path"):
        t0 = time.perf_counter()
        sampler = Sampler(vae, replace(base, batch=seeds), seed=seed)
        found = list(sampler.run(mode, 1))
        distinct = GraphSet()
        uniq = [s for s in found if distinct.add(s.decoded.graph)]
        novel = [s for s in uniq if s.decoded.graph not in train]
        out[mode] = {
            "decoded": sampler.decoded_points, "valid": sampler.valid_points,
            "validity": sampler.valid_points / max(1, sampler.decoded_points),
            "found": len(found), "distinct": len(uniq), "novel": len(novel),
            "yield": len(found) / max(1, sampler.decoded_points),
            "novel_yield": len(novel) / max(1, sampler.decoded_points),
            "seconds": round(time.perf_counter() - t0, 2),
        }
    return out


def table2(vae, *, size: int = 1000, k: int = 4, pairs: int = 200, seed: int = 0, decoding: str = "masked") -> dict:
    """The latent graph versus the naive string-similarity graph over `size` valid points:
    the training encodings first, then prior samples."""
    import torch  # noqa: F401 - the sampler needs it

    from .latent_graph import build_latent_graph, path_statistics
    from .sampling import Sampler, SamplingSettings

    sampler = Sampler(vae, SamplingSettings(decoding=decoding), seed=seed)
    mu = vae.train_mu.numpy()
    take = min(len(mu), size)
    zs: list[np.ndarray] = []
    graphs: list[TypedGraph] = []
    texts: list[str] = []
    from .decoding import decode_latents

    first = decode_latents(vae.model, torch.from_numpy(mu[:take].astype(np.float32)), vocab=vae.vocab,
                           rules=vae.rules, mode=decoding, seed=seed)
    for zrow, d in zip(mu[:take], first):
        if d.valid:
            zs.append(zrow)
            graphs.append(d.graph)
            texts.append(d.text)
    rounds = 0
    while len(graphs) < size and rounds < 50:
        rounds += 1
        for s in sampler.prior(min(256, 2 * (size - len(graphs)))):
            if s.valid and len(graphs) < size:
                zs.append(s.z)
                graphs.append(s.decoded.graph)
                texts.append(s.text)
    Z = np.array(zs)
    latent = path_statistics(build_latent_graph(Z, graphs, texts, k=k, kind="latent"), pairs=pairs, seed=seed)
    naive = path_statistics(build_latent_graph(Z, graphs, texts, k=k, kind="naive"), pairs=pairs, seed=seed)
    return {"size": len(graphs), "k": k, "latent": latent, "naive": naive}


def vae_metrics(vae, *, samples: int = 1000, seed: int = 0, modes: bool = True, graph_size: int = 1000,
                decodings: Sequence[str] = ("free", "masked"), mode_seeds: int = 128) -> dict:
    """Everything `grammarkit vae-metrics` prints."""
    from .sampling import Sampler, SamplingSettings

    train_graphs = Sampler(vae, SamplingSettings(), seed=seed).train_graphs
    train = GraphSet()
    for g in train_graphs:
        train.add(g)
    out: dict = {"model": str(vae.path) if vae.path else None, "grammar": vae.grammar_name,
                 "training_graphs": len(train_graphs),
                 "training_internal_diversity": internal_diversity(train_graphs, seed=seed)}
    for decoding in decodings:
        t0 = time.perf_counter()
        sampler = Sampler(vae, SamplingSettings(decoding=decoding), seed=seed)
        dec = [s.decoded for s in sampler.prior(samples)]
        m = generator_metrics(dec, train, train_graphs, k=min(1000, samples))
        m["seconds"] = round(time.perf_counter() - t0, 2)
        out[f"prior_{decoding}"] = m
        if modes:
            out[f"modes_{decoding}"] = mode_yields(vae, decoding=decoding, seeds=mode_seeds, seed=seed)
    if graph_size:
        out["table2"] = table2(vae, size=graph_size, seed=seed, decoding="masked" if "masked" in decodings else decodings[0])
    return out
