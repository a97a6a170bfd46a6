"""Learning a tiling grammar from segmented examples (Kalojanov 2019 sections 3 and 6).

From the shape graphs of the examples (recomputed from geometry) we read:
- per part type, the exact neighbour-type multisets observed -> `neighbors T: {...} | {...}`;
- the type pairs that touch -> one `dock A -- B { ... }` per pair;
- per type pair, the docking configurations: the placement of the B part in the A part's local
  frame (frames.py: Kalojanov's farthest-point diagonal frame), over every A-B contact of every
  example, clustered with Mean Shift (the number of configurations is not known in advance);
  each cluster's mean becomes one `at (x, y, z) rot (rx, ry, rz)` placement;
- global constraints that every example satisfies (`connected`, `grounded`);
- `example` statements naming the input files.

Mean Shift (flat kernel, written here in numpy): every sample is a seed and moves to the mean
of the samples within `bandwidth` until it stops; modes closer than half a bandwidth merge.
Features are the translation (x, y, z) plus the relative rotation matrix's nine entries scaled
so that a rotation of `ANGLE_SCALE_DEG` weighs like one bandwidth. The bandwidth is
`bandwidth` (default 0.05) times the median bounding-box diagonal of the two part types in the
pair, i.e. relative to the model's own size - the same fraction that validation uses as its
position tolerance, so every learned example validates against its own grammar.
"""
from __future__ import annotations

import math
import os
from collections import defaultdict
from pathlib import Path
from typing import Sequence

import networkx as nx
import numpy as np

from ..errors import ShapeError
from ..ir import Grammar
from ..ir.expr import Call, Num, Str
from ..ir.tiling import ConstraintDef, DockDef, ExampleDef, NeighborRule, PartDef, Placement
from .assembly import Assembly
from .constraints import check_connected, check_grounded
from .frames import local_frames, symmetry_classes
from .graph import shape_graph
from .rules import euler_degrees

__all__ = ["ANGLE_SCALE_DEG", "DockSample", "docking_samples", "learn", "mean_shift"]

ANGLE_SCALE_DEG = 20.0
_DIGITS = 4


