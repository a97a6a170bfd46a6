"""Latent-space sampling (Kalojanov et al. 2019, section 5.2) and the prior.

All modes start from the encodings of training strings (`LoadedVAE.train_mu`, one per
training graph) and decode latent points with `decoding.decode_latents` (free or masked):

- `prior`: z ~ N(0, I), the usual VAE sample.
- `perturb`: around a training point p, add a random offset r (uniform in [-m, m] in every
  dimension) with a magnitude m that grows step by step up to `magnitude` (0.25, the paper's
  value) until the decoded string is valid and describes a graph other than p's.
- `interpolate`: points at equal intervals on the segment between two training points, each
  searched like `perturb` with smaller offsets (`local_magnitude`).
- `path`: a path of `path_length` (32) latent points from one training point to another,
  made by repeatedly splitting every segment at the training point closest to both of its
  ends; its segments are then sampled like `interpolate`.

Placed decoding (placed.py) takes a length budget per point, the *length prior*: the start
string's length, or with `max_length` a random training string's of at most that length (the
length-bucketed prior). `on_point()` is called after every decoded point (progress).

`Sampler.run(n)` yields `Sample`s in order; each knows the latent point, the decoded string,
whether it is valid and its graph, and which training graphs it came from. Everything is
drawn from one numpy generator seeded by the caller: same seed, same samples.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator

import numpy as np
import torch

from .decoding import Decoded, decode_latents
from .graphs import GraphSet, TypedGraph
from .modelfile import LoadedVAE
from .strings import decode

__all__ = ["MODES", "Sample", "Sampler", "SamplingSettings"]

MODES = ("prior", "perturb", "interpolate", "path")


@dataclass(frozen=True)
class SamplingSettings:
    decoding: str = "masked"  # or "free"
    temperature: float = 0.0
    magnitude: float = 0.25  # perturb: largest offset per dimension (paper: 0.25)
    steps: int = 8  # perturb: offsets of magnitude magnitude * k / steps, k = 1..steps
    local_magnitude: float = 0.1  # interpolate / path: offsets around each point
    local_steps: int = 3
    points: int = 8  # interpolate: points per segment; path: points per path segment
    path_length: int = 32
    batch: int = 128  # seeds decoded together
    max_tokens: int | None = None  # size control: start only from training points whose string is this short
    max_length: int | None = None  # placed decoding's length prior: budgets drawn from training strings this short
    min_length: int | None = None  # ... and at least this long (the bucket's lower end)


@dataclass
class Sample:
    z: np.ndarray
    decoded: Decoded
    mode: str
    parents: tuple[int, ...] = ()  # indices of the training graphs it started from
    attempt: int = 0  # decoded points spent on it (perturbation steps)

    @property
    def valid(self) -> bool:
        return self.decoded.valid

    @property
    def text(self) -> str:
        return self.decoded.text


@dataclass
class Sampler:
    vae: LoadedVAE
    settings: SamplingSettings = field(default_factory=SamplingSettings)
    seed: int = 0
    decoded_points: int = 0  # every latent point decoded (the yield's denominator)
    valid_points: int = 0
    placed: object = None  # decoding "placed": the placed.PlacedDecoder that decodes each point
    stop: object = None  # a callable: True when the run's time is up (placed decoding polls it per point)
    on_point: object = None  # a callable, called after every decoded latent point (progress)
    known: object = None  # a callable graph -> bool: graphs the search moves past (training graphs, made ones)
    novel_only: bool = False  # placed decoding: a finished string of a `known` graph is a dead end of its search
    per_point: int = 1  # placed decoding: finished strings of distinct graphs searched per latent point

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self._train_graphs: list[TypedGraph] | None = None
        self._calls = 0
        self.lost: dict[str, int] = {}  # invalid decodes by where they failed ("decoding", "3D placement")
        self._pending: list[Sample] = []  # further strings of points already decoded (per_point > 1)

    # ---- helpers ---------------------------------------------------------------------------
    @property
    def train_graphs(self) -> list[TypedGraph]:
        if self._train_graphs is None:
            self._train_graphs = [decode(s, self.vae.alphabet).graph for s in self.vae.train_strings]
        return self._train_graphs

    @property
    def pool(self) -> np.ndarray:
        """Indices of the training points sampling may start from (all, or those whose string
        has at most `max_tokens` tokens)."""
        S = self.vae.train_strings
        m = self.settings.max_tokens
        idx = np.arange(len(S)) if m is None else np.array([i for i, t in enumerate(S) if len(t) <= m], dtype=np.int64)
        return idx if len(idx) else np.arange(len(S))

    def _targets(self, parents: list[tuple[int, ...]]) -> list[int]:
        """The length prior: per latent point, the length of the training strings it starts
        from (their mean), or a random training string's. With `max_length`, the length of a
        random training string of at most that many tokens instead (a length-bucketed prior:
        the start point still comes from the whole pool, so the latent chooses the content
        and the bucket the size)."""
        S = self.vae.train_strings
        if self.settings.max_length is not None:
            bucket = self._bucket()
            return [int(bucket[int(self.rng.integers(len(bucket)))]) for _ in parents]
        return [int(round(np.mean([len(S[a]) for a in ps]))) if ps else len(S[int(self.rng.integers(len(S)))])
                for ps in parents]

    def _bucket(self) -> list[int]:
        """The training strings' lengths (in characters, as the budget counts them) of at most
        `max_length` (and at least `min_length`); the shortest training string's when none is that short."""
        S = self.vae.train_strings
        m = self.settings.max_length
        lo = self.settings.min_length or 0
        lengths = sorted(len(t) for t in S if lo <= len(t) <= m)
        return lengths or sorted(len(t) for t in S if len(t) <= m) or [min(len(t) for t in S)]

    def _decode(self, z: np.ndarray, parents: list[tuple[int, ...]] | None = None) -> list[Decoded]:
        self._calls += 1
        if self.settings.decoding == "placed":
            targets = self._targets(parents or [()] * len(z))
            out = []
            for i in range(len(z)):  # seconds per point: the time budget is polled between points
                if self.stop is not None and self.stop():
                    break
                reject = self.known if self.novel_only else None
                out.append(self.placed.decode(z[i], targets[i], seed=self.seed * 7919 + self._calls * 1009 + i,
                                              reject=reject, per_point=self.per_point))
                self.decoded_points += 1
                if self.on_point is not None:
                    self.on_point()
            self.decoded_points -= len(out)
            self._count(out)
            return out
        out = decode_latents(self.vae.model, torch.from_numpy(np.ascontiguousarray(z, dtype=np.float32)),
                             vocab=self.vae.vocab, rules=self.vae.rules, mode=self.settings.decoding,
                             temperature=self.settings.temperature, seed=self.seed * 7919 + self._calls)
        self._count(out)
        if self.on_point is not None:
            self.on_point()
        return out

    def _count(self, out: list[Decoded]) -> None:
        self.decoded_points += len(out)
        self.valid_points += sum(d.valid for d in out)
        for d in out:
            if not d.valid:
                key = d.stage or "decoding"
                self.lost[key] = self.lost.get(key, 0) + 1

    def _search(self, centres: np.ndarray, avoid: list[list[int]], magnitude: float, steps: int,
                mode: str, parents: list[tuple[int, ...]]) -> list[Sample | None]:
        """For each centre, offsets of growing magnitude until a valid string whose graph is
        none of `avoid[i]` (training graph indices) and not `known` appears (the paper's "until
        a new valid string"); None where none did."""
        found: list[Sample | None] = [None] * len(centres)
        todo = list(range(len(centres)))
        D = centres.shape[1]
        for k in range(1, steps + 1):
            if not todo or (self.stop is not None and self.stop()):
                break
            m = magnitude * k / steps
            z = centres[todo] + self.rng.uniform(-m, m, size=(len(todo), D))
            outs = self._decode(z, [parents[i] for i in todo])
            left = []
            for j, i, d in zip(range(len(todo)), todo, outs):
                if (d.valid and not any(_same(d.graph, self.train_graphs[a]) for a in avoid[i])
                        and not (self.known is not None and self.known(d.graph))):
                    found[i] = Sample(z[j], d, mode, parents[i], k)
                    # per_point > 1: the point's further strings follow it (same latent point)
                    self._pending += [Sample(z[j], m, mode, parents[i], k) for m in d.more]
                    continue
                if d.valid:  # a valid decode of a graph the search moves past
                    self.lost["novelty"] = self.lost.get("novelty", 0) + 1
                left.append(i)
            todo = left
        return found

    # ---- modes -----------------------------------------------------------------------------
    def prior(self, count: int) -> list[Sample]:
        z = self.rng.standard_normal((count, self.vae.model.config.latent))
        out = [Sample(z[i], d, "prior") for i, d in enumerate(self._decode(z))]
        self._pending += [Sample(s.z, m, "prior") for s in out for m in s.decoded.more]
        return out

    def perturb(self, count: int) -> list[Sample | None]:
        mu = self.vae.train_mu.numpy()
        pool = self.pool
        idx = pool[self.rng.integers(0, len(pool), size=count)]
        return self._search(mu[idx], [[int(i)] for i in idx], self.settings.magnitude, self.settings.steps,
                            "perturb", [(int(i),) for i in idx])

    def interpolate(self, pairs: int) -> list[Sample | None]:
        mu = self.vae.train_mu.numpy()
        out: list[Sample | None] = []
        P = self.settings.points
        ts = np.arange(1, P + 1) / (P + 1)
        for _ in range(pairs):
            a, b = (int(x) for x in self.rng.choice(self.pool, size=2, replace=False))
            centres = mu[a] + ts[:, None] * (mu[b] - mu[a])
            out += self._search(centres, [[a, b]] * P, self.settings.local_magnitude, self.settings.local_steps,
                                "interpolate", [(a, b)] * P)
        return out

    def latent_path(self, a: int, b: int) -> list[int]:
        """Training-point indices of a path from a to b: every segment split at the training
        point closest to both ends (smallest sum of distances) until `path_length` points."""
        mu = self.vae.train_mu.numpy()
        path = [a, b]
        used = {a, b}
        L = min(self.settings.path_length, len(mu))
        while len(path) < L:
            grew = False
            new = [path[0]]
            for p, q in zip(path, path[1:]):
                if len(path) + (len(new) - 1 - path.index(p)) >= L:
                    new.append(q)
                    continue
                d = np.linalg.norm(mu - mu[p], axis=1) + np.linalg.norm(mu - mu[q], axis=1)
                d[list(used)] = np.inf
                x = int(np.argmin(d))
                if np.isfinite(d[x]) and len(new) + (len(path) - len(new)) < L:
                    new.append(x)
                    used.add(x)
                    grew = True
                new.append(q)
            path = new[:L] if len(new) > L else new
            if not grew:
                break
        return path

    def path(self, paths: int) -> list[Sample | None]:
        mu = self.vae.train_mu.numpy()
        out: list[Sample | None] = []
        P = max(1, self.settings.points // 4)
        ts = np.arange(1, P + 1) / (P + 1)
        for _ in range(paths):
            a, b = (int(x) for x in self.rng.choice(self.pool, size=2, replace=False))
            route = self.latent_path(a, b)
            centres, avoid, parents = [], [], []
            for p, q in zip(route, route[1:]):
                for t in ts:
                    centres.append(mu[p] + t * (mu[q] - mu[p]))
                    avoid.append([p, q])
                    parents.append((p, q))
            out += self._search(np.array(centres), avoid, self.settings.local_magnitude,
                                self.settings.local_steps, "path", parents)
        return out

    def run(self, mode: str, rounds: int) -> Iterator[Sample]:
        """`rounds` batches of the mode's samples (perturb: `batch` seeds per round; interpolate:
        `batch // points` pairs; path: one path; prior: `batch` points); None results skipped."""
        if mode not in MODES:
            raise ValueError(f"unknown sampling mode {mode!r}; known: {', '.join(MODES)}")
        B = self.settings.batch
        for _ in range(rounds):
            if mode == "prior":
                batch: list = self.prior(B)
            elif mode == "perturb":
                batch = self.perturb(B)
            elif mode == "interpolate":
                batch = self.interpolate(max(1, B // self.settings.points))
            else:
                batch = self.path(1)
            for s in batch:
                if s is not None:
                    yield s
            pending, self._pending = self._pending, []
            yield from pending


def _same(g: TypedGraph | None, h: TypedGraph) -> bool:
    if g is None:
        return False
    if g.types == h.types and g.edges == h.edges:
        return True
    if sorted(g.types) != sorted(h.types) or len(g.edges) != len(h.edges):
        return False
    s = GraphSet()
    s.add(h)
    return g in s
