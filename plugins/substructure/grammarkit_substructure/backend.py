"""The `substructure` back end: new assemblies by replacing substructures (Liu et al. 2015).

Candidate j (a pure function of the run seed and j) starts from an example drawn by its own
random stream and applies up to max(--iterations, `operations`) operations in a row; every
shape along the chain is a result. Before every operation all
matching cuts are recomputed on the current shape (section 4.2): the copied piece comes from
one of the original examples (in-model and in-group synthesis, section 6), the hole is cut in
the current shape. Operations are drawn at random among all of them; those whose result graph equals the
current shape's or an example's are trivial (the paper drops them) and skipped before any
geometry; an operation whose embedding breaks the grammar (after the optional repair) is
replaced by another draw, up to `tries` embeddings per step. Candidates whose typed shape graph equals an example's or an earlier
result's are skipped (in candidate order), so the output depends only on (seed, index).

Candidates are computed through `request.executor` (a session holding the examples), in
fixed-size batches merged in candidate order.
"""
from __future__ import annotations

import time
import zlib
from collections import Counter
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from .operations import find_operations
from .shape import Shape, embed

BATCH = 16


@dataclass
class _State:
    examples: list[Shape]
    rules: Any
    options: Any
    seed: int
    steps: int
    max_parts: int
    cache: dict


def _init(examples, rules, options, seed, steps, max_parts) -> _State:  # noqa: ANN001
    return _State(examples, rules, options, seed, steps, max_parts, {})


def count_target(examples: list[Shape], mode: str) -> dict[str, tuple[int, int]] | None:
    """The part counts variants are kept in: each type's fewest..most over the examples
    (`counts="examples"`, two or more examples; a type no example has may not appear), or
    None (only the grammar's own count constraints, which the embedding check applies)."""
    from grammarkit.tiling import example_count_ranges

    if mode != "examples" or len(examples) < 2:
        return None
    return example_count_ranges([s.types for s in examples])


def _counts_fit(target: dict | None, shape: Shape) -> bool:
    """Are the shape's type counts within `target` (None: no target)?"""
    if target is None:
        return True
    have = shape.type_counts()
    return all(t in target for t in have) and all(lo <= have.get(t, 0) <= hi for t, (lo, hi) in target.items())


def _operations(state: _State, donor_i: int, host: Shape, host_key: Any) -> list:
    key = (donor_i, host_key)
    ops = state.cache.get(key) if host_key is not None else None
    if ops is None:
        donor = state.examples[donor_i]
        ops = find_operations(donor.graph, host.graph if donor is not host else None, q=state.options.q)
        if host_key is not None:
            state.cache[key] = ops
    return ops


def _typed_graph(types, edges):
    """(histogram, key): the sorted (type, count) pairs, and a Weisfeiler-Lehman key of the typed graph: colours start from the types and
    the degrees and are refined by the sorted colours of the neighbours until the colour classes
    stop splitting (at most one round per part); the key is the sorted colour multiset of
    every round. Refined to the end, not for a fixed number of rounds: a castle is a ring, and
    rings that differ only in where the gate sits look alike within four steps of every part
    (a fixed 4 rounds took most of them for duplicates). Hand-written instead of networkx's
    weisfeiler_lehman_graph_hash because it runs for every candidate operation and this one is
    about 20x faster (tuples of ints, no hashlib); int and tuple hashes do not depend on
    PYTHONHASHSEED, so workers agree."""
    names = sorted(set(types))
    code = {t: k for k, t in enumerate(names)}
    n = len(types)
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for u, v in edges:
        nbrs[u].append(v)
        nbrs[v].append(u)
    colour = [hash((code[t], len(nbrs[i]))) for i, t in enumerate(types)]
    # type names enter as CRC-32 ints: str hashes change with PYTHONHASHSEED between processes
    key = [tuple(zlib.crc32(t.encode("utf-8")) for t in names), tuple(sorted(colour))]
    classes = len(set(colour))
    for _ in range(n):
        get = colour.__getitem__  # the previous round's colours (map + sorted: no generator frames)
        colour = [hash((colour[i], tuple(sorted(map(get, nb))))) for i, nb in enumerate(nbrs)]
        key.append(tuple(sorted(colour)))
        now = len(set(colour))
        if now == classes:
            break  # stable: further rounds split nothing (same for every isomorphic graph)
        classes = now
    return _histogram(types), hash(tuple(key))