def mean_shift(points: np.ndarray, bandwidth: float, *, max_iter: int = 100,
               max_seeds: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """(modes (m, d), label per point (n,)) of flat-kernel Mean Shift. Deterministic."""
    X = np.asarray(points, dtype=np.float64)
    n = len(X)
    if n == 0:
        return np.zeros((0, X.shape[1] if X.ndim == 2 else 0)), np.zeros(0, dtype=int)
    if bandwidth <= 0:
        raise ValueError("mean_shift: bandwidth must be positive")
    # seeds: one per occupied bin of size bandwidth/2 (like sklearn's bin seeding) for big inputs
    if n > max_seeds:
        keys = np.floor(X / (bandwidth / 2)).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        seeds = X[np.sort(first)]
    else:
        seeds = X.copy()
    from scipy.spatial import cKDTree

    tree = cKDTree(X)
    modes = []
    for s in seeds:
        m = s
        for _ in range(max_iter):
            idx = tree.query_ball_point(m, bandwidth)
            new = X[idx].mean(axis=0) if idx else m
            if np.linalg.norm(new - m) <= 1e-6 * bandwidth:
                m = new
                break
            m = new
        modes.append((len(tree.query_ball_point(m, bandwidth)), tuple(m)))
    # strongest modes first; drop modes within half a bandwidth of a kept one
    modes.sort(key=lambda c: (-c[0], c[1]))
    kept: list[np.ndarray] = []
    for _, m in modes:
        m = np.array(m)
        if all(np.linalg.norm(m - k) > bandwidth / 2 for k in kept):
            kept.append(m)
    centres = np.array(kept)
    labels = np.argmin(np.linalg.norm(X[:, None, :] - centres[None, :, :], axis=2), axis=1)
    # drop modes that own no point, keep the order of first appearance (deterministic output)
    used = []
    for lab in labels:
        if lab not in used:
            used.append(int(lab))
    remap = {old: new for new, old in enumerate(used)}
    return centres[used], np.array([remap[int(lab)] for lab in labels])


class DockSample:
    """One observed contact: B's frame in A's frame (translation, rotation) and the parts' sizes."""

    __slots__ = ("a_type", "b_type", "t", "R", "size")

    def __init__(self, a_type: str, b_type: str, t: np.ndarray, R: np.ndarray, size: float):
        self.a_type, self.b_type, self.t, self.R, self.size = a_type, b_type, t, R, size


def docking_samples(assembly: Assembly, graph: nx.Graph) -> list[DockSample]:
    """Relative placements of adjacent parts, A before B by type name (both ways when equal).

    Symmetric parts have several equally valid local frames; each sample is replaced by the
    lexicographically smallest of its symmetric equivalents, so the same docking seen through
    different frames lands in one cluster (and validation accepts all equivalents anyway)."""
    parts = assembly.parts
    all_frames = local_frames([p.mesh for p in parts])
    sym_class, syms = symmetry_classes([p.mesh for p in parts], all_frames)

    def frame(node: str) -> np.ndarray:
        return all_frames[graph.nodes[node]["index"]]

    out = []
    for u, v in graph.edges():
        tu, tv = graph.nodes[u]["type"], graph.nodes[v]["type"]
        size = max(float(np.linalg.norm(graph.nodes[n]["hi"] - graph.nodes[n]["lo"])) for n in (u, v))
        dirs = [(u, v)] if tu < tv else [(v, u)] if tv < tu else [(u, v), (v, u)]
        for a, b in dirs:
            rel = np.linalg.inv(frame(a)) @ frame(b)
            Sa = syms[sym_class[graph.nodes[a]["index"]]]
            Sb = syms[sym_class[graph.nodes[b]["index"]]]
            t, R = _canonical(rel[:3, 3], rel[:3, :3], Sa, Sb, 1e-3 * size)
            out.append(DockSample(graph.nodes[a]["type"], graph.nodes[b]["type"], t, R, size))
    return out


def _canonical(t: np.ndarray, R: np.ndarray, Sa: np.ndarray, Sb: np.ndarray,
               quantum: float) -> tuple[np.ndarray, np.ndarray]:
    """Smallest (rounded, lexicographic) of (Sa_k^T t, Sa_k^T R Sb_l) over the symmetries."""
    if len(Sa) == 1 and len(Sb) == 1:
        return t, R
    ts = np.einsum("kji,j->ki", Sa, t)  # (k, 3)
    Rs = np.einsum("kji,jm,lmn->klin", Sa, R, Sb)  # (k, l, 3, 3)
    k, l = Rs.shape[:2]
    T = np.repeat(ts, l, axis=0)
    keys = np.concatenate([np.round(T / quantum), np.round(Rs.reshape(k * l, 9) / 1e-3)], axis=1)
    best = int(np.lexsort(keys.T[::-1])[0])
    return T[best], Rs.reshape(k * l, 3, 3)[best]


def _cluster_placements(samples: list[DockSample], bandwidth: float) -> list[tuple[np.ndarray, np.ndarray]]:
    sizes = np.array([s.size for s in samples])
    bw = bandwidth * float(np.median(sizes))
    # ||I - R||_F = 2 sqrt(2) sin(theta / 2): scale so ANGLE_SCALE_DEG counts as one bandwidth
    rot_scale = bw / (2 * math.sqrt(2) * math.sin(math.radians(ANGLE_SCALE_DEG) / 2))
    X = np.array([np.concatenate([s.t, rot_scale * s.R.ravel()]) for s in samples])
    centres, labels = mean_shift(X, bw)
    out = []
    for k in range(len(centres)):
        members = [samples[i] for i in np.flatnonzero(labels == k)]
        t = np.mean([m.t for m in members], axis=0)
        U, _, Vt = np.linalg.svd(np.mean([m.R for m in members], axis=0))
        R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0]) @ Vt  # nearest rotation
        out.append((t, R))
    return out


def _num(x: float) -> Num:
    v = round(float(x), _DIGITS)
    return Num(value=0.0 if v == 0 else v)


def _placement(t: np.ndarray, R: np.ndarray) -> Placement:
    rot = euler_degrees(R)
    rot_node = None if all(abs(round(a, 2)) < 1e-9 for a in rot) else tuple(_num(round(a, 2)) for a in rot)
    return Placement(at=tuple(_num(x) for x in t), rot=rot_node)


