"""The default mode's closing solids (`surfaces="solid"`): a volume comp(f) consumes stays as
the solid its faces are views of (Derivation.add_closing), but only where it stands for faces
that survive (CGA shows only what the comp's face branches end in)."""

from __future__ import annotations

from typing import Any

__all__ = ["drop_unspanned_closings"]

#: the reach of the surviving terminals (below) in numpy, one array pass over every (terminal,
#: closing above it) pair instead of Python loops over their corners (candler: 1.0 s -> ~0.05 s
#: of CPU under the profiler). The corners are the same operations in the same order; the
#: projections differ from Python's compensated sum() by rounding at most, far below the 1 mm
#: tolerance they are compared with. False restores the loops (benchmarks/bench_prt.py --prior).
NUMPY_REACH = True
#: below this many terminals the loops are cheaper than building the arrays (a one-volume
#: package: ~0.2 ms of numpy set-up against microseconds)
NUMPY_REACH_MIN = 64


def drop_unspanned_closings(ctx: Any) -> None:
    """`surfaces="solid"`, before the union: a closing solid stands for the faces of its
    volume that survive. CGA shows only what the comp(f)'s face branches end in; if every
    selected face ends in NIL, or what survives of them (terminals descending from the
    comp, faces or volumes made from them) does not reach across the volume along each of
    its axes (only the bottom face kept, or extruded 0.3 m into a slab, under a 5 m
    volume), the closing solid is taken out: the surviving faces are then off every solid
    and become slabs of their own (compose), so the model keeps CGA's visible extent and
    stays watertight. A closing with an opening or a recess cut into it is kept."""
    if not ctx.closings:
        return
    by_node = {c[1]: c for c in ctx.closings}
    nodes = ctx.nodes
    # the closings each tree node descends from (itself included), memoised up the tree
    memo: dict[int, tuple] = {}

    def closings_above(node: int) -> tuple:
        path = []
        while node >= 0 and node not in memo:
            path.append(node)
            node = nodes[node][0] if node < len(nodes) else -1
        found = memo.get(node, ()) if node >= 0 else ()
        for n in reversed(path):
            found = found + ((n,) if n in by_node else ())
            memo[n] = found
        return found

    if NUMPY_REACH and len(ctx.leaves) >= NUMPY_REACH_MIN:
        reach = _reach_numpy(ctx, by_node, closings_above)
    else:
        reach = _reach_python(ctx, by_node, closings_above)
    kept_by_cuts = {cut[1][0] for cut in ctx.cuts if cut[1] is not None}
    owners = set(ctx.openings) | {rec[0] for rec in ctx.opening_boxes}
    drop = []
    for gid, node, index, (_o, _ax, sz) in ctx.closings:
        if index in owners or gid in kept_by_cuts:
            continue
        box = reach.get(node)
        tol = [1e-3 + 1e-6 * v for v in sz]
        if box is not None and all(
            box[a][0] <= tol[a] and box[a][1] >= sz[a] - tol[a] for a in range(3)
        ):
            continue  # what survives reaches across the volume: the solid stands for it
        drop.append((gid, index))
    if not drop:
        return
    gone = {index for _gid, index in drop}
    for gid, _index in drop:
        ctx.solid_of.pop(gid, None)
        ctx.add_of.pop(gid, None)
    # take the solids out of `adds` and renumber what refers to positions in it
    new_index, k = {}, 0
    for i in range(len(ctx.adds)):
        if i not in gone:
            new_index[i] = k
            k += 1
    ctx.adds = [a for i, a in enumerate(ctx.adds) if i not in gone]
    if len(ctx.add_boxes) == len(new_index) + len(gone):
        ctx.add_boxes = [b for i, b in enumerate(ctx.add_boxes) if i not in gone]
    ctx.add_local = {new_index[i]: v for i, v in ctx.add_local.items() if i not in gone}
    ctx.openings = {new_index[i]: v for i, v in ctx.openings.items()}
    ctx.opening_boxes = [(new_index[r[0]], *r[1:]) for r in ctx.opening_boxes]
    ctx.add_of = {g: new_index[i] for g, i in ctx.add_of.items() if i not in gone}
    ctx.closings = [
        (g, n, new_index[i], sc) for g, n, i, sc in ctx.closings if i not in gone
    ]