def _histogram(types) -> tuple:
    counts: dict[str, int] = {}
    for t in types:
        counts[t] = counts.get(t, 0) + 1
    return tuple(sorted(counts.items()))


def _trivial(donor: Shape, host: Shape, op, known: list) -> bool:
    """True when the operation's result graph equals the host's or an example's (the paper
    keeps only results with a topological change), by Weisfeiler-Lehman hash; graph only.
    A result whose type counts no known shape has is not trivial, without building it."""
    from grammarkit.tiling import replace_subgraph

    counts = dict(host.type_counts())
    for v in op.removed:
        counts[host.types[v]] -= 1
    for v in op.copied:
        counts[donor.types[v]] = counts.get(donor.types[v], 0) + 1
    hist = tuple(sorted((t, c) for t, c in counts.items() if c))
    same = [k for k in known if k[0] == hist]
    if not same:
        return False
    kept, edges = replace_subgraph(len(host), host.edges, op.removed, donor.edges, op.copied,
                                   [(b, w) for _, w, b, _ in op.pairs])
    types = [host.types[v] for v in kept] + [donor.types[v] for v in op.copied]
    # a cheap invariant first: the typed degree multiset (most non-trivial results differ in
    # it, and the Weisfeiler-Lehman refinement below is the dearer step)
    degrees = _typed_degrees(types, edges)
    same = [k for k in same if k[2] == degrees]
    if not same:
        return False
    h = _typed_graph(types, edges)[1]
    return any(h == k[1] for k in same)


def _typed_degrees(types, edges) -> tuple:  # noqa: ANN001
    """The sorted (type, degree) pairs of a typed graph: an isomorphism invariant."""
    deg = [0] * len(types)
    for u, v in edges:
        deg[u] += 1
        deg[v] += 1
    return tuple(sorted(zip(types, deg)))


def _known(types, edges) -> tuple:  # noqa: ANN001
    """(histogram, WL key, typed degrees) of a shape the trivial test compares against."""
    hist, key = _typed_graph(types, edges)
    return hist, key, _typed_degrees(types, edges)


# Shapes kept by the memo before it starts afresh (a bound on memory: a castle shape with its
# meshes is a few hundred kB; forgetting changes no result, only what is computed again).
MEMO_SHAPES = 2000


def _memo(state: _State) -> dict:
    """The run's memo of evaluations on shapes named by their path (start example, then the
    (donor, operation) indices applied): operations, trivial verdicts, known keys and
    embeddings. Every entry is a pure function of its path, so the memo changes what is
    computed, never a result, and workers with different memos give the same output."""
    memo = state.cache.get("memo")
    if memo is None or state.cache.get("memo_shapes", 0) > MEMO_SHAPES:
        memo = state.cache["memo"] = {}
        state.cache["memo_shapes"] = 0
        # the path-keyed operation lists and verdicts live in state.cache beside the examples'
        for k in [k for k in state.cache if isinstance(k, tuple) and _is_path_key(k)]:
            del state.cache[k]
    return memo


def _is_path_key(key: tuple) -> bool:
    """A cache key of a shape reached by operations: (donor, path) or ("trivial", path) with a
    path longer than an example's ("example", i)."""
    inner = key[1] if len(key) == 2 else None
    return isinstance(inner, tuple) and len(inner) == 3


def _remember(state: _State, table: dict, key: tuple, out: Any) -> None:
    table[key] = out
    if out.shape is not None:
        state.cache["memo_shapes"] = state.cache.get("memo_shapes", 0) + 1


def _host_known(memo: dict | None, path: Any, host: Shape) -> tuple:
    """`_known` of a shape reached by operations (kept per path with the memo)."""
    if memo is None:
        return _known(host.types, host.edges)
    table = memo.setdefault("known", {})
    if path not in table:
        table[path] = _known(host.types, host.edges)
    return table[path]


