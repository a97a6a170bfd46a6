"""Support (Liu et al. 2015, section 5.3): is every part carried down to the ground?

Liu et al. detect "the horizontal support relation between neighboring nodes by fitting a
plane to their contact area and check whether the normal is parallel to the upright vector",
then walk heights up from the ground-touching nodes. Here:

- a contact is **from below** when its normal points along the up axis: part `a` *carries*
  part `b` when `b` rests on `a`. For two box parts (meshes equal to their axis-aligned boxes)
  this is exact: the axis along which the boxes are separated most (their contact plane's
  normal) is the up axis, and `b` is the higher one. For other parts it is a lift test with
  the exact contact narrow phase: `b` lifted by `LIFT_FRACTION` x the smaller part's diagonal
  moves away from `a` by more than a third of the lift (the contact normal's up component is
  above 1/3, a slope under about 70 degrees), while `a` lifted as much does not. The verdict
  depends on the two parts' geometry only, **never on the contact tolerance**: so widening
  the tolerance can only add contacts and ground contacts, and support results are monotone
  in it (a part carried at tolerance t is carried at every larger one);
- a part is **on the ground** when its lowest point lies within the contact tolerance of the
  ground plane: the examples' minimum along the up axis (`constraint grounded(ground=0)`; learn
  writes it). A part reaching below the ground by more than the tolerance is **sunk**;
- `grounded` holds when no part is sunk and every part is reached from a part on the ground
  through contacts from below (a chain of parts each resting on the previous one).
  `grounded(sideways=true)` also lets support pass through side contacts (rigid joints, as a
  ball track's pieces joined end to end between pillars), never downwards: a pillar column
  hanging under a track piece is still not carried. `max_span=K` bounds the **sideways runs**:
  a run is a connected group of parts held only sideways (no carried part below them), such as
  the track pieces hung between two pillars, or off one; a run of more than K parts is not
  carried, and neither is anything that needs it.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["LIFT_FRACTION", "carry_directions", "sideways_runs", "support_problems"]

# Lift distance of the non-box test, as a fraction of the smaller part's diagonal: large enough
# to clear float noise and small surface waviness, small enough that a part overlapping its
# neighbour sideways by a few millimetres stays joined (reads as a side contact).
LIFT_FRACTION = 0.01
# a lifted part must move away by more than this share of the lift to rest on the other part
_CLEAR_SHARE = 1.0 / 3.0


def _axis(up: np.ndarray) -> tuple[int, float]:
    k = int(np.argmax(np.abs(up)))
    return k, float(np.sign(up[k]) or 1.0)


def carry_directions(lo: np.ndarray, hi: np.ndarray, boxy: np.ndarray, edges: np.ndarray,
                     tolerance: float, up: np.ndarray, *, parts: Sequence[Any] | None = None,
                     cache: dict | None = None, keys: Sequence | None = None) -> np.ndarray:
    """Per contact (a, b) of `edges` (E, 2): +1 when a carries b, -1 when b carries a, 0 when
    they touch side by side. `parts` (Part objects indexed like lo/hi) are needed for pairs
    that are not both boxes; `cache`/`keys` keep their verdicts across calls (by part keys).
    `tolerance` only bounds the distance queries: the verdicts do not depend on it."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    out = np.zeros(len(edges), dtype=np.int8)
    if len(edges) == 0:
        return out
    k, sign = _axis(up)
    a, b = edges[:, 0], edges[:, 1]
    height_a = sign * (lo[a, k] + hi[a, k]) / 2
    height_b = sign * (lo[b, k] + hi[b, k]) / 2
    both = boxy[a] & boxy[b]
    if both.any():
        ia, ib = a[both], b[both]
        sep = np.maximum(lo[ia] - hi[ib], lo[ib] - hi[ia])  # (m, 3): per-axis separation
        others = np.delete(sep, k, axis=1).max(axis=1)
        vertical = sep[:, k] > others  # ties (an edge or corner graze) are side contacts
        out[both] = np.where(vertical, np.where(height_b[both] >= height_a[both], 1, -1), 0)
    rest = np.flatnonzero(~both)
    if len(rest):
        if parts is None:
            raise ValueError("carry_directions: non-box parts need `parts`")
        from .contacts import PoseKeys, lifted_gap

        diag = np.linalg.norm(hi - lo, axis=1)
        solids: dict[int, Any] = {}  # manifold3d solids built once per part in this call
        # contacts between rigid copies in the same relative pose (and the same pose relative to
        # up) get the same verdict: measured once (a 1,000-column model has a few such poses)
        pose_keys = PoseKeys(parts, tolerance) if keys is None else None
        seen: dict = {}
        for e in rest:
            ia, ib = int(a[e]), int(b[e])
            key = (keys[ia], keys[ib]) if keys is not None else None
            if cache is not None and key is not None and key in cache:
                out[e] = cache[key]
                continue
            pose = pose_keys.pair(ia, ib, with_up=True) if pose_keys is not None else None
            if pose is not None and pose in seen:
                out[e] = seen[pose]
                continue
            lift = LIFT_FRACTION * float(min(diag[ia], diag[ib]) or 1.0)
            delta = np.zeros(3)
            delta[k] = sign * lift
            # the query cap covers every distance measured (touching: gap <= tolerance), so the
            # values, and the verdict, are the same whatever the tolerance
            cap = tolerance + 2.0 * lift
            rest_gap = lifted_gap(parts[ia], parts[ib], cap, np.zeros(3), solids, ia, ib)
            up_b = lifted_gap(parts[ia], parts[ib], cap, delta, solids, ia, ib) - rest_gap > _CLEAR_SHARE * lift
            up_a = lifted_gap(parts[ib], parts[ia], cap, delta, solids, ib, ia) - rest_gap > _CLEAR_SHARE * lift
            verdict = 1 if up_b and not up_a else -1 if up_a and not up_b else 0
            if up_a and up_b:  # a point graze: the higher part rests on the lower one
                verdict = 1 if height_b[e] >= height_a[e] else -1
            out[e] = verdict
            if pose is not None:
                seen[pose] = verdict
            if cache is not None and key is not None:
                cache[key] = verdict
    return out


