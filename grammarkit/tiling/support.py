"""Support (Liu et al. 2015, section 5.3): is every part carried down to the ground?

Liu et al. detect "the horizontal support relation between neighboring nodes by fitting a
plane to their contact area and check whether the normal is parallel to the upright vector",
then walk heights up from the ground-touching nodes. Here:

- a contact is **from below** when its normal points along the up axis: part `a` *carries*
  part `b` when `b` rests on `a`. For two box parts (meshes equal to their axis-aligned boxes)
  this is exact: the axis along which the boxes are separated most (their contact plane's
  normal) is the up axis, and `b` is the higher one. For other parts it is a lift test with
  the exact contact narrow phase: lifted by `LIFT` x the contact tolerance, `b` no longer
  touches `a` (while `a` lifted by as much still does), i.e. the contact normal has an upward
  component and nothing holds `b` sideways at that contact;
- a part is **on the ground** when its lowest point lies within the contact tolerance of the
  ground plane: the examples' minimum along the up axis (`constraint grounded(ground=0)`; learn
  writes it). A part reaching below the ground by more than the tolerance is **sunk**;
- `grounded` holds when no part is sunk and every part is reached from a part on the ground
  through contacts from below (a chain of parts each resting on the previous one).
  `grounded(sideways=true)` also lets support pass through side contacts (rigid joints, as a
  ball track's pieces joined end to end between pillars), never downwards: a pillar column
  hanging under a track piece is still not carried.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["LIFT", "carry_directions", "support_problems"]

# Lift distance of the non-box test, in contact tolerances (> 1: a lifted part must clear the
# tolerance band; small: parts that overlap sideways by more than a few tolerances stay joined).
LIFT = 3.0


def _axis(up: np.ndarray) -> tuple[int, float]:
    k = int(np.argmax(np.abs(up)))
    return k, float(np.sign(up[k]) or 1.0)


def carry_directions(lo: np.ndarray, hi: np.ndarray, boxy: np.ndarray, edges: np.ndarray,
                     tolerance: float, up: np.ndarray, *, parts: Sequence[Any] | None = None,
                     cache: dict | None = None, keys: Sequence | None = None) -> np.ndarray:
    """Per contact (a, b) of `edges` (E, 2): +1 when a carries b, -1 when b carries a, 0 when
    they touch side by side. `parts` (Part objects indexed like lo/hi) are needed for pairs
    that are not both boxes; `cache`/`keys` keep their verdicts across calls (by part keys)."""
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
        from .contacts import lifted_gap

        from .contacts import PoseKeys

        delta = np.zeros(3)
        delta[k] = sign * LIFT * tolerance
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
            up_b = lifted_gap(parts[ia], parts[ib], tolerance, delta, solids, ia, ib) > tolerance
            up_a = lifted_gap(parts[ib], parts[ia], tolerance, delta, solids, ib, ia) > tolerance
            verdict = 1 if up_b and not up_a else -1 if up_a and not up_b else 0
            if up_a and up_b:  # a point graze: the higher part rests on the lower one
                verdict = 1 if height_b[e] >= height_a[e] else -1
            out[e] = verdict
            if pose is not None:
                seen[pose] = verdict
            if cache is not None and key is not None:
                cache[key] = verdict
    return out


def support_problems(lo: np.ndarray, hi: np.ndarray, carry: np.ndarray, edges: np.ndarray,
                     tolerance: float, up: np.ndarray, ground: float, *, sideways: bool = False
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(sunk part indices, unsupported part indices): parts below the ground plane (by more than
    the tolerance), and parts no chain of contacts from below (and, with `sideways`, side
    contacts) reaches from a part standing on the ground."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order

    n = len(lo)
    k, sign = _axis(up)
    bottom = np.where(sign > 0, lo[:, k], -hi[:, k]) if n else np.zeros(0)
    g = sign * ground
    sunk = np.flatnonzero(bottom < g - tolerance)
    on_ground = np.flatnonzero(np.abs(bottom - g) <= tolerance)
    if n == 0:
        return sunk, np.zeros(0, dtype=np.int64)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    src, dst = [], []
    up_edges = carry > 0
    src.append(edges[up_edges, 0]); dst.append(edges[up_edges, 1])
    down_edges = carry < 0
    src.append(edges[down_edges, 1]); dst.append(edges[down_edges, 0])
    if sideways:
        side = carry == 0
        src += [edges[side, 0], edges[side, 1]]
        dst += [edges[side, 1], edges[side, 0]]
    # one extra node (n) stands for the ground, carrying every part that stands on it
    src.append(np.full(len(on_ground), n)); dst.append(on_ground)
    s, d = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(s), dtype=np.int8), (s, d)), shape=(n + 1, n + 1)).tocsr()
    reached = np.zeros(n + 1, dtype=bool)
    reached[breadth_first_order(graph, n, directed=True, return_predecessors=False)] = True
    return sunk, np.flatnonzero(~reached[:n])
