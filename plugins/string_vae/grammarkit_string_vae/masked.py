"""Grammar-constrained decoding: which next tokens keep a shape string valid.

The decoder writes a string token by token. `DecodeState` follows what has been written
(an automaton over the string syntax plus the grammar's topology rules) and `allowed()` lists
the tokens that keep the string completable:

- **syntax** from the open-branch stack: a letter may always come (it attaches to the current
  part), `(` only after a part, `)` only inside a branch that has a part, EOS only at the top
  level, a ring label only right after its part's letter;
- **pending ring closures**: a ring label that is open may close on the current part only if the
  two types may touch, the edge is new (not the part's parent or a part it already closed a
  ring with) and both parts can still end up with allowed neighbourhoods; a new ring is opened
  with the lowest free label (as the encoder writes them) and only by a part that can take
  one more neighbour;
- **each part's remaining neighbour types and counts**: a part's neighbour counts must stay
  inside one of its allowed boxes (`topology.TopologyRules`: exact multisets, count ranges,
  valences). A part is *open* while it can still get children (the current part and the
  owners of open branches); a part that is closed can only gain neighbours through its own open
  ring labels, so its counts plus those must be able to fill a box exactly;
- **a length budget**: `lower_bound()` is an admissible estimate of the tokens still needed
  (EOS, one `)` per open branch, one digit per open ring, one part per missing neighbour or
  missing required type, brackets for an open branch's further children); a token is allowed
  only if the estimate after it still fits in `max_len`.

Local checks alone can still walk into a dead end (every castle part needs two neighbours, so
a string can only end by closing a ring opened earlier). `complete(state)` therefore searches
(depth-first, rules only, bounded) for a whole valid completion. The decoder keeps such a
completion (its *plan*) at every step and takes the network's preferred token only when a
completion after it exists, else the plan's next token, which is valid by construction. So
every decoded string is valid and ends within `max_len` tokens: validity by construction, and
the network steers wherever it can. See docs/string-vae.md.
"""
from __future__ import annotations

import math
from typing import Sequence

from .topology import TopologyRules
from .vocab import EOS, Vocab

__all__ = ["Automaton", "DecodeState", "complete"]

START, ATOM, AFTER, BRANCH = 0, 1, 2, 3  # phases: nothing yet / after a letter or ring label /
# after ')' / after '('
INF = 10**9


