"""Graph-based shape sampling (Kalojanov et al. 2019, section 4) over tiling-grammar examples.

One *attempt* (a pure function of the pool of shapes and its own seed):
  1. pick a donor and a recipient shape (one of them new in the previous iteration; they may
     be the same shape);
  2. sample a random connected subgraph of the donor by randomised BFS (size drawn from
     [min_subgraph, 3/4 of the donor's parts], as the authors' code sweeps);
  3. split it into layers (`grammarkit.tiling.cut_layers`): the inserted piece and the boundary nodes;
  4. find nodes of the recipient matching the boundary nodes by type and by all pairwise
     centroid distances within `tolerance` x part size; first match wins;
  5. docking transform: least-squares rigid alignment (Kabsch) of the donor's boundary
     centroids onto the matched ones; reject if any boundary centroid stays further than
     `dock_tolerance` x the boundary's bounding-box diagonal;
  6. replace: keep the recipient's parts reachable from the matched outer layer without
     crossing the matched inner layer, add the donor's piece moved by the docking transform;
  7. recompute the shape graph from the geometry (incrementally: only pairs involving the
     inserted parts; the kept parts have not moved) and check the grammar's rules.
Valid variants whose node-type histogram (or, optionally, typed graph up to isomorphism) is
new are kept, in attempt order, and become the new shapes of the next iteration.

Determinism: attempt `i` of iteration `k` draws from SeedSequence([seed, k, i]); attempts run
in fixed-size batches against the state at the start of the batch and are merged in attempt
order, so the output does not depend on the number of worker processes.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from . import geometry
from .dedupe import Deduper, Orientations, geometric_key, source_geometry
from .options import SamplerOptions
from grammarkit.tiling import (
    adjacency_from_edges, cut_layers, distance_matrix, histogram_key, induced_edges, kept_region,
    match_boundary, random_connected_subgraph,
)

OUTCOMES = ("no-cut", "no-match", "too-large", "counts", "known", "docking", "invalid", "final-check", "valid")


@dataclass
class Proto:
    """A source part of an example; every part of every shape is a proto moved rigidly."""

    type: str
    mesh: Any  # trimesh.Trimesh in its example's world frame
    transform: np.ndarray  # the source Part.transform (provenance)
    source: str  # "example/part-id"
    center: np.ndarray  # area-weighted surface centroid of `mesh` (moves rigidly; as shape_graph)
    size: float  # a third of the bounding-box diagonal (the authors' part size)
    geo: int = -1  # geometry class (dedupe.source_geometry): equal ids, congruent meshes
    pose: np.ndarray | None = None  # places the class's mesh frame in the world (None: identity)


@dataclass
class Shape:
    """A member of the pool: an example or a kept variant (parts as proto + rigid transform)."""

    key: str
    protos: tuple[int, ...]
    transforms: np.ndarray  # (n, 4, 4): applied to the proto's mesh
    edges: tuple[tuple[int, int], ...]  # i < j, sorted
    iteration: int = 0
    parents: tuple[str, ...] = ()
    operation: dict = field(default_factory=dict)
    ids: tuple[str, ...] = ()  # part ids (examples: as read; variants: `Type.k` in node order)
    geo: bytes | None = None  # dedupe.geometric_key (set by the attempt that made it, or prepare)
    # derived (filled by `prepare`)
    types: tuple[str, ...] = ()
    centroids: np.ndarray | None = None
    sizes: np.ndarray | None = None
    adj: list | None = None
    dist: np.ndarray | None = None
    by_type: dict | None = None
    poses: np.ndarray | None = None  # (n, 4, 4) world poses of the parts' geometry classes
    geo_ids: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.protos)

    def prepare(self, protos: Sequence[Proto], orient: Orientations | None = None) -> "Shape":
        """Fill the derived arrays; with `orient` (dedupe.Orientations) also the geometric key,
        when not known yet."""
        self.types = tuple(protos[p].type for p in self.protos)
        if not self.ids:
            counts: dict[str, int] = {}
            ids = []
            for t in self.types:
                ids.append(f"{t}.{counts.get(t, 0)}")
                counts[t] = counts.get(t, 0) + 1
            self.ids = tuple(ids)
        centers = np.array([protos[p].center for p in self.protos], dtype=float)
        rot, trans = self.transforms[:, :3, :3], self.transforms[:, :3, 3]
        self.centroids = np.einsum("nij,nj->ni", rot, centers) + trans
        self.sizes = np.array([protos[p].size for p in self.protos], dtype=float)
        self.adj = adjacency_from_edges(len(self.protos), self.edges)
        self.dist = distance_matrix(self.centroids)
        by_type: dict[str, list[int]] = {}
        for i, t in enumerate(self.types):
            by_type.setdefault(t, []).append(i)
        self.by_type = {t: np.array(v, dtype=np.int64) for t, v in by_type.items()}
        self.geo_ids = np.array([protos[p].geo for p in self.protos], dtype=np.int64)
        self.poses = np.einsum("nij,njk->nik", self.transforms,
                               np.array([protos[p].pose if protos[p].pose is not None else np.eye(4)
                                         for p in self.protos]).reshape(-1, 4, 4))
        if self.geo is None and orient is not None:
            self.geo = geometric_key(self.geo_ids, self.poses, orient.quantum, orient)
        return self

    def histogram(self) -> dict[str, int]:
        return dict(histogram_key(self.types))


@dataclass
class AttemptResult:
    iteration: int
    index: int
    outcome: str
    shape: Shape | None = None
    detail: str = ""


@dataclass
class _Context:
    """Everything an attempt reads; shipped to worker processes once per iteration."""

    protos: list[Proto]
    pool: list[Shape]
    fresh: list[int]  # pool indices of the shapes new in the previous iteration
    options: SamplerOptions
    seed: int
    rules: Any
    contact_tolerance: float
    max_parts: int
    count_range: dict | None = None  # {type: (lo, hi)} a variant's counts must lie in (None: any)
    mesh_cache: dict = field(default_factory=dict)
    bounds_cache: dict = field(default_factory=dict)
    part_cache: geometry.PartCache = field(default_factory=geometry.PartCache)

    geo_vertices: list = field(default_factory=list)  # per geometry class (dedupe.source_geometry)

    @property
    def quantum(self) -> float:
        return self.contact_tolerance / 10.0

    @property
    def orient(self) -> Orientations:
        if "_orient" not in self.__dict__:
            self.__dict__["_orient"] = Orientations(self.geo_vertices, self.quantum)
        return self.__dict__["_orient"]

    def bounds(self, shape_index: int) -> tuple[np.ndarray, np.ndarray]:
        b = self.bounds_cache.get(shape_index)
        if b is None:
            shape = self.pool[shape_index]
            b = geometry.bounds_of([self.world_mesh(shape_index, i) for i in range(len(shape))])
            self.bounds_cache[shape_index] = b
        return b

    def world_mesh(self, shape_index: int, node: int):
        key = (shape_index, node)
        mesh = self.mesh_cache.get(key)
        if mesh is None:
            shape = self.pool[shape_index]
            mesh = geometry.moved_mesh(self.protos[shape.protos[node]].mesh, shape.transforms[node])
            self.mesh_cache[key] = mesh
        return mesh


def rejection_reason(detail: str) -> str:
    """The rule named in a problem text ("part 3 (Wall): [orientation] ..." -> "orientation");
    "pair" for a forbidden contact found while the graph is updated."""
    start = detail.find("[")
    end = detail.find("]", start + 1)
    if start >= 0 and end > start:
        return detail[start + 1:end]
    return "pair" if "no dock" in detail else "other"


def kept_lost_neighbour(recip: Shape, kept: Sequence[int]) -> list[int]:
    """New indices (positions in `kept`) of the kept parts that had a neighbour the edit removed."""
    where = np.full(len(recip), -1, dtype=np.int64)
    where[np.asarray(kept, dtype=np.int64)] = np.arange(len(kept))
    if not recip.edges:
        return []
    E = np.asarray(recip.edges, dtype=np.int64)
    a, b = where[E[:, 0]], where[E[:, 1]]
    return sorted(set(a[(a >= 0) & (b < 0)].tolist()) | set(b[(b >= 0) & (a < 0)].tolist()))


def count_outside(count_range: dict | None, histogram: tuple) -> str:
    """The first type whose count (`histogram`: sorted (type, count) pairs) lies outside
    `count_range` ({type: (lo, hi)}, None: no bound), as "Gate: 0 not in 1..2"; "" if none."""
    if count_range is None:
        return ""
    have = dict(histogram)
    for t, (lo, hi) in count_range.items():
        if not lo <= have.get(t, 0) <= hi:
            return f"{t}: {have.get(t, 0)} not in {lo}..{hi}"
    for t in have:
        if t not in count_range:
            return f"{t}: no example has one"
    return ""


def attempt_seed(seed: int, iteration: int, index: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFF, iteration, index]))


# the paper's attempt as one sequence of steps (pick, BFS, cut, match, dock, replace, check),
# each an early exit with its outcome; the steps read one another's locals
# long: the paper's attempt, one step after another
def run_attempt(ctx: _Context, iteration: int, index: int, known: frozenset) -> AttemptResult:
    """One subgraph replacement attempt (see the module docstring)."""
    opt = ctx.options
    rng = attempt_seed(ctx.seed, iteration, index)
    pool = ctx.pool
    a = ctx.fresh[int(rng.integers(len(ctx.fresh)))]
    b = int(rng.integers(len(pool)))
    donor_i, recip_i = (a, b) if rng.random() < 0.5 else (b, a)
    donor, recip = pool[donor_i], pool[recip_i]

    hi = max(opt.min_subgraph, int(opt.max_subgraph_fraction * len(donor)))
    size = int(rng.integers(opt.min_subgraph, hi + 1))
    nodes = random_connected_subgraph(donor.adj, size, rng, keep_prob=opt.keep_prob)
    cut = cut_layers(donor.adj, nodes)
    if not cut.interior or not cut.outer or len(cut.boundary) < 3:
        return AttemptResult(iteration, index, "no-cut")

    match = match_boundary(donor.types, donor.dist, cut.boundary, recip.by_type, recip.dist,
                           recip.sizes, opt.tolerance, rng, max_steps=opt.max_match_steps)
    if match is None:
        return AttemptResult(iteration, index, "no-match")
    inner2, outer2 = match[:len(cut.inner)], match[len(cut.inner):]
    kept = kept_region(recip.adj, outer2, inner2)
    inserted = list(cut.inserted)
    n_new = len(kept) + len(inserted)
    if n_new > ctx.max_parts:
        return AttemptResult(iteration, index, "too-large", detail=f"{n_new} parts")
    types = [recip.types[i] for i in kept] + [donor.types[i] for i in inserted]
    hkey = histogram_key(types)
    outside = count_outside(ctx.count_range, hkey)
    if outside:
        # option counts="examples": a castle without a gate is not kept (issue 28), so it is
        # dropped before any geometry
        return AttemptResult(iteration, index, "counts", detail=outside)
    if opt.dedupe == "histogram" and hkey in known:
        # Cheap early exit before any geometry: the merge would drop it anyway.
        return AttemptResult(iteration, index, "known")

    src = donor.centroids[list(cut.boundary)]
    dst = recip.centroids[match]
    docked = geometry.dock(src, dst)
    if docked is None:
        return AttemptResult(iteration, index, "docking", detail="boundary centroids are collinear")
    matrix, residual = docked
    moved = src @ matrix[:3, :3].T + matrix[:3, 3]
    worst = float(np.max(np.linalg.norm(moved - dst, axis=1)))
    both = np.vstack([src, dst])
    diag = float(np.linalg.norm(both.max(axis=0) - both.min(axis=0)))
    if worst > opt.dock_tolerance * max(diag, 1e-12):
        return AttemptResult(iteration, index, "docking", detail=f"misalignment {worst:.4g}")

    protos = tuple([recip.protos[i] for i in kept] + [donor.protos[i] for i in inserted])
    transforms = np.concatenate([recip.transforms[kept],
                                 np.einsum("ij,njk->nik", matrix, donor.transforms[inserted])])
    geo = None
    if opt.dedupe == "isomorphism" and opt.geometric_keys:
        geo = geometric_key(np.concatenate([recip.geo_ids[kept], donor.geo_ids[inserted]]),
                            np.concatenate([recip.poses[kept], np.einsum("ij,njk->nik", matrix, donor.poses[inserted])]),
                            ctx.quantum, ctx.orient)
        if geo in known:
            # the same parts at the same places as a shape seen before (most often the recipient:
            # a piece replaced by a congruent one): the merge would drop it as a duplicate
            return AttemptResult(iteration, index, "known")
    meshes = [ctx.world_mesh(recip_i, i) for i in kept]
    meshes += [geometry.moved_mesh(ctx.protos[p].mesh, t)
               for p, t in zip(protos[len(kept):], transforms[len(kept):])]
    k = len(kept)
    rlo, rhi = ctx.bounds(recip_i)
    nlo, nhi = geometry.bounds_of(meshes[k:])
    lo, hi = np.concatenate([rlo[kept], nlo]), np.concatenate([rhi[kept], nhi])
    if opt.incremental:
        # Contacts among kept parts are the recipient's (they did not move); only pairs that
        # involve an inserted part need the geometry.
        edges = induced_edges(recip.edges, kept)
        try:
            keys = [geometry.part_key(p, t) for p, t in zip(protos, transforms)]
            edges |= geometry.contacts_involving(meshes, types, range(k, n_new), ctx.contact_tolerance,
                                                 lo, hi, ctx.rules, keys=keys, cache=ctx.part_cache)
        except geometry.ForbiddenContact as exc:
            return AttemptResult(iteration, index, "invalid", detail=str(exc))
        edges_t = tuple(sorted((min(u, v), max(u, v)) for u, v in edges))
        centroids = np.concatenate([recip.centroids[kept],
                                    donor.centroids[inserted] @ matrix[:3, :3].T + matrix[:3, 3]])
        # required sites can change on the inserted parts and on kept parts that lost a neighbour
        lost = {int(x) for x in kept_lost_neighbour(recip, kept)}
        problems = geometry.violations(ctx.rules, types, edges_t, meshes, centroids,
                                       ctx.contact_tolerance, range(k, n_new), lo, hi,
                                       keys=keys, cache=ctx.part_cache,
                                       sites_of=[*range(k, n_new), *lost])
    else:
        edges, problems = geometry.full_check(ctx.rules, meshes, types, ctx.contact_tolerance)
        edges_t = tuple(sorted(edges))
    if problems:
        return AttemptResult(iteration, index, "invalid", detail=problems[0])
    op = {
        "donor": donor.key, "recipient": recip.key,
        "subgraph": [int(v) for v in cut.nodes],
        "inserted": [int(v) for v in inserted],
        "boundary": [[int(u), int(v)] for u, v in zip(cut.boundary, match)],
        "removed": sorted(set(range(len(recip))) - set(kept)),
        "kept": [int(v) for v in kept],
        "transform": np.round(matrix, 12).tolist(),
        "residual": float(residual),
        "max_misalignment": worst,
    }
    shape = Shape(key="", protos=protos, transforms=transforms, edges=edges_t, iteration=iteration,
                  parents=(donor.key, recip.key), operation=op, geo=geo)
    return AttemptResult(iteration, index, "valid", shape=shape)


# -- parallel attempts -------------------------------------------------------------------------
# Attempts run through grammarkit's one executor (grammarkit.run.executor): a session whose
# state is an attempt `_Context`, updated with each iteration's new shapes and each batch's
# newly known histograms, and mapped over attempt indices. The executor decides whether
# worker processes pay for themselves and keeps results in attempt order, so the output does
# not depend on the number of workers.
def _strip(shape: "Shape") -> "Shape":
    """A copy without the derived arrays (rebuilt on arrival; keeps pickles small)."""
    return Shape(shape.key, shape.protos, shape.transforms, shape.edges, shape.iteration,
                 shape.parents, shape.operation, shape.ids, geo=shape.geo)


def _session_init(protos, options, seed, rules, tolerance, max_parts, geo_vertices=(), count_range=None) -> _Context:
    ctx = _Context(protos, [], [], options, seed, rules, tolerance, max_parts, count_range,
                   geo_vertices=list(geo_vertices))
    ctx.known = set()  # type: ignore[attr-defined]
    return ctx


def _session_pool(ctx: _Context, added: list, fresh: list) -> None:
    """The pool as of the start of an iteration (attempts see no later shapes)."""
    ctx.pool.extend(sh if sh.adj is not None else sh.prepare(ctx.protos, ctx.orient) for sh in added)
    ctx.fresh = list(fresh)


def _session_known(ctx: _Context, added: list) -> None:
    ctx.known.update(added)  # type: ignore[attr-defined]


def _session_work(ctx: _Context, item: tuple) -> Any:
    """One item of a batch: ("attempt", iteration, index) -> AttemptResult, or ("check", shape)
    -> the final check's first problem ("" accepted)."""
    if item[0] == "check":
        return _session_final_check(ctx, item[1])
    return _session_attempt(ctx, (item[1], item[2]))


