"""Placed decoding (beyond the paper): the string and its edge categories decoded together, each
step masked by what can still be placed in 3D.

The paper decodes a string freely, keeps it if the grammar accepts it, and only then asks an
edge-category network how to build it (section 6); the masked decoder (decoding.py) makes every
string grammatical but most sampled castles still cannot be built: a ring of towers and walls
closes only when its turns add up. Here every letter the decoder writes is *placed* at once:

- the new part docks to the part it hangs from (its parent in the string) with one of the
  pair's edge categories (categories.py: a rigid placement seen in the training shapes); every
  category is kept as a hypothesis: a beam of `width` distinct layouts per written prefix,
  scored by the categories' training frequencies (in the second half of the budget, minus a
  growing penalty for the distance to the open rings' docking spots);
- a placement is *masked out* when the part would touch a placed part that it may not join:
  any part that is not its parent and does not own an open ring label (no collision), or a
  ring owner in a placement that is no docking category of the pair (no free docking site);
  when it goes below the ground (support); or when an open ring's owner is farther away than
  the parts the length budget still allows can reach;
- the parts it touches besides its parent *must* be joined right away: after the letter only
  the ring labels those parts opened may follow until all of them are closed, and no other
  ring label may close on it (its owner does not touch it);
- the topology masks (masked.py: neighbour types and counts, syntax, the length budget) apply
  as before, with a budget per sample: the *length prior* (the length of the training string
  the sample starts from, times 1 + `slack`; a random training string's for the prior), so
  samples have the training sizes.

The search is depth-first in the network's order (most likely allowed token first; a letter that
some layout can place against an open ring's owner goes first), at most `branching` tokens per
step whose beam survives and `expansions` steps in all; a latent point whose search runs out is
retried with sampled tokens (`retries` times). What comes out is a string, its graph, and a
frame and category per part and edge: `Instantiator.build` makes the shape and validates it
(the part of the grammar that only the finished shape can show: `grounded`, sites, the
recomputed contact graph); nothing is yielded that fails.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from .consistent import ConsistentDecoder, _relative
from .decoding import Decoded, check_text
from .graphs import GraphSet
from .masked import Automaton, DecodeState
from .strings import decode as decode_string
from .vocab import EOS

__all__ = ["PlacedDecoder", "Placement"]


FINISH_COST = 10  # search steps charged for a finished string that fails the finish check


@dataclass
class Placement:
    frames: list  # per part (string order), 4x4 canonical frames
    variants: list  # per part, geometry variant keys
    categories: dict = field(default_factory=dict)  # (u, v), u < v: category u -> v
    expansions: int = 0  # decoding steps spent
    retries: int = 0
    assembly: Any = None  # the built shape, when the decoder checked it (`finish_check`)


@dataclass
class _Hyp:
    """One way to place the string written so far."""
    frames: list
    variants: list
    cats: dict
    touched: dict  # parts the current part touches besides its parent, not yet joined: category
    score: float = 0.0
    rank: float | None = None  # score minus the homing penalty, when ranked by it
    layout: tuple = ()  # per part: its rounded position and orientation (`_layout_key`)


class _OutOfSteps(Exception):
    pass


class PlacedDecoder:
    """Decode latent points into placed shape strings (see the module docstring)."""

    def __init__(self, vae: Any, instantiator: Any, *, expansions: int = 150, branching: int = 2,
                 retries: int = 2, slack: float = 0.15, pressure: int = 40, temperature: float = 0.0,
                 width: int = 16, homing: float = 1.0, reach: bool = True, homing_from: float | None = None,
                 max_open: int | None = None, bonus: int = 40, finish_check: bool = False, finish_tries: int = 4):
        self.vae = vae
        # finish_check: a finished string is built and checked at once (`Instantiator.build`:
        # the grammar's global constraints such as `filled` and `grounded`, which no local mask
        # sees); one that fails on each of its best `finish_tries` layouts is a dead end of the
        # search like a masked token, so the search goes on to a string that builds
        self.finish_check = bool(finish_check)
        self.finish_tries = max(1, int(finish_tries))
        self.model = vae.model
        self.vocab = vae.vocab
        self.rules = vae.rules
        self.inst = instantiator
        self.cats = instantiator.cats
        self.lib = instantiator.library
        self.geom = ConsistentDecoder(instantiator)  # cached exact contact tests
        self.expansions = int(expansions)
        self.branching = max(1, int(branching))
        self.retries = max(0, int(retries))
        self.slack = float(slack)
        self.pressure = int(pressure)
        self.temperature = float(temperature)
        self.width = max(1, int(width))
        self.homing = float(homing)
        self.max_open = None if max_open is None else int(max_open)
        self.bonus = int(bonus)  # per_point > 1: search steps granted per string found
        # with the reach table the beam is ranked by it from the first letter (measured better
        # than from half the budget); the straight-line homing starts at half the budget as before
        self.homing_from = float(homing_from if homing_from is not None else (0.0 if reach else 0.5))
        self._autos: dict[int, Automaton] = {}
        self._cands: dict[tuple, list] = {}
        self.types = list(vae.alphabet.types)
        steps = [float(np.linalg.norm(c.matrix[:3, 3])) for c in self.cats.categories]
        self.step_max = (max(steps) if steps else 1.0) * 1.05 + 2 * instantiator.tolerance
        self._low: dict[tuple[str, str], np.ndarray] = {}
        total: dict[tuple[str, str], int] = {}
        for c in self.cats.categories:
            total[(c.a, c.b)] = total.get((c.a, c.b), 0) + c.count
        self.logfreq = [math.log(max(1, c.count) / max(1, total[(c.a, c.b)])) for c in self.cats.categories]
        self.reach = None
        if reach:
            from .reach import ReachTable

            self.reach = ReachTable(self.cats, self.types)
        self.stats = {"letters": 0, "collision": 0, "no dock": 0, "ground": 0, "reach": 0, "out of steps": 0}

    # ---- budgets ---------------------------------------------------------------------------
    def budget_for(self, target_len: int | None) -> int:
        """Tokens a sample may write: the length prior (`target_len` * (1 + slack)), never more
        than the masked decoder's budget (1.2 times the longest training string)."""
        cap = int(math.ceil(1.2 * self.model.config.max_len))
        if target_len is None:
            return cap
        return max(4, min(cap, int(math.ceil(target_len * (1.0 + self.slack)))))

    def _automaton(self, max_len: int) -> Automaton:
        a = self._autos.get(max_len)
        if a is None:
            a = self._autos[max_len] = Automaton(self.rules, self.vocab, max_len)
        return a

    # ---- geometry --------------------------------------------------------------------------
    def _lowest(self, t: str, v: str, F: np.ndarray) -> float:
        """The part's lowest point along the grammar's up axis."""
        up = self.lib.up
        key = (t, v)
        if key not in self._low:
            self._low[key] = self.lib.variants[key][0]
        local = self._low[key]
        return float(((local @ F[:3, :3].T + F[:3, 3]) @ up).min())

    def _layout_key(self, ty: str, vy: str, Fy: np.ndarray) -> bytes:
        """A part's variant, position and frame, rounded. (The frame itself, not the canonical
        one modulo the part's symmetries: children are placed from the frame, so two frames
        that differ by a symmetry place them differently.)"""
        size = max(self.lib.sizes.values()) or 1.0
        return (str(vy).encode() + np.round(Fy[:3, 3] / (1e-3 * size)).astype(np.int64).tobytes()
                + np.round(Fy[:3, :3] / 1e-3).astype(np.int64).tobytes())

    @staticmethod
    def _distinct(beam: list) -> list:
        """One hypothesis per distinct layout: the same frames of all parts leave the same
        future, however the categories that led there differ."""
        seen: dict[tuple, _Hyp] = {}
        for h in beam:
            key = (h.layout, tuple(sorted(h.touched)))
            if key not in seen or h.score > seen[key].score:
                seen[key] = h
        return list(seen.values())

    def _candidates(self, tx: str, ty: str, parent_variant: str) -> list:
        """Every (category, placement in the parent's frame, child variant) of a tx -> ty edge,
        in category order (the beam keeps them all and ranks them by frequency, so the
        instantiator's Monte-Carlo order is not needed); cached per pair and parent variant."""
        key = (tx, ty, parent_variant)
        hit = self._cands.get(key)
        if hit is None:
            hit = self._cands[key] = [
                (k, self.cats.placement(k, tx, ty), self.cats.variants(k, tx, ty)[1] or self.inst.default_variant[ty])
                for k in self.cats.pair_categories(tx, ty)
                if parent_variant is None or self.cats.variants(k, tx, ty)[0] in ("", parent_variant)]
        return hit

    def _may_close(self, ctx: "_Ctx", beam: list, ty: str) -> bool:
        """Can a type-`ty` letter under the current part land within touching distance of an
        open ring's owner in some hypothesis (bounding spheres only)? A cheap filter before the
        exact placement of every candidate."""
        st = ctx.state
        parent = st.current
        owners = sorted(set(st.rings.values()))
        if parent < 0 or not owners:
            return False
        ry = max(self.geom._r(t, v) for t, v in self.lib.variants if t == ty) + 2 * self.inst.tolerance
        for hyp in beam:
            if hyp.touched:
                continue
            cands = self._candidates(ctx.types[parent], ty, hyp.variants[parent])
            if not cands:
                continue
            Y = np.array([(hyp.frames[parent] @ A)[:3, 3] for _k, A, _v in cands])
            for o in owners:
                reach = self.geom._r(ctx.types[o], hyp.variants[o]) + ry
                if (np.linalg.norm(Y - hyp.frames[o][:3, 3], axis=1) <= reach).any():
                    return True
        return False

    def _spots(self, types: list, frames: list, o: int) -> list:
        """Where a part joined to part `o` can sit (frame origins), by every category of o's type."""
        to, Fo = types[o], frames[o]
        out = [(Fo @ self.cats.placement(k, to, ty))[:3, 3]
               for ty in set(self.types) for k in self.cats.pair_categories(to, ty)]
        return out or [Fo[:3, 3]]

    def _arrays(self, ctx: "_Ctx", hyp: _Hyp) -> tuple[np.ndarray, np.ndarray]:
        """The hypothesis' frame origins (n, 3) and bounding radii (n,), made once per
        hypothesis and step (every candidate placement of the step reads them)."""
        T, F, V = ctx.types, hyp.frames, hyp.variants
        if not F:
            return np.zeros((0, 3)), np.zeros(0)
        return (np.array([f[:3, 3] for f in F]),
                np.array([self.geom._r(T[p], V[p]) for p in range(len(F))]))

    def _place(self, ctx: "_Ctx", hyp: _Hyp, parent: int, ty: str, Fy: np.ndarray, vy: str,
               arrays: tuple | None = None):
        """The placed parts (besides the parent) that a part of type `ty` at `Fy` touches, with
        their cycle edges' categories, or None with the reason the placement is masked out."""
        T, F, V = ctx.types, hyp.frames, hyp.variants
        if self.lib.up is not None and self.lib.ground is not None and ctx.types and ctx.types[0] in self.lib.on_ground:
            # below the ground only when the first part stands on it (else its height is
            # unknown, and `grounded` is checked on the finished shape)
            if self._lowest(ty, vy, Fy) < self.lib.ground - self.inst.tolerance:
                return None, "ground"
        n = len(F)
        if n == 0:
            return {}, None
        P, R = arrays if arrays is not None else self._arrays(ctx, hyp)
        owners = set(ctx.state.rings.values())
        d = np.sqrt(((P - Fy[:3, 3]) ** 2).sum(axis=1))
        # an open ring's owner must stay reachable with the tokens left (each part one step)
        # from a part that can still grow: the new one or the owner of an open branch
        left = ctx.state.a.max_len - ctx.state.length
        stack = [q for q in ctx.state.stack if q >= 0]
        # parts still possible after this letter: the tokens left minus the end and one ring
        # label per open ring (the reach table counts parts of a chain, exact up to collisions)
        parts_left = left - 2 - len(ctx.state.rings)
        S = P[stack] if stack else None
        for o in owners:
            if o == parent:
                continue
            near = float(d[o]) if S is None else min(float(d[o]), float(np.sqrt(((S - P[o]) ** 2).sum(axis=1)).min()))
            if near > (left + 1) * self.step_max:
                return None, "reach"
            if self.reach is not None and parts_left < self.reach.depth:
                need = min([self.reach.parts_needed(ty, Fy, T[o], F[o])]
                           + [self.reach.parts_needed(T[q], F[q], T[o], F[o]) for q in stack if q != o])
                if need > parts_left:
                    return None, "reach"
        radius = R + self.geom._r(ty, vy)
        touched: dict[int, int] = {}
        for j in np.flatnonzero(d <= radius + 2 * self.inst.tolerance):
            p = int(j)
            if p == parent or not self.geom._touch(T[p], V[p], F[p], ty, vy, Fy):
                continue
            if p not in owners:
                return None, "collision"
            kw, _dist = self.cats.classify(T[p], ty, _relative(F[p], Fy), V[p] or None, vy or None)
            if kw is None:
                return None, "no dock"
            touched[p] = kw
        return touched, None

    def _extend(self, ctx: "_Ctx", beam: list, ty: str) -> list:
        """Every placement of a new type-`ty` part under the current part in every hypothesis
        that the masks let through, the `width` most likely kept (categories scored by how
        often they occur in the training shapes)."""
        parent = ctx.state.current
        out = []
        for hyp in beam:
            if parent < 0:
                cands = [(None, self.lib.start_frame.get(ty, np.eye(4)), self.lib.default[ty])]
            else:
                cands = [(k, hyp.frames[parent] @ A, vy)
                         for k, A, vy in self._candidates(ctx.types[parent], ty, hyp.variants[parent])]
            arrays = self._arrays(ctx, hyp)
            for k, Fy, vy in cands:
                self.stats["letters"] += 1
                touched, why = self._place(ctx, hyp, parent, ty, Fy, vy, arrays)
                if touched is None:
                    self.stats[why] += 1
                    ctx.fails[why] = ctx.fails.get(why, 0) + 1
                    continue
                cats = dict(hyp.cats)
                score = hyp.score
                if k is not None:
                    cats[(parent, len(hyp.frames))] = k
                    score += self.logfreq[k]
                out.append(_Hyp(hyp.frames + [Fy], hyp.variants + [vy], cats, touched, score,
                                layout=hyp.layout + (self._layout_key(ty, vy, Fy),)))
        if len(out) > 1:
            out = self._distinct(out)
        st = ctx.state
        # in the second half of the budget the beam keeps the hypotheses whose open rings can
        # close soonest: the new part's distance to the nearest docking spot of each open
        # ring's owner, in docking steps, weighs more and more (not when placing a given string)
        weight = self.homing * min(1.0, max(0.0, (st.length / st.a.max_len - self.homing_from) / (1.0 - self.homing_from))) if ctx.forced is None else 0
        if len(out) > self.width and weight > 0:
            owners = [o for o in set(st.rings.values())]
            if owners:
                for hyp in out:
                    hyp.rank = hyp.score - weight * self._homing(ctx, hyp, owners, ty)
        out.sort(key=lambda h: -(h.rank if h.rank is not None else h.score))
        return out[:self.width]

    def _homing(self, ctx: "_Ctx", hyp: _Hyp, owners: list, ty: str) -> float:
        """How far the open rings are from closing in `hyp` (whose last part is a new type-`ty`
        part): per open ring's owner, the fewest parts a chain from the new part or an open
        branch's owner needs to dock to it (the reach table), or without one the distance from
        the new part to the owner's nearest docking spot in docking steps."""
        y = hyp.frames[-1]
        if self.reach is None:
            return sum(min(float(np.linalg.norm(p - y[:3, 3])) for p in self._spots(ctx.types, hyp.frames, o))
                       for o in owners) / self.step_max
        T, F = ctx.types, hyp.frames
        stack = [q for q in ctx.state.stack if 0 <= q < len(F)]
        return float(sum(min([self.reach.parts_needed(ty, y, T[o], F[o])]
                             + [self.reach.parts_needed(T[q], F[q], T[o], F[o]) for q in stack if q != o])
                         for o in owners))

    # ---- the search ------------------------------------------------------------------------
    @torch.no_grad()
    def decode(self, z: np.ndarray, target_len: int | None = None, seed: int = 0,
               reject: Any = None, per_point: int = 1) -> Decoded:
        """One latent point -> a checked string with its placement (`Decoded.placement`), or an
        invalid Decoded whose error says why (`stage`: "decoding" or "3D placement").

        `reject` (a callable graph -> bool, e.g. "is a training graph or made already"): a
        finished string whose graph it rejects is a dead end like any masked token, so the
        search goes on to the next-best alternative instead of returning a known shape.

        `per_point` > 1: after a finished string the search goes on (from where it is, so the
        next strings share the latent point's prefix and differ near the end) until that many
        strings of distinct graphs, none rejected, are found; the first is returned, the others
        in its `more`. Each one found grants `bonus` more search steps."""
        zt = torch.from_numpy(np.ascontiguousarray(z, dtype=np.float32).reshape(1, -1))
        auto = self._automaton(self.budget_for(target_len))
        soft_end = target_len if target_len is not None else getattr(self.model, "soft_end", None)
        spent = 0
        reasons: dict[str, int] = {}
        ctx = None
        for attempt in range(self.retries + 1):
            temp = self.temperature if attempt == 0 else max(self.temperature, 0.8)
            ctx = _Ctx(auto.start(), np.random.default_rng([seed, attempt]), temp, soft_end, self.expansions,
                       reject=reject, want=max(1, int(per_point)), attempt=attempt)
            ok = self._run(ctx, zt)
            spent += ctx.steps
            for key, c in ctx.fails.items():
                reasons[key] = reasons.get(key, 0) + c
            if ok and ctx.want <= 1:
                d = self._result(ctx, spent, attempt)
                if d.valid:
                    return d
            if ctx.found:  # every string wanted, or out of steps after some: keep those
                first, *rest = ctx.found
                first.more = rest
                return first
        common = max(reasons, key=reasons.get) if reasons else "no allowed token"
        out = Decoded(ctx.state.graph_text(), False, None,
                      f"placed decoding found no buildable string in {spent} steps (most often masked: {common})",
                      spent, "failed")
        # a search that finished strings but only known ones lost its point to novelty
        out.stage = "novelty" if reasons.get("known") else ("3D placement" if reasons else "decoding")
        return out

    @torch.no_grad()
    def place_text(self, text: str, *, steps: int = 20000, seed: int = 0) -> Decoded:
        """Place a given string (the same masks, the categories searched by the beam): whether
        the masks let a known buildable string through (tests) and how it sits in 3D."""
        tokens = self.vocab.encode(text) + [EOS]
        ctx = _Ctx(self._automaton(max(len(tokens), 4)).start(), np.random.default_rng(seed), 0.0, None, steps,
                   forced=tokens)
        if not self._run(ctx, torch.zeros((1, self.model.config.latent))):
            return Decoded(text, False, None, f"masked out after {ctx.deepest} tokens: {ctx.fails}",
                           ctx.steps, "failed")
        return self._result(ctx, ctx.steps, 0)

    def _run(self, ctx: "_Ctx", z: torch.Tensor) -> bool:
        logits, h = self.model.start(z)
        try:
            return self._dfs(ctx, z, logits, h, [_Hyp([], [], {}, {})])
        except _OutOfSteps:
            self.stats["out of steps"] += 1
            return False

    def _result(self, ctx: "_Ctx", spent: int, attempt: int) -> Decoded:
        d = check_text(ctx.state.graph_text(), self.vae.alphabet, self.rules)
        best = ctx.result
        d.placement = Placement(list(best.frames), list(best.variants), dict(best.cats), spent, attempt,
                                assembly=ctx.built)
        d.repaired = "placed" if attempt == 0 else "placed-resample"
        d.backtracks = spent
        return d

    def _built(self, text: str, beam: list) -> tuple | None:
        """(layout, assembly) of the first of the beam's best layouts whose shape passes the
        final check, or None."""
        g = decode_string(text, self.vae.alphabet).graph
        for hyp in beam[:self.finish_tries]:
            asm, problem = self.inst.build(g, list(hyp.frames), list(hyp.variants))
            if problem is None:
                return hyp, asm
        return None

    def _ordered(self, ctx: "_Ctx", logits: torch.Tensor, allowed: list[int]) -> list[int]:
        row = logits[0].double()
        if ctx.temperature > 0:
            g = torch.from_numpy(ctx.rng.gumbel(size=row.shape[0]))
            row = row / ctx.temperature + g
        return sorted(allowed, key=lambda t: -float(row[t]))

    def _next_beam(self, ctx: "_Ctx", beam: list, t: int) -> list:
        """The hypotheses that survive token `t` (see the module docstring)."""
        st = ctx.state
        kind, value = self.vocab.kind(t)
        if kind == "ring" and value in st.rings:  # closes: only where its owner touches this part
            owner = st.rings[value]
            out = []
            for h in beam:
                if owner in h.touched:
                    cats = dict(h.cats)
                    cats[(owner, st.current)] = h.touched[owner]
                    rest = {p: k for p, k in h.touched.items() if p != owner}
                    out.append(_Hyp(h.frames, h.variants, cats, rest, h.score, layout=h.layout))
            return out
        if kind == "ring":  # opens
            return beam
        # anything else leaves the part: every part it touches must have been joined
        beam = [h for h in beam if not h.touched]
        if kind == "node" and beam:
            return self._extend(ctx, beam, self.types[value])
        return beam

    def _dfs(self, ctx: "_Ctx", z: torch.Tensor, logits: torch.Tensor, h: torch.Tensor, beam: list) -> bool:
        """Depth-first over tokens in the network's order (at most `branching` per step whose
        beam of placements survives); True when the string ended (ctx.result holds the best
        placement)."""
        st = ctx.state
        if st.done:
            if ctx.reject is not None and ctx.reject(decode_string(st.graph_text(), self.vae.alphabet).graph):
                # a known graph: the decoder's favourite small castles come back from many
                # latent points; searching on finds the nearest completion that is new
                ctx.fails["known"] = ctx.fails.get("known", 0) + 1
                self.stats["known"] = self.stats.get("known", 0) + 1
                return False
            ctx.result = beam[0]
            if self.finish_check:
                built = self._built(st.graph_text(), beam)
                if built is None:
                    ctx.fails["unbuildable"] = ctx.fails.get("unbuildable", 0) + 1
                    self.stats["unbuildable"] = self.stats.get("unbuildable", 0) + 1
                    # a build costs as much as many token steps: charge it to the step budget
                    ctx.steps += FINISH_COST
                    return False
                ctx.result, ctx.built = built
            if ctx.want <= 1:
                return True
            d = self._result(ctx, ctx.steps, ctx.attempt)
            if not d.valid or not ctx.distinct.add(d.graph):
                return False
            ctx.found.append(d)
            ctx.limit += self.bonus
            return len(ctx.found) >= ctx.want
        ctx.steps += 1
        if st.length > ctx.deepest:
            ctx.deepest = st.length
            self.deepest_text = f"{st.graph_text()} (budget {st.a.max_len}, open rings {len(st.rings)}, beam {len(beam)})"
        if ctx.steps > ctx.limit:
            raise _OutOfSteps
        allowed = st.allowed()
        if ctx.forced is not None:  # place a given string: its next token or nothing
            nxt = ctx.forced[st.length] if st.length < len(ctx.forced) else None
            order = [nxt] if nxt in allowed else []
        else:
            if allowed and self.pressure:
                allowed = st.closing(allowed, self.pressure, ctx.soft_end)
            if self.max_open is not None and len(st.rings) >= self.max_open:
                # no new ring while max_open are open (a ring can only close on a chain that
                # comes back to its owner; many at once rarely all do within the budget)
                allowed = [t for t in allowed if not (self.vocab.kind(t)[0] == "ring" and self.vocab.kind(t)[1] not in st.rings)]
            order = self._ordered(ctx, logits, allowed)
        beams = {}
        if ctx.forced is None and st.rings and any(self.vocab.kind(t)[0] == "node" for t in order):
            # a letter that meets a part whose ring is open (so closes it) goes first: rings
            # close as soon as the geometry lets them, not only when the network remembers
            beams = {t: self._next_beam(ctx, beam, t) for t in order
                     if self.vocab.kind(t)[0] == "node" and self._may_close(ctx, beam, self.types[self.vocab.kind(t)[1]])}
            closes = [t for t in order if any(hy.touched for hy in beams.get(t, ()))]
            order = closes + [t for t in order if t not in closes]
        tried = 0
        for t in order:
            if tried >= self.branching:
                break
            nb = beams[t] if t in beams else self._next_beam(ctx, beam, t)
            if not nb:
                continue
            tried += 1
            kind, value = self.vocab.kind(t)
            st.apply(t)
            if kind == "node":
                ctx.types.append(self.types[value])
            nl, nh = self.model.step(torch.tensor([t]), h, z)
            if self._dfs(ctx, z, nl, nh, nb):
                return True
            if kind == "node":
                ctx.types.pop()
            st.undo()
        return False


@dataclass
class _Ctx:
    state: DecodeState
    rng: np.random.Generator
    temperature: float
    soft_end: int | None
    limit: int
    forced: list | None = None  # place_text: the tokens to write
    steps: int = 0
    deepest: int = 0  # the longest prefix reached (diagnostics)
    types: list = field(default_factory=list)  # per part written
    fails: dict = field(default_factory=dict)
    result: Any = None
    reject: Any = None  # graph -> bool: finished graphs that count as dead ends (known ones)
    want: int = 1  # finished strings of distinct graphs to find (per_point)
    attempt: int = 0
    built: Any = None  # finish_check: the shape of ctx.result
    found: list = field(default_factory=list)  # per_point > 1: the Decoded strings found so far
    distinct: Any = field(default_factory=lambda: GraphSet())
