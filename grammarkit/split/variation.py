"""Variations of a split grammar (Nishida 2016, "variation"): resample, re-roll, swap.

Each variation
1. swaps snippets: for every `variants T { s1: p1 | s2: p2 ... }` table, every anchor bound to a
   snippet of object type T gets a snippet drawn with those probabilities;
2. resamples attrs: every ranged attr uniformly in its range (integers stay integers when the
   default and both bounds are integers), every enum attr uniformly among its values; attrs
   fixed by the caller are kept;
3. re-rolls stochastic choices: a fresh run seed.
All draws come from one generator seeded with `seed`, so `variations(g, n, seed=s)` is
reproducible, and variation i does not depend on how many variations are requested.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any, Mapping

from ..errors import GrammarError
from ..expr_eval import fold_constant
from .compile import CompiledGrammar, ValueEnv


@dataclass(frozen=True)
class Variation:
    index: int
    seed: int  # the run seed of this variation
    attrs: dict[str, Any]  # the sampled attr values (including fixed ones)
    bindings: dict[str, str]  # anchor -> snippet

    def to_dict(self) -> dict:
        return {"index": self.index, "seed": self.seed, "attrs": self.attrs, "bindings": self.bindings}


def snippet_weights(grammar: Any, functions: Any, values: Mapping[str, Any]) -> dict[str, list[tuple[str, float]]]:
    from ..expr_eval import NOT_CONSTANT

    tables: dict[str, list[tuple[str, float]]] = {}
    for v in grammar.variants:
        opts = []
        for opt in v.options:
            w = fold_constant(opt.weight, lambda name: values.get(name, NOT_CONSTANT), functions)
            if isinstance(w, bool) or not isinstance(w, (int, float)) or w < 0:
                shown = "an expression of the derivation" if w is NOT_CONSTANT else repr(w)
                raise GrammarError(f"variant weight must be a constant number >= 0, got {shown}", opt.span,
                                   code="bad-percent")
            opts.append((opt.snippet, float(w)))
        if sum(w for _, w in opts) <= 0:
            raise GrammarError(f"variants {v.object_type}: the weights add up to 0", v.span)
        tables[v.object_type] = opts
    return tables


def sample_attrs(compiled: CompiledGrammar, rng: random.Random, fixed: Mapping[str, Any]) -> dict[str, Any]:
    """Attrs drawn in their ranges and enums (bounds that use other values see the defaults)."""
    env = ValueEnv(0, dict(compiled.default_values()))
    fixed_keys = set()
    for name in fixed:
        fixed_keys.update(compiled.resolve_attr_keys(name))
    out: dict[str, Any] = dict(fixed)
    for key, info in compiled.attrs.items():
        if key in fixed_keys:
            continue
        if info.lo is not None and info.hi is not None:
            lo, hi = info.lo(env), info.hi(env)
            default = info.default(env)
            if all(isinstance(v, int) and not isinstance(v, bool) for v in (lo, hi, default)):
                out[key] = rng.randint(lo, hi)
            else:
                out[key] = lo + (hi - lo) * rng.random()
        elif info.choices is not None:
            out[key] = rng.choice([c(env) for c in info.choices])
    return out