class Automaton:
    """Topology rules compiled against a vocabulary and a length budget (tokens incl. EOS)."""

    def __init__(self, rules: TopologyRules, vocab: Vocab, max_len: int):
        self.rules = rules
        self.vocab = vocab
        self.max_len = int(max_len)
        self.T = len(rules.types)
        rindex = {t: k for k, t in enumerate(rules.types)}
        # vocab letter k (alphabet order) -> rules type index, or -1 (a type the rules do not know)
        self.letter_type = [rindex.get(t, -1) for t in vocab.alphabet.types]
        self.type_letter = {k: vocab.letter_id(i) for i, k in enumerate(self.letter_type) if k >= 0}
        self.boxes = [[(b.lo, b.hi, b.total_lo, b.total_hi) for b in rules.boxes.get(k, ())]
                      for k in range(self.T)]
        self.pair_ok = rules.pair_ok
        self.count_hi = {k: hi for k, (lo, hi) in rules.count_limits.items() if hi is not None}
        self.count_lo = {k: lo for k, (lo, hi) in rules.count_limits.items() if lo > 0}
        self.reach = rules.reach
        self.letters = [k for k in range(self.T) if self.boxes[k] and k in self.type_letter]
        # needs_ring[p]: every part a type-p part may get as a child needs a further neighbour
        # besides p, so every new subtree under a type-p part must end in ring closures (a
        # subtree's leaves can only get more neighbours through ring labels)
        self.needs_ring = []
        for p in range(self.T):
            kids = [y for y in self.letters if self.pair_ok[p][y]]
            need = []
            for y in kids:
                e = [0] * self.T
                e[p] = 1
                need.append(self.deficit(y, e, 1, 0))
            self.needs_ring.append(bool(kids) and min(need) >= 1)
        # close_cap[t]: most ring labels a new type-t part can close (all its neighbours but its
        # parent)
        self.close_cap = [max((b[3] for b in self.boxes[t]), default=0) - 1 if t in self.letters else 0
                          for t in range(self.T)]

    def start(self) -> "DecodeState":
        return DecodeState(self)

    # ---- box arithmetic --------------------------------------------------------------------
    def fits(self, k: int, counts: Sequence[int], total: int, wild: int, open_: bool,
             add: int = -1) -> bool:
        """Can a type-k part with these neighbour counts (+1 of type `add`), `wild` open ring
        labels (partners not yet known) end in an allowed box? Open parts may still get more
        children; closed ones get exactly their `wild` ring partners."""
        if add >= 0:
            total += 1
        for lo, hi, tlo, thi in self.boxes[k]:
            if total + wild > thi:
                continue
            need = cap = 0
            ok = True
            for j in range(self.T):
                c = counts[j] + (1 if j == add else 0)
                h = hi[j]
                if c > h:
                    ok = False
                    break
                if lo[j] > c:
                    need += lo[j] - c
                cap += h - c
            if not ok or wild > cap:
                continue
            if open_:
                return True
            if need <= wild and total + wild >= tlo:
                return True
        return False

    def capacity(self, k: int, counts: Sequence[int], total: int, wild: int) -> int:
        """Most further neighbours (beyond the open ring labels) a part could still take."""
        best = -1
        for lo, hi, tlo, thi in self.boxes[k]:
            if total + wild > thi or any(c > h for c, h in zip(counts, hi)):
                continue
            room = sum(h - c for c, h in zip(counts, hi)) - wild
            best = max(best, min(thi - total - wild, room))
        return best

    def deficit(self, k: int, counts: Sequence[int], total: int, wild: int) -> int:
        """Fewest further neighbours (beyond the open ring labels) an open part still needs."""
        best = INF
        for lo, hi, tlo, thi in self.boxes[k]:
            if total + wild > thi:
                continue
            need = cap = 0
            ok = True
            for j in range(self.T):
                c = counts[j]
                if c > hi[j]:
                    ok = False
                    break
                if lo[j] > c:
                    need += lo[j] - c
                cap += hi[j] - c
            if not ok or wild > cap:
                continue
            best = min(best, max(0, max(need, tlo - total) - wild))
        return best