def _session_attempt(ctx: _Context, item: tuple[int, int]) -> "AttemptResult":
    iteration, index = item
    res = run_attempt(ctx, iteration, index, ctx.known)  # type: ignore[attr-defined]
    if res.shape is not None:
        res.shape = _strip(res.shape)
    return res


def _session_final_check(ctx: _Context, shape: "Shape") -> str:
    """`grammarkit validate`'s own verdict on a candidate (shape graph from the geometry at the
    variant's default tolerance, every rule): the first problem, or "" (accepted). Support
    verdicts of congruent contacts come from the context's memo (they depend on the two
    parts' relative placement and on up only, not on the tolerance)."""
    shape.prepare(ctx.protos)
    keys = [geometry.part_key(p, t) for p, t in zip(shape.protos, shape.transforms)]
    return geometry.final_problem(ctx.rules, geometry.shape_to_assembly(shape, ctx.protos),
                                  keys=keys, cache=ctx.part_cache)


def default_workers() -> int:
    from grammarkit.run import default_workers as _default

    return _default()


@dataclass
class IterationStats:
    iteration: int
    shapes_before: int
    fresh: int
    attempts: int = 0
    outcomes: dict = field(default_factory=lambda: {k: 0 for k in OUTCOMES})
    new: int = 0
    shapes_after: int = 0
    seconds: float = 0.0
    # invalid attempts by the rule that rejected them first ("orientation", "constraint grounded", ...)
    reasons: dict = field(default_factory=dict)

    def row(self) -> dict:
        return {"iteration": self.iteration, "shapes_before": self.shapes_before,
                "fresh": self.fresh, "attempts": self.attempts,
                "matched": self.attempts - self.outcomes["no-cut"] - self.outcomes["no-match"],
                "valid": self.outcomes["valid"], "new": self.new,
                "shapes": self.shapes_after, "outcomes": dict(self.outcomes),
                "reasons": dict(sorted(self.reasons.items())), "seconds": round(self.seconds, 3)}