def _step_options(state: _State, host: Shape, host_key: Any, key: Any, rng: Any) -> tuple[list, list]:
    """Every (donor index, operation index, operation) on the current shape, and the order
    they are tried in. Local edits first: an operation whose pieces are "the rest of the
    shape" (stored as complements) mostly swaps one whole example for another, a trivial
    result; those are drawn only after every local one (random order within each group)."""
    options = []
    for d in range(len(state.examples)):
        donor = state.examples[d]
        same = host_key == ("example", d)
        ops = _operations(state, d, donor if same else host, ("example", d) if same else key)
        options.extend((d, j, op) for j, op in enumerate(ops))
    if not options:
        return options, []
    local = [k for k, (_, _, op) in enumerate(options)
             if not op.copied_side.complement and not op.removed_side.complement]
    far = [k for k, (_, _, op) in enumerate(options)
           if op.copied_side.complement or op.removed_side.complement]
    order = [local[i] for i in rng.permutation(len(local))] + [far[i] for i in rng.permutation(len(far))]
    return options, order


def candidate(state: _State, index: int) -> dict:
    """Candidate `index`: a chain of up to `steps` operations from an example (each shape
    along the chain is a result); a pure function of (seed, index)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(state.seed) & 0xFFFFFFFF, int(index)]))
    opt = state.options
    if "known" not in state.cache:
        state.cache["known"] = [_known(e.types, e.edges) for e in state.examples]
    examples_known = state.cache["known"]
    if "target" not in state.cache:
        state.cache["target"] = count_target(state.examples, getattr(opt, "counts", "grammar"))
    target = state.cache["target"]
    start = int(rng.integers(len(state.examples)))
    host, host_key = state.examples[start], ("example", start)
    # `path`: the start example and the (donor, operation) indices applied so far; the shape
    # it names is a pure function of it, so with `memo` every evaluation on it is kept
    path: Any = host_key
    memo = _memo(state) if getattr(opt, "memo", False) else None
    history: list = []
    shapes: list = []
    tried = outside = 0
    for _ in range(state.steps):
        key = host_key if memo is None else path
        options, order = _step_options(state, host, host_key, key, rng)
        if not options:
            break
        known = examples_known + ([_host_known(memo, path, host)] if host_key is None else [])
        embedded = 0
        done = False
        # an example host's verdicts are the same in every candidate (its known shapes are the
        # examples): kept per (donor, example, operation); with the memo, per path
        verdicts = state.cache.setdefault(("trivial", key), {}) if key is not None else {}
        embedded_memo = memo.setdefault(("embed", path), {}) if memo is not None else None
        for k in order:
            if embedded >= opt.tries:
                break
            d, j, op = options[k]
            donor = state.examples[d]
            trivial = verdicts.get((d, j))
            if trivial is None:
                trivial = verdicts[(d, j)] = _trivial(donor, host, op, known)
            if trivial:
                continue
            embedded += 1
            tried += 1
            out = embedded_memo.get((d, j)) if embedded_memo is not None else None
            if out is None:
                out = embed(donor, host, op, state.rules, embedding=opt.embedding, repair=opt.repair,
                            orientation_degrees=opt.orientation_degrees, max_parts=state.max_parts,
                            origin_at=opt.frame_origin,
                            cache=state.cache.setdefault("geometry", {}) if opt.reuse_geometry else None)
                if embedded_memo is not None:
                    _remember(state, embedded_memo, (d, j), out)
            if out.shape is None:
                continue
            history.append({"donor": donor.name, "operation": op.to_json(host.ids, donor.ids),
                            "repaired": out.repaired})
            host, host_key, path = out.shape, None, (path, d, j)
            # a shape outside the examples' counts is a step on the way, not a result: the
            # next operation may bring it back (a gate moved is a wall turned gate, then a
            # gate turned wall)
            if _counts_fit(target, host):
                shapes.append((host, list(history)))
            else:
                outside += 1
            done = True
            break
        if not done:
            break
    return {"index": index, "shapes": shapes, "start": state.examples[start].name, "tried": tried,
            "outside_counts": outside}


class _Deduper:
    """Typed shape graphs already seen, by Weisfeiler-Lehman hash. (VF2 on rings of identical
    parts backtracks for minutes; WL can only merge non-isomorphic graphs, never tell two
    isomorphic ones apart, so a duplicate is never written, at worst a rare new shape skipped.)"""

    def __init__(self, mode: str):
        self.mode = mode
        self.seen: set = set()

    def add(self, shape: Shape) -> bool:
        if self.mode == "none":
            return True
        h = _typed_graph(shape.types, shape.edges)[1]
        if h in self.seen:
            return False
        self.seen.add(h)
        return True


def load_examples(grammar, tolerance: float | None) -> tuple[list, list[Shape], float]:
    """The grammar's example assemblies, as Shapes at one contact tolerance (the smallest
    example's default unless given)."""
    from grammarkit.errors import GrammarError
    from grammarkit.tiling import default_tolerance, load_examples as loader

    assemblies = list(loader(grammar))
    if not assemblies:
        raise GrammarError(f"grammar {grammar.name!r} has no examples: the substructure search "
                           "edits example assemblies (add `example NAME = assembly(\"file.glb\")`)",
                           getattr(grammar, "span", None))
    tol = tolerance if tolerance is not None else min(float(default_tolerance(a)) for a in assemblies)
    shapes = []
    for n, a in enumerate(assemblies):
        a.name = a.name or f"example{n}"
        shapes.append(Shape.from_assembly(a, tol))
    return assemblies, shapes, tol


