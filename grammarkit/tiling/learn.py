"""Learning a tiling grammar from segmented examples (Liu 2015 section 3, Kalojanov 2019 sections 3, 6).

From the shape graphs of the examples (recomputed from geometry) `learn` writes:
- `up +z` (the examples' up axis) and per part type `part T = mesh("example.glb", "T.0")
  symmetry(zN) [up(...)]`: the first example part of each type as the prototype, its turn
  symmetry about the up axis found from its geometry (orientation.turn_order), and the
  directions of its modelling frame that point up in the examples (written only when they are
  not just the up axis: a beam that also stands on its end);
- **docking sites** (Liu 2015, section 3: "parts of the same type have the same configuration
  of docking sites"): per part type, the contact positions of all its contacts in all examples
  (the centre of the two parts' bounding-box intersection, in the type's modelling frame,
  reduced modulo its turn symmetry) clustered with Mean Shift (bandwidth SITE_BANDWIDTH x
  `bandwidth` x the smaller part's diagonal); each cluster is a `site`, named
  by its direction from the part's centre (`east`, `top`, ...), and `required` when every part
  of the type in every example has a neighbour at (every turned image of) it;
- per pair of touching sites a `dock A.s -- B.t { at (...) rot (...) | ... }`: the relative
  placements of B's Kalojanov frame in A's (frames.py) over those contacts, clustered with
  Mean Shift (features: translation plus the rotation matrix's entries scaled so that a
  rotation of `ANGLE_SCALE_DEG` weighs like one bandwidth; each sample first reduced modulo the
  parts' turn symmetries). With `sites=False`: one `dock A -- B { ... }` per type pair;
- neighbourhood rules: `neighbors="none"` (the default: sites, docks and `filled` only, the
  rules that generalise to new tilings), `"multisets"` (Kalojanov's exact neighbour-type
  multisets: they reject any neighbourhood no example shows, e.g. most larger or smaller valid
  tilings) or `"ranges"` (per neighbour type the observed count range);
- `count(T, lo, hi)`: the fewest and most T parts an example has (two or more examples;
  `count_slack` widens the range), for the types every example has 1..2 of unless
  `counts="all"`, see learn_stats;
- site docks beyond the observed ones where the sites' recovered sockets fit (learn_sockets;
  `sockets=False`: observed pairs only); `required` sites only for types some part of which
  has an empty site (stands on a border) in the examples, `filled` otherwise;
- `connected`, and `grounded(ground=G)` (strict support) or `grounded(ground=G, sideways=true,
  max_span=K)` when every example satisfies it, G being the examples' lowest point along the
  up axis and K the examples' longest sideways run (learn_stats, support);
- `filled(T, "s")` for every site the examples fill wherever it opens inside the shape's
  outline (not `required`: a border tile leaves its outer side open; holes.py);
- `example NAME = assembly("file")` for each input.

Mean Shift (flat kernel, written here in numpy): every sample is a seed and moves to the mean
of the samples within `bandwidth` until it stops; modes closer than half a bandwidth merge.
The bandwidth is `bandwidth` (default 0.05) times the median diagonal of the *smaller* part of
each contact: neighbouring panels along a 36 m ledge are 1.5 m apart whatever the ledge's
length, so the scale of the alternatives is the small part's. Every learned grammar is then
checked against its own examples with the validator; a contact no learned placement covers
(a cluster mean too far from a member) gets its own placement, so `learn` never writes a
grammar that rejects its examples.
"""
from __future__ import annotations

import math
import os
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable, Sequence

import networkx as nx
import numpy as np

from ..errors import ShapeError
from ..ir import Grammar
from ..ir.expr import Ref, Str
from ..ir.split import Arg
from ..ir.tiling import (
    ConstraintDef, CountRange, DockDef, ExampleDef, NeighborRule, SiteDef, UpDef,
)
from .assembly import Assembly
from .frames import local_frame
from .graph import shape_graph
from .learn_text import _dir_text, _identifier, _num, _part_def, _placement
from .learn_sockets import add_corner_docks
from .learn_stats import COUNT_MODES, SupportStats, count_statements, support_stats
from .meanshift import mean_shift
from .rules import PartSpec, Rules

__all__ = ["ANGLE_SCALE_DEG", "DockSample", "NEIGHBOR_MODES", "docking_samples", "learn", "mean_shift"]