def count_target(examples: Sequence[Shape], mode: str) -> dict | None:
    """{type: (fewest, most)} over the examples (option counts="examples", two or more
    examples: one example gives no range), or None (the grammar's own constraints only)."""
    from grammarkit.tiling import example_count_ranges

    if mode != "examples" or len(examples) < 2:
        return None
    return example_count_ranges([s.types for s in examples])


class GraphSampler:
    """Sampler over the examples of one tiling grammar. `run()` yields kept variants."""

    def __init__(self, grammar=None, *, seed: int = 0, workers: int | None = None,
                 options: SamplerOptions | None = None, examples=None, rules=None, executor=None):
        """`grammar`: a tiling Grammar (its rules and examples); or give `rules` (a
        grammarkit.tiling Rules) and `examples` (Assemblies) directly. `executor`: a
        grammarkit.run executor (default: a LocalExecutor with `workers` processes)."""
        if grammar is not None:
            grammar = geometry.as_grammar(grammar)
        elif rules is None or examples is None:
            raise ValueError("GraphSampler needs a grammar, or both rules and examples")
        self.grammar = grammar
        self.seed = int(seed)
        if executor is None:
            from grammarkit.run import LocalExecutor

            executor = LocalExecutor(workers)
        self.executor = executor
        self.workers = executor.workers
        self.options = options or SamplerOptions()
        self.rules = rules if rules is not None else geometry.rules(grammar)
        assemblies = list(examples) if examples is not None else geometry.load_examples(grammar)
        if not assemblies:
            raise geometry.no_examples_error(grammar)
        self.protos: list[Proto] = []
        self.examples: list[Shape] = []
        tol = self.options.contact_tolerance
        if tol is None:
            tol = min(geometry.default_contact_tolerance(a) for a in assemblies)
        self.contact_tolerance = float(tol)
        for n, assembly in enumerate(assemblies):
            name = assembly.name or f"example{n}"
            geometry.check_example(self.rules, assembly, self.contact_tolerance, grammar)
            first = len(self.protos)
            for part in assembly.parts:
                lo, hi = part.mesh.bounds
                self.protos.append(Proto(part.type, part.mesh, np.asarray(part.transform, float),
                                         f"{name}/{part.id}", geometry.surface_centroid(part.mesh),
                                         float(np.linalg.norm(hi - lo)) / 3.0))
            ids = [p.id for p in assembly.parts]
            edges = geometry.example_edges(assembly, self.contact_tolerance)
            index = {pid: i for i, pid in enumerate(ids)}
            edge_t = tuple(sorted((min(index[a], index[b]), max(index[a], index[b])) for a, b in edges))
            shape = Shape(key=f"example:{name}", protos=tuple(range(first, len(self.protos))),
                          transforms=np.repeat(np.eye(4)[None], len(ids), axis=0), edges=edge_t,
                          ids=tuple(ids))
            self.examples.append(shape)
        # geometry classes of the source parts (the geometric keys of dedupe.py)
        geo, poses, local = source_geometry([p.mesh for p in self.protos], [p.transform for p in self.protos],
                                            [p.type for p in self.protos], self.quantum)
        for proto, g, pose in zip(self.protos, geo.tolist(), poses):
            proto.geo, proto.pose = g, pose
        self.geo_vertices = local  # per geometry class: its vertices in its own frame
        self.orient = Orientations(local, self.quantum)
        self.examples = [sh.prepare(self.protos, self.orient) for sh in self.examples]
        largest = max(len(s) for s in self.examples)
        self.max_parts = self.options.max_parts or 4 * largest
        self.count_range = count_target(self.examples, self.options.counts)
        self.stats: list[IterationStats] = []
        self.counter = 0
        self.stopped = ""  # what ended the last run (see `run`)
        self.by_key: dict[str, Shape] = {s.key: s for s in self.examples}

    @property
    def quantum(self) -> float:
        """Translation step of the geometric keys: a tenth of the contact tolerance."""
        return self.contact_tolerance / 10.0

    # The pool grows as variants are kept; examples are never emitted.
    # the iteration / batch / merge loop of one run is one generator (its stopping rules share
    # the loop's state: emitted, fresh, stopped)
    # long: one generator for the run's iteration, batch and merge loop
    def run(self, n: int, iterations: int, *, progress: Callable | None = None,
            time_is_up: Callable[[], bool] | None = None) -> Iterator[Shape]:
        """Yield up to `n` new variants over at most `iterations` iterations; `time_is_up()`
        (polled between batches of attempts) ends the run gracefully. Afterwards `stopped`
        says what ended it: "n" (asked for reached), "iterations" (the cap), "exhausted" (an
        iteration found nothing new: later ones would repeat it) or "time"."""
        if n < 0 or iterations < 0:
            raise ValueError("n and iterations must be >= 0")
        self.stopped = "n"
        opt = self.options
        dedupe = Deduper(opt.dedupe)
        for s in self.examples:
            dedupe.add(s.types, s.edges, s.geo)
        pool: list[Shape] = list(self.examples)
        self.by_key = {s.key: s for s in self.examples}
        self.counter = 0
        fresh = list(range(len(pool)))
        emitted = 0
        self.stats = []
        if n == 0 or iterations == 0:
            return
        session = self.executor.session(_session_init, self.protos, opt, self.seed, self.rules,
                                        self.contact_tolerance, self.max_parts, self.geo_vertices,
                                        self.count_range)
        sent = 0  # pool shapes the session already has
        known_sent: set = set()
        try:
            for it in range(1, iterations + 1):
                if emitted >= n:
                    break
                if not fresh:
                    self.stopped = "exhausted"
                    break
                if time_is_up is not None and time_is_up():
                    self.stopped = "time"
                    break
                t0 = time.perf_counter()
                st = IterationStats(it, len(pool), len(fresh))
                budget = min(opt.max_attempts, max(opt.min_attempts, opt.attempts_per_shape * len(fresh)))
                session.update(_session_pool, [_strip(sh) for sh in pool[sent:]], list(fresh))
                sent = len(pool)
                advance = progress(f"iteration {it}/{iterations}", budget) if progress else None
                new_this: list[int] = []
                # candidates of the last batch (new when tested) whose final check rides with
                # the next batch's attempts, so the workers never wait on one check alone
                pending: list = []

                def keep(verdicts: list | None) -> Iterator[Shape]:
                    nonlocal emitted, pending
                    batch, pending = pending, []
                    for shape in self._keep(session, batch, dedupe, st, n - emitted, verdicts):
                        self.counter += 1
                        shape.key = f"variant_{self.counter:05d}"
                        pool.append(shape)
                        self.by_key[shape.key] = shape
                        new_this.append(len(pool) - 1)
                        st.new += 1
                        emitted += 1
                        yield shape

                for start in range(0, budget, opt.batch_size):
                    if len(pending) >= n - emitted:
                        # these may be the last ones wanted: check them before more attempts
                        yield from keep(None)
                        if emitted >= n:
                            break
                    indices = list(range(start, min(budget, start + opt.batch_size)))
                    added = sorted(dedupe.known() - known_sent, key=repr)
                    if added:
                        session.update(_session_known, added)
                        known_sent.update(added)
                    checks = [("check", _strip(sh)) for _, sh in pending] if opt.final_check else []
                    results = session.map(_session_work, checks + [("attempt", it, i) for i in indices])
                    yield from keep([next(results) for _ in checks] if opt.final_check else None)
                    candidates = []
                    for res in results:
                        st.attempts += 1
                        st.outcomes[res.outcome] += 1
                        if res.outcome in ("invalid", "counts"):
                            why = (rejection_reason(res.detail) if res.outcome == "invalid"
                                   else f"counts {res.detail.split(':')[0]}")
                            st.reasons[why] = st.reasons.get(why, 0) + 1
                        if res.shape is None:
                            continue
                        shape = res.shape.prepare(self.protos, self.orient)
                        if dedupe.is_new(shape.types, shape.edges, shape.geo):
                            candidates.append((res, shape))
                        else:
                            dedupe.note_duplicate(shape.geo)
                    pending = candidates
                    if advance:
                        advance(len(indices), attempts=st.attempts, valid=st.outcomes["valid"],
                                new=st.new, total_new=emitted)
                    if emitted >= n:
                        break
                    if time_is_up is not None and time_is_up():
                        self.stopped = "time"
                        break
                # the iteration's last candidates join the pool before the next iteration
                if pending and emitted < n:
                    yield from keep(None)
                st.shapes_after = len(pool)
                st.seconds = time.perf_counter() - t0
                self.stats.append(st)
                if not new_this and len(fresh) < len(pool):
                    # nothing new from the last iteration's shapes: one more round with every
                    # shape of the pool as a partner before the run counts as exhausted
                    new_this = list(range(len(pool)))
                fresh = new_this
                if self.stopped == "time":
                    break
            else:
                if emitted < n:
                    self.stopped = "iterations"
            if emitted < n and not fresh and self.stopped == "n":
                self.stopped = "exhausted"
        finally:
            session.close()

    def _keep(self, session, candidates: list, dedupe: Deduper, st: "IterationStats", wanted: int,
              verdicts: list | None = None) -> Iterator["Shape"]:
        """The candidates of a batch (valid, new at the time of the test) that are kept, in
        attempt order: each passes the final check and is still new once the earlier ones are
        kept. `verdicts`: the final checks of all `candidates`, made already (they ride with
        the next batch's attempts); else checks are run through the session (so in the
        workers) for as many as are still wanted at a time, so a run that reaches -n checks
        few extra."""
        queue = list(candidates)
        if verdicts is not None:
            checked = list(zip(queue, verdicts))
            queue = []
        while wanted > 0 and (queue or verdicts is not None):
            if verdicts is None:
                head, queue = queue[:wanted], queue[wanted:]
                if self.options.final_check:
                    found = list(session.map(_session_work, [("check", _strip(sh)) for _, sh in head]))
                else:
                    found = [""] * len(head)
                checked = list(zip(head, found))
            verdicts = None
            for (res, shape), problem in checked:
                if wanted <= 0:
                    break
                if problem:  # `grammarkit validate` would reject the file: never kept
                    st.outcomes["valid"] -= 1
                    st.outcomes["final-check"] += 1
                    why = f"final-check {rejection_reason(problem)}"
                    st.reasons[why] = st.reasons.get(why, 0) + 1
                    continue
                if not dedupe.add(shape.types, shape.edges, shape.geo):
                    continue
                shape.operation["attempt"] = [shape.iteration, res.index]
                wanted -= 1
                yield shape
            checked = []

    def growth_table(self) -> list[dict]:
        rows = [{"iteration": 0, "shapes": len(self.examples), "new": len(self.examples)}]
        rows += [{"iteration": s.iteration, "shapes": s.shapes_after, "new": s.new,
                  "attempts": s.attempts, "valid": s.outcomes["valid"]} for s in self.stats]
        return rows

    def to_assembly(self, shape: Shape):
        assembly = geometry.shape_to_assembly(shape, self.protos)
        assembly.meta["graph_sampler"]["operation"] = self.describe(shape)
        return assembly

    def describe(self, shape: Shape) -> dict:
        """The operation that made `shape`, with part ids instead of node indices."""
        op = shape.operation
        donor, recip = self.by_key[op["donor"]], self.by_key[op["recipient"]]
        inserted_new = {old: len(op["kept"]) + k for k, old in enumerate(op["inserted"])}
        kept_new = {old: k for k, old in enumerate(op["kept"])}
        return {
            "donor": donor.key, "recipient": recip.key,
            "replaced": [recip.ids[i] for i in op["removed"]],
            "inserted": {donor.ids[i]: shape.ids[inserted_new[i]] for i in op["inserted"]},
            "subgraph": [donor.ids[i] for i in op["subgraph"]],
            "boundary": [{"donor": donor.ids[a], "recipient": recip.ids[b],
                          "variant": shape.ids[inserted_new[a]] if a in inserted_new
                          else shape.ids[kept_new[b]]}
                         for a, b in op["boundary"]],
            "transform": op["transform"], "residual": op["residual"],
            "max_misalignment": op["max_misalignment"], "attempt": op.get("attempt"),
        }


def sample(grammar, n: int = 100, iterations: int = 4, seed: int = 0, workers: int | None = None,
           *, options: SamplerOptions | None = None, progress: Callable | None = None,
           **option_kwargs) -> Iterator:
    """Yield up to `n` new valid assemblies made from `grammar`'s examples (Kalojanov 2019).

    `grammar`: a Grammar, grammar text or a path (loaded with grammarkit.dsl.load).
    Each yielded `Assembly` has `meta["graph_sampler"]` with its parents and operation.
    Keyword options (`tolerance=0.1`, `dedupe="isomorphism"`, ...) are `SamplerOptions` fields.
    """
    grammar = geometry.as_grammar(grammar)
    if option_kwargs:
        options = SamplerOptions(**{**(options.model_dump() if options else {}), **option_kwargs})
    sampler = GraphSampler(grammar, seed=seed, workers=workers, options=options)
    for shape in sampler.run(n, iterations, progress=progress):
        yield sampler.to_assembly(shape)