def _shortfall(made: int, asked: int, stopped: str, stats: dict, opt, target: dict | None) -> str:  # noqa: ANN001
    """Why a run made fewer variants than asked: the rule that stopped it and where the
    candidates' shapes went (rejected embeddings, outside the examples' counts, repeats,
    dropped by the final check), with the option that would change it."""
    # the time case names no cause of its own: the run layer, which owns the budget, puts
    # "the time limit (S s) was reached; " before this account (summary["stopped_by"] == "time")
    why = {"patience": f"the last {opt.patience} candidates gave nothing new after ",
           "candidates": f"max_candidates ({opt.max_candidates}) reached after "}.get(stopped, "")
    repeats = stats["valid"] - stats["new"] - stats.get("dropped_by_final_check", 0)
    parts = [f"{why}{stats['candidates']} candidates",
             f"{stats['embeddings_tried']} embeddings tried, {stats['valid'] + stats['outside_counts']} "
             "valid for the grammar",
             f"{stats['valid']} within the examples' counts" if target else f"{stats['valid']} kept",
             f"{repeats} of them repeat an example or an earlier result"]
    if stats.get("dropped_by_final_check"):
        parts.append(f"{stats['dropped_by_final_check']} dropped by the final check")
    text = ", ".join(parts)
    if stats["outside_counts"] and target:
        seen = ", ".join(f"{t} {lo}..{hi}" for t, (lo, hi) in sorted(target.items()))
        text += (f"; {stats['outside_counts']} valid shapes had part counts outside the examples' ({seen}) "
                 "and were not written (--option counts=grammar writes every shape the grammar accepts)")
    rejected = stats["embeddings_tried"] - stats["valid"] - stats["outside_counts"]
    if rejected > 0:
        text += f"; {rejected} embeddings broke the grammar (placements, support, holes)"
    hint = ("longer chains (--option operations=8), " if opt.operations < 8 else "") + "--option q=1 or more examples may find more"
    return f"{text}; {hint}" if stopped != "time" else f"{text}; a longer --time-limit may find more"