ANGLE_SCALE_DEG = 20.0
# Contact positions closer than SITE_BANDWIDTH x bandwidth x the smaller part's diagonal are one
# site: the same end of a gate whether a wall (4 m) or a tower (6 m) meets it, while panels
# 1.5 m apart along a ledge (diagonal 3.4 m) stay separate sites.
SITE_BANDWIDTH = 4.0
NEIGHBOR_MODES = ("multisets", "ranges", "none")


class DockSample:
    """One observed contact seen from part A: B's frame in A's frame (translation, rotation),
    the contact's size scale (the smaller part's diagonal) and the sites involved."""

    __slots__ = ("a_type", "b_type", "t", "R", "size", "a_site", "b_site", "example", "edge")

    def __init__(self, a_type: str, b_type: str, t: np.ndarray, R: np.ndarray, size: float,
                 a_site: int = -1, b_site: int = -1, example: int = 0, edge: tuple = ()):
        self.a_type, self.b_type, self.t, self.R, self.size = a_type, b_type, t, R, size
        self.a_site, self.b_site, self.example, self.edge = a_site, b_site, example, edge


# --------------------------------------------------------------------------------------------
# poses and symmetry (exactly as validation computes them: learn and validate agree)
# --------------------------------------------------------------------------------------------
class _TypeInfo:
    """A part type's prototype (modelling frame) as its `part` statement will give it, its
    Kalojanov frame, allowed ups and turn order; `free` when no faithful prototype can be
    written (an in-memory example part that is not a box): `up(any)`, no pose."""

    def __init__(self, name: str, proto_vertices: np.ndarray | None, proto_faces: np.ndarray | None,
                 extents: np.ndarray | None = None):
        self.name = name
        self.free = proto_vertices is None
        self.V = proto_vertices
        self.extents = extents
        if proto_vertices is not None:
            self.frame = local_frame(proto_vertices, proto_faces)
            self.size = float(np.linalg.norm(proto_vertices.max(axis=0) - proto_vertices.min(axis=0)))
        self.ups: list[np.ndarray] = []
        self.orders: list[int] = []

    def spec(self) -> PartSpec:
        return PartSpec(self.name, self.frame, self.size, np.array(self.ups), tuple(self.orders), True, False,
                        self.V)


def _observed_ups(d: np.ndarray, cos_tol: float) -> list[np.ndarray]:
    """Distinct directions among the rows of `d` (unit vectors), merged within the angle
    tolerance; rounded to 4 digits (what the grammar text holds), axis-like ones snapped."""
    out: list[np.ndarray] = []
    for v in d:
        if any(float(v @ u) >= cos_tol for u in out):
            continue
        w = np.round(v, 4)
        k = int(np.argmax(np.abs(w)))
        if abs(abs(w[k]) - 1.0) < 1e-3:
            w = np.zeros(3)
            w[k] = np.sign(v[k])
        out.append(w / np.linalg.norm(w))
    return out


def _canonical_point(p: np.ndarray, S: np.ndarray, quantum: float) -> np.ndarray:
    """The image of p under the turns S (k, 3, 3) with the smallest rounded coordinates."""
    imgs = np.einsum("kij,j->ki", S, p)
    keys = np.round(imgs / quantum)
    return imgs[int(np.lexsort(keys.T[::-1])[0])]


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
        out.append(_mean_placement(members))
    return out


def _mean_placement(members: list[DockSample]) -> tuple[np.ndarray, np.ndarray]:
    t = np.mean([m.t for m in members], axis=0)
    U, _, Vt = np.linalg.svd(np.mean([m.R for m in members], axis=0))
    R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0]) @ Vt  # nearest rotation
    return t, R