class DecodeState:
    """What has been written so far, with `apply`/`undo` for search."""

    __slots__ = ("a", "ntype", "counts", "total", "wild", "adj", "current", "phase", "stack",
                 "rings", "type_count", "tokens", "_undo")

    def __init__(self, automaton: Automaton):
        self.a = automaton
        self.ntype: list[int] = []
        self.counts: list[list[int]] = []
        self.total: list[int] = []
        self.wild: list[int] = []
        self.adj: list[set[int]] = []
        self.current = -1
        self.phase = START
        self.stack: list[int] = []
        self.rings: dict[int, int] = {}  # label -> the part that opened it
        self.type_count = [0] * automaton.T
        self.tokens: list[int] = []
        self._undo: list[tuple] = []

    @property
    def length(self) -> int:
        return len(self.tokens)

    @property
    def done(self) -> bool:
        return bool(self.tokens) and self.tokens[-1] == EOS

    def is_open(self, v: int) -> bool:
        return v == self.current or v in self.stack

    # ---- transitions ----------------------------------------------------------------------
    def apply(self, tok: int) -> None:
        kind, value = self.a.vocab.kind(tok)
        rec: tuple
        if kind == "eos":
            rec = ("eos",)
        elif kind == "node":
            k = self.a.letter_type[value]
            v = len(self.ntype)
            self.ntype.append(k)
            self.counts.append([0] * self.a.T)
            self.total.append(0)
            self.wild.append(0)
            self.adj.append(set())
            self.type_count[k] += 1
            cur = self.current
            if cur >= 0:
                self._link(cur, v)
            rec = ("node", cur, self.phase)
            self.current = v
            self.phase = ATOM
        elif kind == "open":
            rec = ("open", self.phase)
            self.stack.append(self.current)
            self.phase = BRANCH
        elif kind == "close":
            rec = ("close", self.current, self.phase)
            self.current = self.stack.pop()
            self.phase = AFTER
        elif kind == "ring":
            owner = self.rings.get(value)
            if owner is not None:
                del self.rings[value]
                self._link(owner, self.current)
                self.wild[owner] -= 1
                rec = ("ring-close", value, owner)
            else:
                self.rings[value] = self.current
                self.wild[self.current] += 1
                rec = ("ring-open", value)
        else:
            raise ValueError(f"token {tok} cannot be written")
        self.tokens.append(tok)
        self._undo.append(rec)

    def _link(self, u: int, v: int) -> None:
        self.counts[u][self.ntype[v]] += 1
        self.counts[v][self.ntype[u]] += 1
        self.total[u] += 1
        self.total[v] += 1
        self.adj[u].add(v)
        self.adj[v].add(u)

    def _unlink(self, u: int, v: int) -> None:
        self.counts[u][self.ntype[v]] -= 1
        self.counts[v][self.ntype[u]] -= 1
        self.total[u] -= 1
        self.total[v] -= 1
        self.adj[u].discard(v)
        self.adj[v].discard(u)

    def undo(self) -> None:
        rec = self._undo.pop()
        self.tokens.pop()
        kind = rec[0]
        if kind == "node":
            v = len(self.ntype) - 1
            cur, phase = rec[1], rec[2]
            if cur >= 0:
                self._unlink(cur, v)
            self.type_count[self.ntype[v]] -= 1
            for lst in (self.ntype, self.counts, self.total, self.wild, self.adj):
                lst.pop()
            self.current, self.phase = cur, phase
        elif kind == "open":
            self.stack.pop()
            self.phase = rec[1]
        elif kind == "close":
            self.stack.append(self.current)
            self.current, self.phase = rec[1], rec[2]
        elif kind == "ring-close":
            label, owner = rec[1], rec[2]
            self._unlink(owner, self.current)
            self.wild[owner] += 1
            self.rings[label] = owner
        elif kind == "ring-open":
            del self.rings[rec[1]]
            self.wild[self.current] -= 1

    # ---- what may come next ---------------------------------------------------------------
    def _final_ok(self) -> bool:
        for k, lo in self.a.count_lo.items():
            if self.type_count[k] < lo:
                return False
        for a_, b_ in self.a.reach:
            if self.type_count[a_] and not self.type_count[b_]:
                return False
        return True

    def local_allowed(self) -> list[int]:
        """Tokens that keep every part's neighbourhood completable (no budget check)."""
        a = self.a
        out: list[int] = []
        ph, cur = self.phase, self.current
        T = a.T
        if ph == START:
            zeros = [0] * T
            for k in a.letters:
                if self.type_count[k] < a.count_hi.get(k, INF) and a.fits(k, zeros, 0, 0, True):
                    out.append(a.type_letter[k])
            return out
        if self.done:
            return out
        ct = self.ntype[cur]
        cnt, tot, wld = self.counts[cur], self.total[cur], self.wild[cur]
        if ph in (ATOM, AFTER) and not self.stack and not self.rings \
                and a.fits(ct, cnt, tot, wld, False) and self._final_ok():
            out.append(EOS)
        e_ct = [0] * T
        e_ct[ct] = 1
        stays_open = ph == BRANCH
        can_branch = False
        for k in a.letters:
            if not a.pair_ok[ct][k] or self.type_count[k] >= a.count_hi.get(k, INF):
                continue
            if not a.fits(k, e_ct, 1, 0, True):
                continue
            if a.fits(ct, cnt, tot, wld, stays_open, add=k):
                out.append(a.type_letter[k])
            if ph in (ATOM, AFTER) and not can_branch and a.fits(ct, cnt, tot, wld, True, add=k):
                can_branch = True
        if can_branch:
            out.append(a.vocab.open_id)
        if self.stack and ph in (ATOM, AFTER) and a.fits(ct, cnt, tot, wld, False):
            out.append(a.vocab.close_id)
        if ph == ATOM:
            adj = self.adj[cur]
            for label, o in sorted(self.rings.items()):
                if o == cur or o in adj:
                    continue
                to = self.ntype[o]
                if not a.pair_ok[to][ct]:
                    continue
                if a.fits(to, self.counts[o], self.total[o], self.wild[o] - 1, self.is_open(o), add=ct) \
                        and a.fits(ct, cnt, tot, wld, True, add=to):
                    out.append(a.vocab.ring_id(label))
            free = next((r for r in range(1, a.vocab.rings + 1) if r not in self.rings), None)
            if free is not None and a.fits(ct, cnt, tot, wld + 1, True):
                out.append(a.vocab.ring_id(free))
        return out

    def lower_bound(self) -> int:
        """Admissible estimate of the tokens still needed to end validly (EOS included)."""
        a = self.a
        if self.done:
            return 0
        if self.phase == START:
            return 2
        cur = self.current
        cur_cap = a.capacity(self.ntype[cur], self.counts[cur], self.total[cur], self.wild[cur])
        # open rings the current part may still close itself (right after its letter, as far
        # as it has room): they fill its neighbourhood and need no new part
        if self.phase == ATOM:
            adj = self.adj[cur]
            ct = self.ntype[cur]
            closable = min(max(cur_cap, 0), sum(
                1 for o in self.rings.values()
                if o != cur and o not in adj and a.pair_ok[self.ntype[o]][ct]
                and a.fits(self.ntype[o], self.counts[o], self.total[o], self.wild[o] - 1, self.is_open(o), add=ct)
                and a.fits(ct, self.counts[cur], self.total[cur], self.wild[cur], True, add=self.ntype[o])))
        else:
            closable = 0
        need_nodes = 0
        brackets = 0
        ringed = 0  # new subtrees that need a ring endpoint each
        for v in ([cur] + [o for o in self.stack if o != cur]):
            d = a.deficit(self.ntype[v], self.counts[v], self.total[v], self.wild[v])
            if d >= INF:
                return INF
            if v == cur:
                d = max(0, d - closable)
            else:
                brackets += 2 * max(0, d - 1)
            need_nodes += d
            if a.needs_ring[self.ntype[v]]:
                ringed += d
        count_def = sum(max(0, lo - self.type_count[k]) for k, lo in a.count_lo.items())
        count_def += len({b_ for a_, b_ in a.reach if self.type_count[a_] and not self.type_count[b_]})
        rings = len(self.rings)
        host = 1 if rings > closable else 0  # some ring needs a new part to close it
        # typed closers: every ring the current part does not close needs a new part of a type
        # its owner can still take; such a part closes at most close_cap of them
        shares = []
        for o in self.rings.values():
            to = self.ntype[o]
            best = 0
            for t in a.letters:
                if a.close_cap[t] > best and a.pair_ok[to][t] and \
                        a.fits(to, self.counts[o], self.total[o], self.wild[o] - 1, self.is_open(o), add=t):
                    best = a.close_cap[t]
            shares.append(1.0 / best if best > 0 else math.inf)
        shares.sort()
        if closable:
            shares = shares[:-closable]  # the current part takes the dearest ones
        closers = math.ceil(sum(shares) - 1e-9) if shares else 0
        if closers >= INF or any(math.isinf(x) for x in shares):
            return INF
        # ring endpoints beyond the open rings cost a token each (a new ring: two tokens, two ends)
        extra_ends = max(0, ringed - rings)
        new_nodes = max(need_nodes, count_def, host, closers)
        if new_nodes:
            # new parts can only hang below an open part with room for one more neighbour
            if cur_cap <= 0 and not any(
                    a.capacity(self.ntype[o], self.counts[o], self.total[o], self.wild[o]) > 0
                    for o in self.stack if o != cur):
                return INF
        return 1 + len(self.stack) + rings + brackets + extra_ends + new_nodes

    def allowed(self) -> list[int]:
        """Tokens that keep the string completable locally and within the length budget."""
        out = []
        budget = self.a.max_len
        for t in self.local_allowed():
            if t == EOS:
                if self.length + 1 <= budget:
                    out.append(t)
                continue
            self.apply(t)
            ok = self.length + self.lower_bound() <= budget
            self.undo()
            if ok:
                out.append(t)
        return out

    def closing(self, allowed: list[int], slack: int, soft_end: int | None = None) -> list[int]:
        """End-game pressure, a steering heuristic of the decoder (not a rule: every token it
        drops was allowed). With at most `slack` tokens to spare beyond the lower bound, tokens
        that open something (a new ring label, a branch) give way to the others; with at most
        half of that, a token that closes something (a ring label, `)`, the end) is taken
        whenever one is allowed. With `soft_end` (a length training strings seldom exceed), the
        string is treated as having no tokens to spare from there on."""
        lb = self.lower_bound()
        spare = self.a.max_len - self.length - lb
        if soft_end is not None:  # past the length where training strings usually end
            spare = min(spare, max(0, soft_end - self.length - lb) + slack // 2)
        if spare > slack:
            return allowed
        v = self.a.vocab
        if spare <= slack // 2:
            closers = [t for t in allowed if t in (EOS, v.close_id) or (v.kind(t)[0] == "ring" and v.kind(t)[1] in self.rings)]
            if closers:
                return closers
            if self.rings:  # letters right after which an open ring label can close
                ahead = []
                for t in allowed:
                    if v.kind(t)[0] != "node":
                        continue
                    self.apply(t)
                    if any(v.kind(u)[0] == "ring" and v.kind(u)[1] in self.rings for u in self.local_allowed()):
                        ahead.append(t)
                    self.undo()
                if ahead:
                    return ahead
        keep = [t for t in allowed if t != v.open_id and not (v.kind(t)[0] == "ring" and v.kind(t)[1] not in self.rings)]
        return keep or allowed

    def signature(self) -> tuple:
        """Everything that decides whether the state can still be completed (for memoising)."""
        live = set(self.stack)
        if self.current >= 0:
            live.add(self.current)
        live.update(self.rings.values())
        nodes = tuple((v, self.ntype[v], tuple(self.counts[v]), self.wild[v],
                       frozenset(self.adj[v]) if v == self.current else None) for v in sorted(live))
        return (self.length, self.phase, self.current, tuple(self.stack),
                tuple(sorted(self.rings.items())), nodes,
                tuple(self.type_count) if (self.a.count_hi or self.a.count_lo or self.a.reach) else ())

    def graph_text(self) -> str:
        return self.a.vocab.decode(self.tokens)


def _order(state: DecodeState, tokens: list[int]) -> list[tuple[int, int]]:
    """(lower bound after the token, token) pairs, most promising first: the fewest tokens
    still needed, then EOS, closing rings, ')', letters, opening rings, '('."""
    v = state.a.vocab
    rank = {"eos": 0, "close": 2, "node": 3, "open": 6}
    out = []
    for t in tokens:
        kind, value = v.kind(t)
        r = (1 if value in state.rings else 5) if kind == "ring" else rank[kind]
        state.apply(t)
        lb = state.lower_bound()
        state.undo()
        out.append((lb, r, t))
    out.sort()
    return [(lb, t) for lb, _, t in out]


def complete(state: DecodeState, *, max_expansions: int = 20000) -> list[int] | None:
    """A valid completion of `state` (tokens up to and including EOS) within the length
    budget, or None if none was found within `max_expansions` token applications.

    Iterative deepening (IDA*) on the completion's length with `lower_bound` as the
    admissible estimate: short completions are tried first and a branch is cut as soon as
    its estimate exceeds the current bound; dead states are remembered per remaining bound.
    The state is left as it was."""
    if state.done:
        return []
    room = state.a.max_len - state.length
    failed: dict[tuple, int] = {}  # signature -> largest remaining bound known to fail
    budget = [max_expansions]

    def search(bound: int) -> list[int] | None:
        # bound: tokens we may still write (EOS included)
        allowed = state.allowed()
        if EOS in allowed:
            return [EOS]
        sig = state.signature()[1:]  # without the length: `bound` says how much room is left
        if failed.get(sig, -1) >= bound:
            return None
        exhausted = True
        for lb, t in _order(state, [t for t in allowed if t != EOS]):
            if lb + 1 > bound:
                exhausted = exhausted and True
                break  # sorted by lb: the rest cannot fit either
            if budget[0] <= 0:
                exhausted = False
                break
            budget[0] -= 1
            state.apply(t)
            rest = search(bound - 1)
            state.undo()
            if rest is not None:
                return [t] + rest
        if exhausted and budget[0] > 0:
            failed[sig] = max(failed.get(sig, -1), bound)
        return None

    bound = state.lower_bound()
    while bound <= room and budget[0] > 0:
        found = search(bound)
        if found is not None:
            return found
        bound += 1 if bound < 8 else max(1, bound // 4)
    return None