# long: the run loop (batches, dedupe, final check, results) and its summary share the
# counters; the candidate work and the shortfall text are in their own functions
def run(request) -> Iterator:  # noqa: ANN001
    """Yield up to `request.n` new valid assemblies; return the run's statistics."""
    from grammarkit.errors import DerivationError
    from grammarkit.run import Result
    from grammarkit.tiling import rules_from_grammar, validate

    t0 = time.perf_counter()
    opt = request.options
    rules = rules_from_grammar(request.grammar)
    assemblies, examples, tol = load_examples(request.grammar, opt.contact_tolerance)
    for a, s in zip(assemblies, examples):
        report = validate(rules, a, tolerance=tol, max_violations=3)
        if not report.ok:
            raise DerivationError(f"example {a.name!r} violates the grammar, so it cannot seed the "
                                  "substructure search: " + "; ".join(v.format() for v in report.violations),
                                  getattr(request.grammar, "span", None))
    n_ops = sum(len(find_operations(d.graph, h.graph if d is not h else None, q=opt.q))
                for d in examples for h in examples)
    if n_ops == 0:
        raise DerivationError(
            f"grammar {request.grammar.name!r}: its examples have no replaceable substructure (no "
            "two pieces whose boundaries reconnect in observed ways), so the substructure back end "
            "can make nothing new; try --option q=1 or 2 to tolerate ordering defects, or more examples",
            getattr(request.grammar, "span", None))
    max_parts = opt.max_parts or 4 * max(len(s) for s in examples)
    steps = max(int(request.iterations), opt.operations)
    dedupe = _Deduper(opt.dedupe)
    for s in examples:
        dedupe.add(s)
    stats = {"candidates": 0, "valid": 0, "new": 0, "embeddings_tried": 0, "repaired": 0,
             "outside_counts": 0}
    made = 0
    session = request.executor.session(_init, examples, rules, opt, request.seed, steps, max_parts) \
        if request.executor is not None else None
    state = None if session is not None else _init(examples, rules, opt, request.seed, steps, max_parts)
    advance = request.progress("substructure candidates", request.n)
    try:
        next_index = 0
        last_new = 0  # candidate count when the last new variant came
        stopped = "n"
        while made < request.n and next_index < opt.max_candidates \
                and stats["candidates"] - last_new < opt.patience:
            request.check_deadline()
            if request.time_is_up():
                stopped = "time"
                break
            items = list(range(next_index, min(opt.max_candidates, next_index + BATCH)))
            next_index = items[-1] + 1
            outs = session.map(candidate, items) if session is not None else (candidate(state, i) for i in items)
            for out in outs:
                stats["candidates"] += 1
                stats["embeddings_tried"] += out["tried"]
                stats["outside_counts"] += out["outside_counts"]
                for shape, history in out["shapes"]:
                    if made >= request.n:
                        break
                    stats["valid"] += 1
                    if not dedupe.add(shape):
                        continue
                    key = f"variant_{made + 1:05d}"
                    assembly = shape.to_assembly(key, {"substructure": {"start": out["start"],
                                                                        "operations": history}})
                    if opt.final_check and not validate(request.grammar, assembly, max_violations=1).ok:
                        stats["dropped_by_final_check"] = stats.get("dropped_by_final_check", 0) + 1
                        continue  # never written: `grammarkit validate` would reject the file
                    index = made
                    made += 1
                    last_new = stats["candidates"]
                    stats["new"] += 1
                    repaired = any(h["repaired"] for h in history)
                    stats["repaired"] += int(repaired)
                    advance(1, candidates=stats["candidates"], new=made)
                    if index < request.start:
                        continue
                    yield Result(id=key, index=index, seed=request.seed, model=assembly,
                                 parents=(f"example:{out['start']}",) + tuple(
                                     f"example:{h['donor']}" for h in history),
                                 metrics={"parts": len(shape), "operations": len(history),
                                          "candidate": out["index"], "repaired": repaired},
                                 extra={"operation": history[-1]["operation"], "operations": history,
                                        "histogram": dict(sorted(Counter(shape.types).items()))})
    finally:
        if session is not None:
            session.close()
    elapsed = time.perf_counter() - t0
    summary = {"examples": len(examples), "operations_in_examples": n_ops, **stats,
               "seconds": round(elapsed, 3),
               "variants_per_minute": round(60.0 * made / elapsed, 1) if elapsed > 0 else None}
    if made < request.n and stopped != "time":
        stopped = "patience" if stats["candidates"] - last_new >= opt.patience else "candidates"
    summary["stopped_by"] = stopped  # machine-readable: "n", "time", "patience", "candidates"
    summary["stopped"] = {"n": f"made the {request.n} asked for", "time": "the time limit was reached",
                          "patience": f"{opt.patience} candidates in a row gave nothing new",
                          "candidates": f"the candidate cap ({opt.max_candidates}) was reached"}[stopped]
    if made < request.n:
        summary["shortfall"] = _shortfall(made, request.n, stopped, stats, opt, count_target(examples, opt.counts))
    return summary
