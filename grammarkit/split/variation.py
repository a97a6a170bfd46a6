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
from typing import Any, Iterator, Mapping

from ..errors import DerivationError, GrammarError
from ..expr_eval import fold_constant
from .compile import CompiledGrammar, ValueEnv
from .engine import Limits


@dataclass(frozen=True)
class Variation:
    index: int
    seed: int  # the run seed of this variation
    attrs: dict[str, Any]  # the sampled attr values (including fixed ones)
    bindings: dict[str, str]  # anchor -> snippet

    def to_dict(self) -> dict:
        return {"index": self.index, "seed": self.seed, "attrs": self.attrs, "bindings": self.bindings}


def _weights(grammar: Any, functions: Any, values: Mapping[str, Any]) -> dict[str, list[tuple[str, float]]]:
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


def variations(grammar: Any, n: int, *, seed: int = 0, attrs: Mapping[str, Any] | None = None,
               limits: Limits | None = None, start: int = 0, registries: Any
               ) -> Iterator[tuple[Variation, Any]]:
    """Yield `n` (Variation, Model) pairs: variations start, start+1, ... (each depends only on
    `seed` and its index, so workers can derive disjoint index ranges)."""
    from . import as_mapping, derive, load_grammar
    from . import compile as compile_split

    for what, v, lo in (("n", n, 0), ("start", start, 0), ("seed", seed, None)):
        if isinstance(v, bool) or not isinstance(v, int) or (lo is not None and v < lo):
            raise DerivationError(f"variations(): {what}= must be an integer"
                                  + (f" >= {lo}" if lo is not None else "") + f", got {v!r}",
                                  None, code="bad-argument")
    g = load_grammar(grammar, registries)
    base = compile_split(g, registries=registries)
    tables = _weights(g, registries.functions, base.default_values())
    snippets = {s.name: s for s in g.snippets}
    fixed = as_mapping(attrs, "attrs")
    for i in range(start, start + n):
        rng = random.Random(hash((seed, i)) & ((1 << 64) - 1))
        choices: dict[str, str] = {}
        for anchor, snip in sorted(base.bindings.items()):
            otype = snippets[snip].object_type if snip in snippets else None
            table = tables.get(otype or "")
            if table:
                names = [s for s, _ in table]
                choices[anchor] = rng.choices(names, weights=[w for _, w in table])[0]
        compiled = compile_split(g, choices or None, registries=registries)
        sampled = sample_attrs(compiled, rng, fixed)
        run_seed = rng.getrandbits(32)
        model = derive(g, seed=run_seed, attrs=sampled, limits=limits, choices=choices or None,
                       registries=registries)
        yield Variation(i, run_seed, model.attrs, dict(compiled.bindings)), model
