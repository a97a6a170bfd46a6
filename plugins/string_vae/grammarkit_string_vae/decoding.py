"""Turning latent points into strings: free decoding (the paper) and masked decoding (valid by
construction).

- `free`: the decoder picks the most likely token (or samples) at every step, as in the paper;
  the string is then checked against the grammar and invalid ones are counted as such.
- `masked`: at every step the logits of tokens that `masked.DecodeState.allowed()` rules out
  are removed (and near the end of the budget, tokens that open rings or branches give way to
  others: `DecodeState.closing`). If a string walks into a dead end (no token allowed:
  possible with cycles, see masked.py) it is *repaired*: 1. depth-first backtracking over the
  network's next-best allowed tokens (chronological, a bounded number of token expansions);
  2. the same latent point decoded again with sampled tokens (twice); 3. a rules-only
  completion search (`masked.complete`) from the dead end or from before one of the last
  tokens that opened something. Every string that comes out is checked against the grammar
  again.

Latent points are decoded in batches; everything is deterministic for a given seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import torch

from .graphs import TypedGraph
from .masked import Automaton, DecodeState, complete
from .strings import Alphabet, ShapeStringError, decode
from .topology import TopologyRules
from .vocab import EOS, PAD, Vocab

__all__ = ["Decoded", "check_text", "decode_latents"]

MODES = ("free", "masked")


@dataclass
class Decoded:
    text: str
    valid: bool
    graph: TypedGraph | None = None
    error: str | None = None
    backtracks: int = 0  # token expansions spent repairing a dead end (masked)
    repaired: str | None = None  # masked dead ends: None, "backtrack", "resample", "rules" or "failed"
    placement: Any = None  # placed decoding: frames, variants and categories (placed.Placement)
    stage: str | None = None  # invalid: where it failed ("decoding", "3D placement")
    more: list = field(default_factory=list)  # placed decoding with `per_point` > 1: further finished strings


def check_text(text: str, alphabet: Alphabet, rules: TopologyRules) -> Decoded:
    """Parse and check one string."""
    try:
        parsed = decode(text, alphabet)
    except ShapeStringError as exc:
        return Decoded(text, False, None, str(exc))
    problems = rules.check(parsed.graph, limit=1)
    if problems:
        return Decoded(text, False, parsed.graph, problems[0].message)
    return Decoded(text, True, parsed.graph)


def _choose(logits: torch.Tensor, temperature: float, rng: np.random.Generator) -> int:
    if temperature <= 0:
        return int(torch.argmax(logits))
    p = torch.softmax(logits.double() / temperature, dim=0).numpy()
    p = p / p.sum()
    return int(rng.choice(len(p), p=p))


@torch.no_grad()
def decode_latents(model, z: torch.Tensor, *, vocab: Vocab, rules: TopologyRules, mode: str = "masked",
                   temperature: float = 0.0, seed: int = 0, batch_size: int = 256,
                   repair_expansions: int = 200, rules_expansions: int = 1500, pressure: int | None = 40,
                   resamples: int = 2, budget: float = 1.2, soft_end: int | None = None) -> list[Decoded]:
    """Decode latent points `z` (N, latent) into checked strings. Masked decoding may write up
    to `budget` times the longest training string (the length budget of the masks); from
    `soft_end` tokens on (default: the model's `soft_end`, a length 90% of its training
    strings stay within) it closes rather than opens (`DecodeState.closing`)."""
    if soft_end is None:
        soft_end = getattr(model, "soft_end", None)
    if mode not in MODES:
        raise ValueError(f"decoding mode must be one of {MODES}, got {mode!r}")
    out: list[Decoded] = []
    auto = Automaton(rules, vocab, int(math.ceil(budget * model.config.max_len))) if mode == "masked" else None
    for start in range(0, z.shape[0], batch_size):
        zb = z[start:start + batch_size]
        rng = np.random.default_rng([seed, start])
        out.extend(_decode_batch(model, zb, vocab, rules, auto, temperature, rng, repair_expansions,
                                 rules_expansions, pressure, resamples, soft_end))
    return out


def _pass(model, z: torch.Tensor, auto: Automaton | None, temperature: float, rng: np.random.Generator,
          pressure: int | None, soft_end: int | None = None):
    """One batched decoding pass: tokens, states, finished flags, per-step hiddens and logits."""
    B = z.shape[0]
    max_len = auto.max_len if auto is not None else model.config.max_len
    logits, h = model.start(z)
    tokens: list[list[int]] = [[] for _ in range(B)]
    states: list[DecodeState] | None = [auto.start() for _ in range(B)] if auto is not None else None
    finished = [False] * B
    dead = [False] * B
    hist_h: list[torch.Tensor] = []
    hist_logits: list[torch.Tensor] = []
    for _step in range(max_len):
        if auto is not None:
            hist_h.append(h)
            hist_logits.append(logits)
        nxt = torch.full((B,), PAD, dtype=torch.long)
        any_active = False
        for i in range(B):
            if finished[i] or dead[i]:
                continue
            row = logits[i]
            if states is not None:
                allowed = states[i].allowed()
                if pressure is not None and allowed:
                    allowed = states[i].closing(allowed, pressure, soft_end)
                if not allowed:
                    dead[i] = True
                    continue
                masked = torch.full_like(row, float("-inf"))
                idx = torch.tensor(allowed, dtype=torch.long)
                masked[idx] = row[idx]
                row = masked
            else:
                row = row.clone()
                row[:EOS] = float("-inf")  # PAD and BOS are never written
                row[EOS + 1] = float("-inf")  # UNK (index 3) neither
            t = _choose(row, temperature, rng)
            tokens[i].append(t)
            if states is not None:
                states[i].apply(t)
            if t == EOS:
                finished[i] = True
            else:
                nxt[i] = t
                any_active = True
        if not any_active:
            break
        logits, h = model.step(nxt, h, z)
    return tokens, states, finished, hist_h, hist_logits


def _decode_batch(model, z: torch.Tensor, vocab: Vocab, rules: TopologyRules, auto: Automaton | None,
                  temperature: float, rng: np.random.Generator, repair_expansions: int,
                  rules_expansions: int, pressure: int | None = 40, resamples: int = 2,
                  soft_end: int | None = None) -> list[Decoded]:
    B = z.shape[0]
    max_len = model.config.max_len
    tokens, states, finished, hist_h, hist_logits = _pass(model, z, auto, temperature, rng,
                                                          pressure if auto is not None else None, soft_end)
    alphabet = vocab.alphabet
    if auto is None:
        return [check_text(vocab.decode(tokens[i]), alphabet, rules) if finished[i] else
                Decoded(vocab.decode(tokens[i]), False, None, f"no end of string within {max_len} tokens")
                for i in range(B)]
    how: list[str | None] = [None] * B
    spent = [0] * B
    for i in range(B):  # 1. the network's next-best tokens, backtracking from the dead end
        if not finished[i]:
            finished[i], spent[i] = _repair_backtrack(model, z[i:i + 1], states[i], hist_h, hist_logits, i,
                                                      repair_expansions)
            how[i] = "backtrack"
    for r in range(resamples):  # 2. decode the same latent point again, sampling tokens
        left = [i for i in range(B) if not finished[i]]
        if not left:
            break
        _t, st2, fin2, _h, _l = _pass(model, z[left], auto, max(temperature, 0.8), rng, pressure, soft_end)
        for j, i in enumerate(left):
            if fin2[j]:
                states[i], finished[i], how[i] = st2[j], True, "resample"
    results: list[Decoded] = []
    for i in range(B):
        state = states[i]
        if not finished[i]:  # 3. the rules-only completion search
            if _repair_rules(state, rules_expansions):
                how[i] = "rules"
            else:
                results.append(Decoded(state.graph_text(), False, None,
                                       "masked decoding found no valid completion", spent[i], "failed"))
                continue
        d = check_text(state.graph_text(), alphabet, rules)
        d.backtracks, d.repaired = spent[i], how[i]
        if not d.valid:  # pragma: no cover - the automaton and the checker disagree: a bug
            d.error = f"masked decoding produced an invalid string ({d.error})"
        results.append(d)
    return results


def _repair_backtrack(model, z: torch.Tensor, state: DecodeState, hist_h: Sequence[torch.Tensor],
                      hist_logits: Sequence[torch.Tensor], row: int, budget: int) -> tuple[bool, int]:
    """Chronological backtracking from a dead end, trying the network's next-best allowed
    tokens first, at most `budget` token expansions. On success `state` holds the string."""
    left = [budget]
    failed: set[tuple] = set()
    original = list(state.tokens)

    def dfs(h: torch.Tensor, logits: torch.Tensor) -> bool:
        allowed = state.allowed()
        if not allowed:
            return False
        sig = state.signature()
        if sig in failed:
            return False
        for t in sorted(allowed, key=lambda t: -float(logits[t])):
            if left[0] <= 0:
                return False
            left[0] -= 1
            state.apply(t)
            if t == EOS:
                return True
            lg, h2 = model.step(torch.tensor([t]), h, z)
            if dfs(h2, lg[0]):
                return True
            state.undo()
        if left[0] > 0:
            failed.add(sig)
        return False

    for back in range(1, len(original) + 1):
        if left[0] <= 0:
            break
        state.undo()
        pos = len(original) - back
        logits = hist_logits[pos][row]
        h = hist_h[pos][:, row:row + 1]
        tried = original[pos]
        for t in sorted(state.allowed(), key=lambda t: -float(logits[t])):
            if t == tried or left[0] <= 0:
                continue
            left[0] -= 1
            state.apply(t)
            if t == EOS:
                return True, budget - left[0]
            lg, h2 = model.step(torch.tensor([t]), h, z)
            if dfs(h2, lg[0]):
                return True, budget - left[0]
            state.undo()
    # restore the dead-end string for the next repair
    while state.tokens:
        state.undo()
    for t in original:
        state.apply(t)
    return False, budget - left[0]


def _repair_rules(state: DecodeState, expansions: int) -> bool:
    """Complete the dead-end string, or a prefix of it, by the rules-only search. Prefixes are
    tried from the longest: the dead end itself, then just before each of the last few tokens
    that opened something (a ring label or a branch: what makes a string hard to finish),
    then half and none of it."""
    original = list(state.tokens)
    v = state.a.vocab
    points = [len(original)]
    probe = state.a.start()
    openers = []
    for i, t in enumerate(original):
        kind, value = v.kind(t)
        if t == v.open_id or (kind == "ring" and value not in probe.rings):
            openers.append(i)
        probe.apply(t)
    points += sorted(openers, reverse=True)[:6]
    points += [len(original) // 2, 0]
    for cut in dict.fromkeys(points):
        while state.length > cut:
            state.undo()
        plan = complete(state, max_expansions=expansions)
        if plan is not None:
            for t in plan:
                state.apply(t)
            return True
    while state.tokens:
        state.undo()
    for t in original:
        state.apply(t)
    return False