def learn(assemblies: Sequence[Assembly | str | os.PathLike], name: str = "learned", *,
          example_paths: Sequence[str] | None = None, tolerance: float | None = None,
          bandwidth: float = 0.05, docks: bool = True, constraints: bool = True) -> Grammar:
    """The tiling grammar the examples exhibit (see the module docstring).

    `assemblies` are Assembly objects or file/folder paths (read with `read_assembly`).
    `example_paths` are the file names written into `example NAME = assembly("...")`
    statements (default: the given paths; omitted for in-memory assemblies without a source).
    `docks=False` writes `dock A -- B` without placements (type pairs only)."""
    from .contacts import check_tolerance
    from .io import read_assembly

    if isinstance(assemblies, (Assembly, str, os.PathLike)):
        assemblies = [assemblies]  # one example
    if isinstance(bandwidth, bool) or not isinstance(bandwidth, (int, float)) \
            or not (math.isfinite(bandwidth) and bandwidth > 0):
        raise ShapeError(f"learn: bandwidth must be a finite number > 0, got {bandwidth!r}")
    tolerance = check_tolerance(tolerance, "learn")
    asms: list[Assembly] = []
    paths: list[str | None] = []
    for a in assemblies:
        if isinstance(a, Assembly):
            asms.append(a)
            paths.append(a.meta.get("source") if isinstance(a.meta.get("source"), str) else None)
        else:
            asms.append(read_assembly(a))
            paths.append(str(a))
    if not asms:
        raise ShapeError("learn: no example assemblies given")
    if example_paths is not None:
        if len(example_paths) != len(asms):
            raise ShapeError(f"learn: example_paths must have one entry per assembly "
                             f"({len(example_paths)} paths for {len(asms)} assemblies)")
        paths = list(example_paths)

    multisets: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    samples: dict[tuple[str, str], list[DockSample]] = defaultdict(list)
    all_connected = all_grounded = True
    for asm in asms:
        g = shape_graph(asm, tolerance)
        for node, data in g.nodes(data=True):
            multisets[data["type"]].add(tuple(sorted(g.nodes[n]["type"] for n in g.neighbors(node))))
        for s in docking_samples(asm, g):
            samples[(s.a_type, s.b_type)].append(s)
        all_connected &= not check_connected(g, {})
        all_grounded &= not check_grounded(g, {})

    statements: list = []
    for t in sorted(multisets):  # one declaration per type: the geometry of its first example part
        statements.append(_part_def(t, asms, paths))
    for t in sorted(multisets):
        statements.append(NeighborRule(part=t, multisets=tuple(sorted(multisets[t]))))
    for (a, b) in sorted(samples):
        placements: tuple[Placement, ...] = ()
        if docks:
            placements = tuple(_placement(t, R) for t, R in _cluster_placements(samples[(a, b)], bandwidth))
            placements = tuple(dict.fromkeys(placements))  # rounding may merge two clusters
        statements.append(DockDef(a=a, b=b, placements=placements))
    if constraints and all_connected:
        statements.append(ConstraintDef(name="connected"))
    if constraints and all_grounded:
        statements.append(ConstraintDef(name="grounded"))
    used_names: set[str] = set()
    for asm, path in zip(asms, paths):
        if path is None:
            continue
        ex_name = _identifier(asm.name or Path(path).stem, used_names)
        statements.append(ExampleDef(name=ex_name, source=Path(path).as_posix()))
    return Grammar(name=_identifier(name, set()), statements=tuple(statements))


def _part_def(ptype: str, asms: list[Assembly], paths: list[str | None]) -> PartDef:
    """`part T = mesh("example.glb", "T.0")` naming the first example part of type T, or for
    in-memory examples without a file a `box(w, d, h)` of that part's local bounding box."""
    for asm, path in zip(asms, paths):
        for p in asm.parts:
            if p.type != ptype:
                continue
            if path is not None:
                return PartDef(name=ptype, geometry=Call(func="mesh", args=(
                    Str(value=Path(path).as_posix()), Str(value=p.id))))
            local = p.mesh.copy()
            local.apply_transform(np.linalg.inv(p.transform))
            ext = local.bounds[1] - local.bounds[0]
            return PartDef(name=ptype, geometry=Call(func="box", args=tuple(_num(x) for x in ext)))
    raise AssertionError(ptype)  # every learned type comes from some part


def _identifier(text: str, used: set[str]) -> str:
    base = "".join(c if c.isalnum() or c == "_" else "_" for c in text) or "example"
    if base[0].isdigit():
        base = "_" + base
    name, k = base, 2
    while name in used:
        name, k = f"{base}_{k}", k + 1
    used.add(name)
    return name