class _Example:
    """One example with its graph and, as the validator sees them (validate._Shape and
    validate._poses: learn and validate agree by construction), its parts' frames and turn
    symmetry groups."""

    def __init__(self, k: int, asm: Assembly, graph: nx.Graph, info: dict[str, _TypeInfo], up: np.ndarray):
        from .validate import _Shape

        self.k, self.asm, self.graph = k, asm, graph
        self.shape = _Shape(asm, graph)
        parts = asm.parts
        self.index = {n: i for i, n in enumerate(self.shape.nodes)}
        self.types = self.shape.types
        self.F = self.shape.frames()
        self.edges = self.shape.edges
        self.lo, self.hi, self.diag = self.shape.lo, self.shape.hi, self.shape.diag
        # d: the modelling-frame direction pointing up, per part (M = F inv(F_proto))
        self.d = np.zeros((len(parts), 3))
        for t, ti in info.items():
            m = np.array([i for i, x in enumerate(self.types) if x == t], dtype=np.int64)
            if len(m) and not ti.free:
                R = np.einsum("nij,kj->nik", self.F[m, :3, :3], ti.frame[:3, :3])
                self.d[m] = np.einsum("nji,j->ni", R, up)
        self.poses = None
        self.rules: Rules | None = None

    def set_poses(self, rules: Rules) -> None:
        from .validate import _poses

        self.rules = rules
        self.poses = _poses(rules, self.shape)

    def group(self, i: int, info: dict[str, _TypeInfo] | None = None) -> np.ndarray:
        g = int(self.poses.group[i])
        return self.poses.groups[g] if g >= 0 else np.eye(3)[None]

    def contact_points(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per contact its position, normal and corner flag (sitegeom: as validation reads them)."""
        from .sitegeom import contact_geometry

        assert self.rules is not None, "set_poses first"
        return contact_geometry(self.rules, self.shape, np.arange(len(self.edges)))


def docking_samples(assembly: Assembly, graph: nx.Graph, *, up: str | None = "+z") -> list[DockSample]:
    """Relative placements of adjacent parts, A before B by type name (both ways when equal),
    each reduced modulo the parts' turn symmetries about the up axis (the first part of each
    type is the prototype). A helper for inspecting what `learn` clusters."""
    from .orientation import up_vector

    upv = up_vector(up)
    upv = upv if upv is not None else np.array([0.0, 0.0, 1.0])
    info = _type_infos([assembly], [assembly.meta.get("source")])
    ex = _Example(0, assembly, graph, info, upv)
    _finish_types(info, [ex], upv, up or "+z", [])
    return _samples(ex, info)


def _type_infos(asms: list[Assembly], paths: list) -> dict[str, _TypeInfo]:
    """Per type: the prototype as `part` statements give it (the first example part, in its
    own frame; for in-memory examples without a file a box of its local bounding box, when the
    part is exactly that box, else no prototype: `up(any)`)."""
    import trimesh

    info: dict[str, _TypeInfo] = {}
    for asm, path in zip(asms, paths):
        for p in asm.parts:
            if p.type in info:
                continue
            inv = np.linalg.inv(np.asarray(p.transform, dtype=np.float64))
            V = np.asarray(p.mesh.vertices, dtype=np.float64) @ inv[:3, :3].T + inv[:3, 3]
            if path is not None:
                info[p.type] = _TypeInfo(p.type, V, np.asarray(p.mesh.faces))
                continue
            ext = np.array([float(_num(x).value) for x in V.max(axis=0) - V.min(axis=0)])
            box = trimesh.creation.box(extents=ext)
            BV = np.asarray(box.vertices, dtype=np.float64)
            centred = V - (V.max(axis=0) + V.min(axis=0)) / 2
            size = float(np.linalg.norm(ext)) or 1.0
            if BV.shape == centred.shape and np.abs(BV - centred).max() <= 1e-4 * size:
                info[p.type] = _TypeInfo(p.type, BV, np.asarray(box.faces), ext)
            else:
                info[p.type] = _TypeInfo(p.type, None, None, ext)
    return info


def _box_extents(p) -> np.ndarray:  # noqa: ANN001
    inv = np.linalg.inv(np.asarray(p.transform, dtype=np.float64))
    V = np.asarray(p.mesh.vertices, dtype=np.float64) @ inv[:3, :3].T + inv[:3, 3]
    return V.max(axis=0) - V.min(axis=0)


def _finish_types(info: dict[str, _TypeInfo], examples: list["_Example"], upv: np.ndarray, up: str,
                  notes: list[str]) -> None:
    """Allowed ups (observed) and turn orders per type, then every example's poses as the
    validator will compute them from the learned statements."""
    from .orientation import turn_order

    cos_tol = math.cos(math.radians(20.0))
    for t, ti in sorted(info.items()):
        if ti.free:
            notes.append(f"up(any) for {t}: an in-memory example part that is not a box has no "
                         "prototype to write, so its orientation is not learned")
            continue
        d = np.concatenate([ex.d[[i for i, x in enumerate(ex.types) if x == t]] for ex in examples])
        ti.ups = _observed_ups(d, cos_tol)
        # one declared group for the type (what `symmetry(zN)` can say): the turns common to
        # every allowed up direction
        n = math.gcd(*[turn_order(ti.V, ti.frame[:3, 3], u) for u in ti.ups])
        ti.orders = [n] * len(ti.ups)
        notes.append(f"symmetry({'none' if n <= 1 else f'z{n}'}) for {t}: turns about the up axis that leave "
                     "its prototype's geometry unchanged")
        if len(ti.ups) > 1 or not np.allclose(ti.ups[0], upv):
            notes.append(f"up({', '.join(_dir_text(u) for u in ti.ups)}) for {t}: its parts stand that way in "
                         "the examples")
    rules = Rules(up=up, parts={t: ti.spec() for t, ti in info.items() if not ti.free},
                  free=frozenset(t for t, ti in info.items() if ti.free))
    for ex in examples:
        ex.set_poses(rules)


def _samples(ex: _Example, info: dict[str, _TypeInfo], site_of: dict | None = None) -> list[DockSample]:
    out = []
    for e, (u, v) in enumerate(ex.edges.tolist()):
        tu, tv = ex.types[u], ex.types[v]
        size = float(min(ex.diag[u], ex.diag[v]))
        dirs = [(u, v)] if tu < tv else [(v, u)] if tv < tu else [(u, v), (v, u)]
        for a, b in dirs:
            rel = np.linalg.inv(ex.F[a]) @ ex.F[b]
            t, R = _canonical(rel[:3, 3], rel[:3, :3], ex.group(a, info), ex.group(b, info), 1e-3 * size)
            sa = site_of.get((e, a), -1) if site_of else -1
            sb = site_of.get((e, b), -1) if site_of else -1
            out.append(DockSample(ex.types[a], ex.types[b], t, R, size, sa, sb, ex.k, (a, b)))
    return out


# --------------------------------------------------------------------------------------------
# sites: clusters of contact positions per part type
# --------------------------------------------------------------------------------------------
_SIDE_NAMES = {(0, 1): "east", (0, -1): "west", (1, 1): "north", (1, -1): "south", (2, 1): "top", (2, -1): "bottom"}


def _learn_sites(examples: list["_Example"], info: dict[str, _TypeInfo], bandwidth: float
                 ) -> tuple[dict[str, list[dict]], dict]:
    """Per type the site clusters (position in modelling coordinates, name, facing), and per
    (example, edge, part) the site index its contact is at.

    A contact's features, per part: the contact point (the centre of the two bounding boxes'
    intersection, Liu's boundary-frame origin) and its normal (sitegeom.contact_geometry), both in
    the part's modelling frame and reduced modulo its turn symmetry; the normal weighs two
    bandwidths, so a ledge's top and bottom (0.2 m apart) are different sites."""
    feats: dict[str, list[tuple[np.ndarray, np.ndarray, float, tuple[int, int, int], bool]]] = defaultdict(list)
    for ex in examples:
        if not len(ex.edges):
            continue
        cs, ns, corner = ex.contact_points()
        for e, (u, v) in enumerate(ex.edges.tolist()):
            scale = float(min(ex.diag[u], ex.diag[v]))
            for a, sgn in ((u, 1.0), (v, -1.0)):
                ti = info[ex.types[a]]
                if ti.free:
                    continue  # no modelling frame to put a site in
                Ra = ex.F[a][:3, :3]
                pk = Ra.T @ (cs[e] - ex.F[a][:3, 3])  # in the part's Kalojanov frame
                nk = Ra.T @ (sgn * ns[e])
                S = ex.group(a, info)
                both = np.concatenate([pk, nk * ti.size])
                imgs = np.concatenate([np.einsum("kij,j->ki", S, pk), np.einsum("kij,j->ki", S, nk) * ti.size], axis=1)
                keys = np.round(imgs / (1e-3 * ti.size))
                best = imgs[int(np.lexsort(keys.T[::-1])[0])] if len(S) > 1 else both
                pm = ti.frame[:3, :3] @ best[:3] + ti.frame[:3, 3]  # to the modelling frame
                nm = ti.frame[:3, :3] @ (best[3:] / ti.size)
                feats[ex.types[a]].append((pm, nm, scale, (ex.k, e, a), bool(corner[e])))
    sites: dict[str, list[dict]] = {}
    site_of: dict = {}
    for t in sorted(feats):
        rows = feats[t]
        bw = SITE_BANDWIDTH * bandwidth * float(np.median([r[2] for r in rows]))
        bw = max(bw, 1e-9)
        X = np.array([np.concatenate([r[0], 2 * bw * r[1]]) for r in rows])
        centres, labels = mean_shift(X, bw)
        found = []
        for c in range(len(centres)):
            pos = np.array([rows[i][0] for i in np.flatnonzero(labels == c)]).mean(axis=0)
            normal = np.array([rows[i][1] for i in np.flatnonzero(labels == c)]).mean(axis=0)
            k = int(np.argmax(np.abs(normal)))
            sign = 1 if normal[k] >= 0 else -1
            members = np.flatnonzero(labels == c)
            found.append((k, -sign, tuple(np.round(pos, 4)), c, pos, sign, all(rows[i][4] for i in members)))
        found.sort()  # by facing, then position: stable names
        used: dict[str, int] = {}
        remap = {}
        out = []
        for j, (k, _, _, c, pos, sign, at_corner) in enumerate(found):
            base = _SIDE_NAMES[(k, sign)]
            used[base] = used.get(base, 0) + 1
            name = base if used[base] == 1 else f"{base}_{used[base]}"
            facing = ("+" if sign > 0 else "-") + "xyz"[k]
            out.append({"name": name, "pos": np.array([float(_num(x).value) for x in pos]), "facing": facing,
                        "corner": at_corner})
            remap[c] = j
        sites[t] = out
        for row, lab in zip(rows, labels):
            site_of[row[3]] = remap[int(lab)]
    return sites, site_of