def _reach(n: int, src: np.ndarray, dst: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Mask of the nodes reached from `starts` along the directed edges src -> dst."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order

    s = np.concatenate([src, np.full(len(starts), n)])
    d = np.concatenate([dst, starts])
    graph = coo_matrix((np.ones(len(s), dtype=np.int8), (s, d)), shape=(n + 1, n + 1)).tocsr()
    reached = np.zeros(n + 1, dtype=bool)
    reached[breadth_first_order(graph, n, directed=True, return_predecessors=False)] = True
    return reached[:n]


def sideways_runs(n: int, carry: np.ndarray, edges: np.ndarray, on_ground: np.ndarray, *,
                  sideways: bool = True, max_span: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(carried mask, per-part run length, per-part too-long mask).

    A carried part is *held only sideways* when none of the parts it rests on is carried (and
    it does not stand on the ground); a *run* is a connected group of such parts along side
    contacts, and each of its parts gets the run's size (0 for parts carried from below). With
    `max_span`, the parts of a longer run are taken out (they carry nothing) and support is
    recomputed, until every run fits: a run hung off one pillar cannot borrow support from a
    run that is itself too long."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    carry = np.asarray(carry).reshape(-1)
    # directed edges carrier -> carried, and side contacts (both ways when sideways)
    vs = np.concatenate([edges[carry > 0, 0], edges[carry < 0, 1]])
    vd = np.concatenate([edges[carry > 0, 1], edges[carry < 0, 0]])
    side = edges[carry == 0] if sideways else edges[:0]
    banned = np.zeros(n, dtype=bool)
    grounded = np.zeros(n, dtype=bool)
    grounded[on_ground] = True
    while True:
        ok_v = ~banned[vs] & ~banned[vd]
        ok_s = ~banned[side[:, 0]] & ~banned[side[:, 1]]
        s = side[ok_s]
        reached = _reach(n, np.concatenate([vs[ok_v], s[:, 0], s[:, 1]]),
                         np.concatenate([vd[ok_v], s[:, 1], s[:, 0]]), np.flatnonzero(grounded & ~banned))
        below = grounded.copy()
        below[vd[ok_v][reached[vs[ok_v]]]] = True
        held = reached & ~below
        run = np.zeros(n, dtype=np.int64)
        if held.any():
            hs = s[held[s[:, 0]] & held[s[:, 1]]]
            graph = coo_matrix((np.ones(len(hs), dtype=np.int8), (hs[:, 0], hs[:, 1])), shape=(n, n))
            _, label = connected_components(graph, directed=False)
            size = np.bincount(label[held], minlength=n)
            run[held] = size[label[held]]
        too = held & (run > max_span) if max_span is not None else held & False
        if not too.any():
            return reached, np.where(reached, run, -1), banned
        banned |= too


def support_problems(lo: np.ndarray, hi: np.ndarray, carry: np.ndarray, edges: np.ndarray,
                     tolerance: float, up: np.ndarray, ground: float, *, sideways: bool = False,
                     max_span: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(sunk part indices, unsupported part indices, per-part sideways runs, parts in too long a
    run): parts below the ground plane (by more than the tolerance), parts no chain of
    contacts from below (and, with `sideways`, side contacts, in runs of at most `max_span`
    parts) reaches from a part standing on the ground, each part's run length
    (`sideways_runs`; -1: not carried), and the parts taken out for a run over `max_span`."""
    n = len(lo)
    k, sign = _axis(up)
    bottom = np.where(sign > 0, lo[:, k], -hi[:, k]) if n else np.zeros(0)
    g = sign * ground
    sunk = np.flatnonzero(bottom < g - tolerance)
    on_ground = np.flatnonzero(np.abs(bottom - g) <= tolerance)
    empty = np.zeros(0, dtype=np.int64)
    if n == 0:
        return sunk, empty, empty, empty
    reached, run, banned = sideways_runs(n, carry, edges, on_ground, sideways=sideways, max_span=max_span)
    return sunk, np.flatnonzero(~reached), run, np.flatnonzero(banned)
