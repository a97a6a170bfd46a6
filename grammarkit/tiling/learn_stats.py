"""The global statistics `learn` takes from its examples: part counts as ranges and support
(strict, or sideways with the longest sideways run), each written as a `constraint`.

- `count(T, lo, hi)`: lo and hi are the fewest and the most T parts one example has (two or
  more examples; one example gives no range), widened by `slack` parts on each side only when
  asked: a castle learned from examples with 1 and 2 gates must have a gate. By default
  (`counts="few"`) only for types no example has more than FEW of: the number of grass tiles
  of a tiling or of walls of a castle follows the shape's size, and a range of it would reject
  every valid tiling larger or smaller than the examples; `counts="all"` bounds every type
  (the examples' sizes: what the shipped example grammars use);
- `grounded(ground=G)` when every example part is carried from below, else
  `grounded(ground=G, sideways=true, max_span=K)`, K being the longest sideways run any
  example has (support.sideways_runs): a ball track whose examples hang at most 3 pieces in a
  row between pillars may not hang 7.
"""
from __future__ import annotations

from typing import Sequence

import networkx as nx

from ..ir.expr import Bool, Num, Ref
from ..ir.split import Arg
from ..ir.tiling import ConstraintDef

__all__ = ["COUNT_MODES", "FEW", "count_statements", "example_count_ranges", "SupportStats", "support_stats"]


# a type no example has more than this many of is a *designed* count (gates, entries, exits, a
# door); more numerous types grow with the shape (tiles of a tiling, walls of a castle, the ledges
# of a facade: one per floor)
FEW = 2
COUNT_MODES = ("few", "all", "none")


def count_statements(types: Sequence[str], type_counts: list[dict[str, int]], slack: int,
                     notes: list[str], mode: str = "few") -> list[ConstraintDef]:
    """`constraint count(T, lo, hi)` from the per-example counts (two or more examples): for
    every type with `mode="all"`, for the types every example has 1..FEW of with "few"
    (the default: a tiling's tile counts follow its size, and ranges of them would reject
    every larger or smaller valid tiling)."""
    if len(type_counts) < 2 or mode == "none":
        return []
    out = []
    seen_range = example_count_ranges(type_counts, types)
    for t in sorted(types):
        ns = [h.get(t, 0) for h in type_counts]
        if mode == "few" and (max(ns) > FEW or min(ns) == 0):
            continue  # many (grows with the shape), or absent from some example (a rare tile)
        lo, hi = max(0, seen_range[t][0] - slack), seen_range[t][1] + slack
        seen = f"{min(ns)}..{max(ns)}" if min(ns) != max(ns) else f"{min(ns)}"
        widened = f", widened by {slack}" if slack else ""
        notes.append(f"count({t}, {lo}, {hi}): the {len(ns)} examples have {seen} {t} part(s){widened}")
        out.append(ConstraintDef(name="count", args=(Arg(value=Ref(name=t)), Arg(name="lo", value=Num(value=float(lo))),
                                                    Arg(name="hi", value=Num(value=float(hi))))))
    return out


def example_count_ranges(examples: Sequence, types: Sequence[str] | None = None) -> dict[str, tuple[int, int]]:
    """{type: (fewest, most)} parts of each type one example has: `examples` are assemblies,
    sequences of part types, or {type: count} dicts; `types` adds types (count 0 where absent).

    The range a person expects a variant's counts in (docs/tiling.md, *Counts*): the
    substructure back end keeps its variants in it (`counts="examples"`), and
    benchmarks/bench_tiling_quality.py measures every back end against it."""
    hists: list[dict[str, int]] = []
    for e in examples:
        if isinstance(e, dict):
            hists.append(dict(e))
            continue
        seq = [p.type for p in e.parts] if hasattr(e, "parts") else list(e)
        h: dict[str, int] = {}
        for t in seq:
            h[t] = h.get(t, 0) + 1
        hists.append(h)
    names = sorted(set(types or ()) | {t for h in hists for t in h})
    return {t: (min(h.get(t, 0) for h in hists), max(h.get(t, 0) for h in hists)) for t in names} if hists else {}


class SupportStats:
    """What the examples say about support: `strict` (every part carried from below),
    `sideways` (carried when side contacts count), `max_span` (their longest sideways run)."""

    def __init__(self, strict: bool, sideways: bool, max_span: int | None):
        self.strict, self.sideways, self.max_span = strict, sideways, max_span

    def statement(self, ground: Num) -> ConstraintDef | None:
        if not self.sideways:
            return None
        args = [Arg(name="ground", value=ground)]
        if not self.strict:
            args.append(Arg(name="sideways", value=Bool(value=True)))
            if self.max_span is not None:
                args.append(Arg(name="max_span", value=Num(value=float(self.max_span))))
        return ConstraintDef(name="grounded", args=tuple(args))


def support_stats(graphs: Sequence[nx.Graph], contexts: Sequence[dict], ground: float,
                  notes: list[str]) -> SupportStats:
    from .constraints import check_grounded, sideways_span

    strict = all(not check_grounded(g, {"ground": ground}, c) for g, c in zip(graphs, contexts))
    if strict:
        return SupportStats(True, True, None)
    spans = [sideways_span(g, {"ground": ground}, c) for g, c in zip(graphs, contexts)]
    if any(s is None for s in spans):
        notes.append("no grounded constraint: some example part is not carried down to the ground")
        return SupportStats(False, False, None)
    span = max(spans)
    notes.append(f"grounded(sideways=true, max_span={span}): not every part of the examples rests on parts "
                 f"below it; some are held by side contacts only, at most {span} in a row")
    return SupportStats(False, True, span)