def _reach_python(ctx: Any, by_node: dict, closings_above: Any) -> dict[int, list]:
    """closing node -> [min, max] per axis, in its scope frame, of the corners of every
    terminal that descends from it."""
    reach: dict[int, list] = {}
    for leaf_tag, o, ax, sz in ctx.leaves:
        above = closings_above(ctx.tags[leaf_tag][5])
        if not above:
            continue
        corners = [
            tuple(o[k] + ax[0][k] * x + ax[1][k] * y + ax[2][k] * z for k in range(3))
            for x in (0.0, sz[0])
            for y in (0.0, sz[1])
            for z in (0.0, sz[2])
        ]
        for cn in above:
            co, cax, _csz = by_node[cn][3]
            box = reach.setdefault(
                cn, [[float("inf"), float("-inf")] for _ in range(3)]
            )
            for p in corners:
                for a in range(3):
                    q = sum((p[k] - co[k]) * cax[a][k] for k in range(3))
                    if q < box[a][0]:
                        box[a][0] = q
                    if q > box[a][1]:
                        box[a][1] = q
    return reach


def _reach_numpy(ctx: Any, by_node: dict, closings_above: Any) -> dict[int, list]:
    """_reach_python's boxes (to rounding), computed on arrays of (terminal, closing) pairs."""
    import numpy as np

    leaf_rows: list[tuple] = []
    pair_leaf: list[int] = []
    pair_closing: list[int] = []
    closing_nodes: list[int] = []
    closing_row: dict[int, int] = {}
    for leaf_tag, o, ax, sz in ctx.leaves:
        above = closings_above(ctx.tags[leaf_tag][5])
        if not above:
            continue
        li = len(leaf_rows)
        leaf_rows.append((o, ax, sz))
        for cn in above:
            ci = closing_row.get(cn)
            if ci is None:
                ci = closing_row[cn] = len(closing_nodes)
                closing_nodes.append(cn)
            pair_leaf.append(li)
            pair_closing.append(ci)
    if not leaf_rows:
        return {}
    lo = np.array([r[0] for r in leaf_rows], dtype=float).reshape(-1, 3)
    lax = np.array([r[1] for r in leaf_rows], dtype=float).reshape(-1, 3, 3)
    lsz = np.array([r[2] for r in leaf_rows], dtype=float).reshape(-1, 3)
    zero = np.zeros(len(lsz))
    # the 8 corners in _reach_python's order (x outer, z inner), each coordinate summed
    # left to right as there: o + ax0 * x + ax1 * y + ax2 * z
    corners = np.empty((len(lsz), 8, 3))
    c = 0
    for x in (zero, lsz[:, 0]):
        for y in (zero, lsz[:, 1]):
            for z in (zero, lsz[:, 2]):
                for k in range(3):
                    corners[:, c, k] = (
                        lo[:, k]
                        + lax[:, 0, k] * x
                        + lax[:, 1, k] * y
                        + lax[:, 2, k] * z
                    )
                c += 1
    frames = [by_node[cn][3] for cn in closing_nodes]
    co = np.array([f[0] for f in frames], dtype=float).reshape(-1, 3)
    cax = np.array([f[1] for f in frames], dtype=float).reshape(-1, 3, 3)
    pl, pc = np.asarray(pair_leaf), np.asarray(pair_closing)
    d = corners[pl] - co[pc][:, None, :]  # (pairs, 8, 3)
    ca = cax[pc]  # (pairs, 3 axes, 3)
    box_lo = np.full((len(closing_nodes), 3), np.inf)
    box_hi = np.full((len(closing_nodes), 3), -np.inf)
    for a in range(3):
        q = (
            d[:, :, 0] * ca[:, None, a, 0]
            + d[:, :, 1] * ca[:, None, a, 1]
            + d[:, :, 2] * ca[:, None, a, 2]
        )
        np.minimum.at(box_lo[:, a], pc, q.min(axis=1))
        np.maximum.at(box_hi[:, a], pc, q.max(axis=1))
    return {
        cn: [[float(box_lo[i, a]), float(box_hi[i, a])] for a in range(3)]
        for i, cn in enumerate(closing_nodes)
    }