# --------------------------------------------------------------------------------------------
# learn
# --------------------------------------------------------------------------------------------
# long: one pass over the stages (graphs, sites, docks, sockets, counts, required and filled
# sites, self-check) that share the examples' state; each stage's work is in its own helper
def learn(assemblies: Sequence[Assembly | str | os.PathLike], name: str = "learned", *,
          example_paths: Sequence[str] | None = None, tolerance: float | None = None,
          bandwidth: float = 0.05, docks: bool = True, constraints: bool = True,
          neighbors: str = "none", sites: bool = True, counts: bool | str = True, count_slack: int = 0,
          holes: bool = True, sockets: bool = True,
          up: str = "+z", notes: list[str] | None = None,
          progress: Callable[[str], Any] | None = None) -> Grammar:
    """The tiling grammar the examples exhibit (see the module docstring).

    `assemblies` are Assembly objects or file/folder paths (read with `read_assembly`).
    `example_paths` are the file names written into `example NAME = assembly("...")`
    statements (default: the given paths; omitted for in-memory assemblies without a source).
    `docks=False` writes `dock A -- B` without placements (type pairs only); `sites=False`
    learns no docking sites (one dock per type pair); `neighbors` is "multisets", "ranges" or
    "none"; `counts` is True ("few": ranges for the types no example has more than
    learn_stats.FEW of), "all" (every type) or False; `count_slack` widens each learned
    count range by that many parts on each side (default 0: the examples' min..max); `up` is
    the examples' up axis; `holes=False` writes no `filled` constraints (holes.py);
    `sockets=False` writes only the site pairs the examples show (learn_sockets: by default
    every pair of sites whose recovered sockets fit).
    `notes` (a list) receives one line per inference (counts, symmetries, support, ...);
    `progress(stage)` is called as each stage starts."""
    from .contacts import check_tolerance
    from .io import read_assembly
    from .orientation import normalize_mirrored, up_vector

    say = progress or (lambda stage: None)
    if isinstance(assemblies, (Assembly, str, os.PathLike)):
        assemblies = [assemblies]  # one example
    if isinstance(bandwidth, bool) or not isinstance(bandwidth, (int, float)) \
            or not (math.isfinite(bandwidth) and bandwidth > 0):
        raise ShapeError(f"learn: bandwidth must be a finite number > 0, got {bandwidth!r}")
    if counts not in (True, False, *COUNT_MODES):
        raise ShapeError(f"learn: counts must be True, False or one of {', '.join(COUNT_MODES)}, got {counts!r}")
    if isinstance(count_slack, bool) or not isinstance(count_slack, int) or count_slack < 0:
        raise ShapeError(f"learn: count_slack must be a whole number >= 0, got {count_slack!r}")
    if neighbors not in NEIGHBOR_MODES:
        raise ShapeError(f"learn: neighbors must be one of {', '.join(NEIGHBOR_MODES)}, got {neighbors!r}")
    upv = up_vector(up) if up != "none" else None
    if up not in ("+x", "-x", "+y", "-y", "+z", "-z"):
        raise ShapeError(f"learn: up must be an axis (+x, -x, +y, -y, +z, -z), got {up!r}")
    tolerance = check_tolerance(tolerance, "learn")
    asms: list[Assembly] = []
    paths: list[str | None] = []
    for a in assemblies:
        if isinstance(a, Assembly):
            asms.append(a)
            paths.append(a.meta.get("source") if isinstance(a.meta.get("source"), str) else None)
        else:
            say(f"reading {a}")
            asms.append(read_assembly(a))
            paths.append(str(a))
    if not asms:
        raise ShapeError("learn: no example assemblies given")
    if example_paths is not None:
        if len(example_paths) != len(asms):
            raise ShapeError(f"learn: example_paths must have one entry per assembly "
                             f"({len(example_paths)} paths for {len(asms)} assemblies)")
        paths = list(example_paths)
    asms = [a if not any(np.linalg.det(np.asarray(p.transform)[:3, :3]) < 0 for p in a.parts)
            else Assembly([normalize_mirrored(p) for p in a.parts], a.name, a.meta) for a in asms]
    notes = notes if notes is not None else []
    sites = sites and docks  # without placements, learned sites would constrain nothing

    # -- graphs, prototypes, poses ------------------------------------------------------------
    graphs = []
    for k, asm in enumerate(asms):
        say(f"shape graph of {asm.name or k} ({len(asm)} parts)")
        graphs.append(shape_graph(asm, tolerance))
    info = _type_infos(asms, paths)
    examples = [_Example(k, a, g, info, upv) for k, (a, g) in enumerate(zip(asms, graphs))]
    say("orientations and symmetries")
    _finish_types(info, examples, upv, up, notes)

    # -- sites, docking samples ---------------------------------------------------------------
    site_defs: dict[str, list[dict]] = {}
    site_of: dict = {}
    if sites:
        say("docking sites (Mean Shift on contact positions)")
        site_defs, site_of = _learn_sites(examples, info, bandwidth)
    samples: dict[tuple, list[DockSample]] = defaultdict(list)
    for ex in examples:
        keyed = {(e, a): s for (k, e, a), s in site_of.items() if k == ex.k}
        for s in _samples(ex, info, keyed):
            sa = site_defs[s.a_type][s.a_site]["name"] if s.a_site >= 0 else None
            sb = site_defs[s.b_type][s.b_site]["name"] if s.b_site >= 0 else None
            if s.a_type == s.b_type and sa is not None and sb is not None and sb < sa:
                continue  # the reverse direction's sample covers this one (dock A.s -- A.t is both ways)
            samples[(s.a_type, s.b_type, sa, sb)].append(s)

    # -- neighbourhoods, counts, constraints -------------------------------------------------
    multisets: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    type_counts: list[dict[str, int]] = []
    for g in graphs:
        for node, data in g.nodes(data=True):
            multisets[data["type"]].add(tuple(sorted(g.nodes[n]["type"] for n in g.neighbors(node))))
        hist: dict[str, int] = defaultdict(int)
        for _, data in g.nodes(data=True):
            hist[data["type"]] += 1
        type_counts.append(hist)

    statements: list = [UpDef(axis=up)]
    for t in sorted(info):
        statements.append(_part_def(t, asms, paths, info[t], upv))
    for t in sorted(site_defs):
        for sd in site_defs[t]:
            statements.append(SiteDef(part=t, name=sd["name"], position=tuple(_num(x) for x in sd["pos"]),
                                      facing=sd["facing"]))
    if neighbors == "multisets":
        for t in sorted(multisets):
            statements.append(NeighborRule(part=t, multisets=tuple(sorted(multisets[t]))))
    elif neighbors == "ranges":
        for t in sorted(multisets):
            ranges = _ranges(multisets[t])
            statements.append(NeighborRule(part=t, counts=tuple(CountRange(type=o, lo=lo, hi=hi)
                                                                for o, (lo, hi) in sorted(ranges.items()))))
    say("docking configurations (Mean Shift on relative placements)")
    dock_keys = sorted(samples, key=lambda k: (k[0], k[1], k[2] or "", k[3] or ""))
    placements_of: dict[tuple, list[tuple[np.ndarray, np.ndarray]]] = {}
    for key in dock_keys:
        placements_of[key] = _cluster_placements(samples[key], bandwidth) if docks else []
    extra: list[ConstraintDef] = []  # `filled` constraints (found once the sites are known)
    mode = "few" if counts is True else "none" if counts is False else counts
    count_st = count_statements(list(info), type_counts, count_slack, notes, mode)
    ground = None
    support = SupportStats(False, False, None)
    connected = False
    if constraints:
        from .constraints import check_connected

        connected = all(not check_connected(g, {}) for g in graphs)
        if upv is not None:
            k = int(np.argmax(np.abs(upv)))
            lows = [float(a.bounds[0][k]) if upv[k] > 0 else float(a.bounds[1][k]) for a in asms]
            ground = min(lows) if upv[k] > 0 else max(lows)
            proto_rules = Rules(name=name, up=up)
            support = support_stats(graphs, [{"assembly": a, "rules": proto_rules} for a in asms], ground, notes)
    used_names: set[str] = set()
    examples_st = []
    for asm, path in zip(asms, paths):
        if path is None:
            continue
        ex_name = _identifier(asm.name or Path(path).stem, used_names)
        examples_st.append(ExampleDef(name=ex_name, source=Path(path).as_posix()))

    def build() -> Grammar:
        out = list(statements)
        for key in dock_keys:
            a, b, sa, sb = key
            pls = tuple(dict.fromkeys(_placement(t, R) for t, R in placements_of[key]))
            if not docks and (sa is not None or sb is not None):
                continue
            out.append(DockDef(a=a, a_site=sa if docks else None, b=b, b_site=sb if docks else None,
                               placements=pls))
        if not docks:
            for a, b in sorted({(k[0], k[1]) for k in dock_keys}):
                out.append(DockDef(a=a, b=b))
        out.extend(count_st)
        out.extend(extra)
        if connected:
            out.append(ConstraintDef(name="connected"))
        grounded = support.statement(_num(ground)) if ground is not None else None
        if grounded is not None:
            out.append(grounded)
        return Grammar(name=_identifier(name, set()), statements=tuple(out + examples_st))

    grammar = build()
    if sites and docks and sockets:
        say("socket classes (site pairs that fit beyond the observed ones)")
        _add_socket_docks(grammar, info, examples, samples, placements_of, dock_keys, up, bandwidth, notes)
        add_corner_docks(site_defs, sorted(info), placements_of, dock_keys, notes)
        grammar = build()
    # types whose example parts are not all rigid copies of the prototype (a longer ledge on a
    # wider facade): declared deformable, so the examples pass the rigid-copy check
    from .rigid import rigid_errors

    rules = _rules_for(grammar, info, up)
    bent = sorted({ex.types[i] for ex in examples
                   for i, _ in rigid_errors(rules, ex.shape, ex.poses, np.arange(len(ex.types)))})
    for t in bent:
        notes.append(f"deformable({t}): its example parts are not all rigid copies of the first one")
        extra.append(ConstraintDef(name="deformable", args=(Arg(value=Ref(name=t)),)))
    if bent:
        grammar = build()
    if sites and docks:
        # required sites: those every part of the type has filled in every example
        say("required sites")
        corners = {(t, sd["name"]) for t, sds in site_defs.items() for sd in sds if sd["corner"]}
        required = _required_sites(grammar, info, examples, up, corners)
        if required:
            statements[:] = [s.model_copy(update={"required": True})
                             if isinstance(s, SiteDef) and (s.part, s.name) in required else s for s in statements]
        if holes and upv is not None:
            # and the sites every example fills wherever they open inside the shape (holes.py)
            from .holes import filled_sites
            from .validate import _Shape

            # a site where parts only meet along an edge or at a point (diagonal neighbours of
            # square tiles): no probe beyond it tells inside from outside, and a hole there
            # also empties the face sites around it
            for t, site in filled_sites(_rules_for(grammar, info, up), [_Shape(e.asm, e.graph) for e in examples],
                                        required | corners):
                notes.append(f"filled({t}, \"{site}\"): every example has a neighbour at {t}.{site} wherever "
                             "it opens inside the shape")
                extra.append(ConstraintDef(name="filled", args=(Arg(value=Ref(name=t)), Arg(value=Str(value=site)))))
        grammar = build()
    if docks:
        # the learned grammar must accept its own examples: add any contact no cluster covers
        say("checking the examples against the learned grammar")
        for _ in range(3):
            missing = _uncovered(grammar, info, examples, samples, up)
            if not missing:
                break
            for key, more in missing.items():
                placements_of[key].extend(more)
            grammar = build()
    return grammar


def _add_socket_docks(grammar: Grammar, info: dict[str, _TypeInfo], examples: list[_Example],
                      samples: dict[tuple, list[DockSample]], placements_of: dict[tuple, list], dock_keys: list,
                      up: str, bandwidth: float, notes: list[str]) -> None:
    """Extend the site docks by the socket classes (learn_sockets.extend_site_docks)."""
    from .learn_sockets import extend_site_docks

    rules = _rules_for(grammar, info, up)
    sizes = {t: ti.size for t, ti in info.items() if not ti.free}
    frames = {t: ti.frame for t, ti in info.items() if not ti.free}
    added = extend_site_docks(rules.sites, frames, sizes, samples, examples, placements_of, dock_keys, bandwidth)
    if added:
        notes.append(f"{added} site dock(s) no example shows: their sites' sockets fit those of observed docks "
                     "(learn_sockets; sockets=False: only observed pairs)")


def _ranges(msets: set[tuple[str, ...]]) -> dict[str, tuple[int, int]]:
    types = sorted({t for m in msets for t in m})
    out = {}
    for t in types:
        cs = [m.count(t) for m in msets]
        out[t] = (min(cs), max(cs))
    return out


def _rules_for(grammar: Grammar, info: dict[str, _TypeInfo], up: str) -> Rules:
    """The learned grammar as validation compiles it, with the prototypes learn already holds
    (the grammar's files are relative to where it will be written)."""
    from .rules import _site_specs, builtin_functions, rules_from_grammar

    rules = rules_from_grammar(grammar, site_placements=False)
    rules.parts = {t: ti.spec() for t, ti in info.items() if not ti.free}
    rules.sites = _site_specs(grammar, up, {}, builtin_functions())
    return rules


REQUIRED_CHANCE = 0.01  # see _required_sites


def _required_sites(grammar: Grammar, info: dict[str, _TypeInfo], examples: list[_Example], up: str,
                    corners: frozenset[tuple[str, str]] | set[tuple[str, str]] = frozenset()) -> set[tuple[str, str]]:
    """(type, site) pairs filled on every part of the type in every example (the validator's
    own occupancy test, so the examples pass their `required` rules), for the types the
    examples show on the shape's border often enough to tell: if all k sites of the type could
    face outwards, n empty sightings would miss the m never-empty ones with chance
    ((k - m) / k) ** n, which must be below REQUIRED_CHANCE (a coast's shores, empty ten
    times at their ends, never at their grass or water side: required; a road bend empty eight
    times over three of its four sides: not). Other types' sites get `filled` (holes inside)
    instead. Corner sites (`corners`: meeting along an edge or at a point) are never required."""
    from .validate import _Shape, required_site_violations

    rules = _rules_for(grammar, info, up)
    all_sites = {(t, s.name) for t, sts in rules.sites.items() for s in sts} - set(corners)
    rules.sites = {t: tuple(type(s)(s.part, s.name, s.frames, True) for s in sts) for t, sts in rules.sites.items()}
    empty: set[tuple[str, str]] = set()
    sightings: dict[str, int] = defaultdict(int)
    for ex in examples:
        shape = _Shape(ex.asm, ex.graph)
        for v in required_site_violations(rules, shape):
            t, name = v.allowed.split(".", 1)
            empty.add((t, name))
            if (t, name) not in corners:
                sightings[t] += 1
    n_sites: dict[str, int] = defaultdict(int)
    for t, _ in all_sites:
        n_sites[t] += 1
    never: dict[str, int] = defaultdict(int)
    for t, _ in all_sites - empty:
        never[t] += 1
    told = {t for t, n in sightings.items() if ((n_sites[t] - never[t]) / n_sites[t]) ** n < REQUIRED_CHANCE}
    return {(t, name) for t, name in all_sites - empty if t in told}


def _uncovered(grammar: Grammar, info: dict[str, _TypeInfo], examples: list[_Example],
               samples: dict[tuple, list[DockSample]], up: str) -> dict[tuple, list]:
    """Per dock key, the placements of example contacts the learned grammar rejects."""
    from .validate import _dock_violations, _Shape

    rules = _rules_for(grammar, info, up)
    by_edge: dict[tuple, list[tuple[tuple, DockSample]]] = defaultdict(list)
    for key, ss in samples.items():
        for s in ss:
            by_edge[(s.example, *sorted(s.edge))].append((key, s))
    out: dict[tuple, list] = defaultdict(list)
    for ex in examples:
        shape = _Shape(ex.asm, ex.graph)
        for v in _dock_violations(rules, shape, np.arange(len(shape.edges))):
            a, b = ex.index[v.part_id], ex.index[v.other_id]
            for key, s in by_edge.get((ex.k, *sorted((a, b))), []):
                out[key].append((s.t, s.R))
    return out
