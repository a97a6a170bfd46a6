"""Edge categories (Kalojanov et al. 2019, section 6): the ways two part types dock.

For every pair of part types, the relative placements of adjacent parts across a dataset (the
placement of B's local frame in A's, `inv(F_A) @ F_B`, with Kalojanov's diagonal frames stored
by `grammarkit dataset`) are clustered with Mean Shift into a finite set of docking
configurations. The clustering is `grammarkit.tiling.learn`'s: the same `mean_shift` and the
same features (translation plus the rotation matrix scaled so that a rotation of
`ANGLE_SCALE_DEG` weighs like one bandwidth); the bandwidth is `bandwidth` (0.02, finer than
learn's 0.05: a facade's long ledges take parts at many nearby places) x the larger part's size.
Pairs are ordered by type name (A < B); for two parts of one type both directions are samples,
and `reverse[k]` is the category of the opposite direction.

**Symmetric parts.** A part's frame is fixed by its vertex order, so a copy turned by one of
the part's own symmetries (an octagonal tower turned by 45 degrees, a wall turned end for end;
the graph sampler makes such copies) has another frame although nothing about the shape
changed, and the same docking would show up as several placements. So every frame is first
made canonical from the part's surroundings: of the frames its symmetries allow
(`grammarkit.tiling.symmetry_offsets`: F @ S), the one in which the positions of its
neighbours' frame origins, rounded and sorted, are smallest (world axes break remaining ties).
This does not depend on how the whole shape is turned, nor on the string: equal local
configurations give equal categories, and a category stays an exact placement between
canonical frames, so it still says on which face of a tower a wall sits. Placing a part from
its parent's canonical frame by a category gives its own canonical frame, so instantiation
and decompression need not recompute them.

`PartLibrary` collects what this needs from a grammar: each type's geometry variants (the
facade has two ledge lengths), sizes, symmetries and a start frame.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from grammarkit.errors import GrammarkitError

__all__ = ["Category", "EdgeCategories", "PartLibrary", "canonical_frames", "edge_labels", "learn_categories",
           "relative_placement", "variant_key"]


def relative_placement(frame_a: np.ndarray, frame_b: np.ndarray) -> np.ndarray:
    """B's frame in A's frame (4x4)."""
    return np.linalg.inv(frame_a) @ frame_b


def variant_key(part_or_mesh) -> str:  # noqa: ANN001
    """A geometry variant's key: the part's vertices in its own Kalojanov frame (rounded to
    1e-4 of its size) and its faces, hashed. Rigid copies of one mesh share the key."""
    from grammarkit.tiling import local_frame

    mesh = getattr(part_or_mesh, "mesh", part_or_mesh)
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = local_frame(V, np.asarray(mesh.faces))
    local = (V - F[:3, 3]) @ F[:3, :3]
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    q = np.round(local / (1e-4 * size)).astype(np.int64)
    return hashlib.sha1(q.tobytes() + np.asarray(mesh.faces, dtype=np.int64).tobytes()).hexdigest()[:12]


class PartLibrary:
    """Every part type's geometry variants (from the grammar's examples, else its `part`
    statement): vertices in the part's own frame, faces, symmetries; size; start frame."""

    def __init__(self, grammar: Any):
        from grammarkit.tiling import (load_examples, local_frame, part_prototype, rules_from_grammar,
                                       symmetry_offsets, up_vector)

        examples = load_examples(grammar)
        # the up axis and the ground exactly as `validate` uses them, so that what is built here
        # passes its orientation and `grounded` checks
        rules = rules_from_grammar(grammar, resolve_constraints=False)
        up = up_vector(rules.up)
        self.up = up
        ground = None
        for name, args, _where in rules.constraints:
            if name == "grounded":
                ground = args.get("ground") if args.get("ground") is not None else rules.ground
        # the ground as a coordinate along `up` (rules give it along the axis, e.g. z for -z too)
        self.ground = None if up is None or ground is None else float(ground) * float(up.sum())
        self.variants: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        self.symmetries: dict[tuple[str, str], np.ndarray] = {}
        self.default: dict[str, str] = {}
        self.sizes: dict[str, float] = {}
        self.start_frame: dict[str, np.ndarray] = {}
        meshes = [(p.type, p.mesh) for asm in examples for p in asm.parts]
        # the types every example part of which stands on the ground: only a shape started
        # from one of them has a known height (built shapes are stood on the ground as a whole)
        lowest: dict[str, list[float]] = {}
        for asm in examples:
            for p in asm.parts:
                self.start_frame.setdefault(p.type, local_frame(p))
                if up is not None:
                    lowest.setdefault(p.type, []).append(float((np.asarray(p.mesh.vertices) @ up).min()))
        self.on_ground: set[str] = {t for t, lows in lowest.items()
                                    if self.ground is not None and max(abs(v - self.ground) for v in lows) < 1e-3}
        for p in grammar.parts:
            if p.name not in {t for t, _ in meshes}:
                meshes.append((p.name, part_prototype(grammar, p.name)))
        for t, mesh in meshes:
            key = variant_key(mesh)
            if (t, key) in self.variants:
                continue
            V = np.asarray(mesh.vertices, dtype=np.float64)
            Fc = np.asarray(mesh.faces)
            F = local_frame(V, Fc)
            self.variants[(t, key)] = ((V - F[:3, 3]) @ F[:3, :3], Fc)
            syms = [S[:3, :3] for S in symmetry_offsets(V, Fc)]
            if up is not None:
                # gravity is not a symmetry: keep only the turns that leave the part's up
                # direction (the world's up in the prototype's frame) where it is, so that a
                # category's placement is never a flipped copy of what the examples show
                u = F[:3, :3].T @ up
                syms = [S for S in syms if float(np.dot(S @ u, u)) > 1.0 - 1e-6] or [np.eye(3)]
            self.symmetries[(t, key)] = np.array(syms)
            self.default.setdefault(t, key)
            self.sizes[t] = max(self.sizes.get(t, 0.0), float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))))

    def part(self, type_name: str, frame: np.ndarray, pid: str, variant: str | None = None):  # noqa: ANN201
        """A Part of the type's geometry variant (default: its first) whose frame is `frame`."""
        import trimesh

        from grammarkit.tiling import Part

        key = variant if (type_name, variant) in self.variants else self.default.get(type_name)
        if key is None:
            raise GrammarkitError(f"no geometry for part type {type_name!r}")
        local, faces = self.variants[(type_name, key)]
        verts = local @ frame[:3, :3].T + frame[:3, 3]
        part = Part(pid, type_name, trimesh.Trimesh(vertices=verts, faces=faces, process=False), frame.copy())
        part.meta["variant"] = key
        return part

    def symmetry_json(self) -> dict:
        return {f"{t}|{v}": [[round(float(x), 9) for x in S.ravel()] for S in syms]
                for (t, v), syms in self.symmetries.items()}


@dataclass
class Category:
    index: int
    a: str  # type of the first part (a <= b by name)
    b: str
    matrix: np.ndarray  # 4x4: B's canonical frame in A's (the cluster's member closest to its mean)
    count: int
    va: str = ""  # geometry variants of the two parts (`variant_key`; "" when not recorded)
    vb: str = ""

    def to_json(self) -> dict:
        return {"index": self.index, "a": self.a, "b": self.b, "count": self.count, "va": self.va, "vb": self.vb,
                "matrix": [round(float(x), 9) for x in self.matrix.ravel()]}


@dataclass
class EdgeCategories:
    types: tuple[str, ...]
    categories: list[Category]
    sizes: dict[str, float]
    symmetries: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # (type, variant) -> (k,3,3)
    default_variant: dict[str, str] = field(default_factory=dict)
    bandwidth: float = 0.02
    reverse: dict[int, int] = field(default_factory=dict)  # same-type pairs: opposite direction
    position_tolerance: float = 0.05  # classification: x the larger part's size
    angle_tolerance: float = 20.0  # degrees

    def __post_init__(self) -> None:
        self.by_pair: dict[tuple[str, str], list[int]] = {}
        for c in self.categories:
            self.by_pair.setdefault((c.a, c.b), []).append(c.index)

    def __len__(self) -> int:
        return len(self.categories)

    def sym(self, t: str, v: str | None) -> np.ndarray:
        s = self.symmetries.get((t, v or "")) if v else None
        if s is None:
            s = self.symmetries.get((t, self.default_variant.get(t, "")))
        return s if s is not None else np.eye(3)[None]

    def canonical_frame(self, t: str, v: str | None, frame: np.ndarray,
                        neighbours: np.ndarray | None = None) -> np.ndarray:
        """Of the frames F @ S the part's symmetries allow, the one in which the neighbours'
        positions (world points, (m, 3)), rounded and sorted, are smallest; ties by the
        rounded world axes (see the module docstring)."""
        S = self.sym(t, v)
        if len(S) == 1:
            return frame
        R = np.einsum("ij,kjl->kil", frame[:3, :3], S)  # (k, 3, 3) candidate axes
        size = self.sizes.get(t, 1.0) or 1.0
        keys = []
        for k in range(len(S)):
            key: list[float] = []
            if neighbours is not None and len(neighbours):
                local = (np.asarray(neighbours, dtype=np.float64) - frame[:3, 3]) @ R[k]
                q = np.round(local / (1e-3 * size)).astype(np.int64)
                key += q[np.lexsort(q.T[::-1])].ravel().tolist()
            key += np.round(R[k].ravel() / 1e-3).astype(np.int64).tolist()
            keys.append(tuple(key))
        best = min(range(len(S)), key=lambda k: keys[k])
        out = frame.copy()
        out[:3, :3] = R[best]
        return out

    def pair_categories(self, t1: str, t2: str) -> list[int]:
        return list(self.by_pair.get(tuple(sorted((t1, t2))), ()))  # type: ignore[arg-type]

    def oriented(self, k: int, parent_type: str, child_type: str) -> np.ndarray:
        """Category k's canonical placement of the child in the parent's frame."""
        c = self.categories[k]
        if (c.a, c.b) == (parent_type, child_type):
            return c.matrix
        if (c.b, c.a) == (parent_type, child_type):
            return np.linalg.inv(c.matrix)
        raise GrammarkitError(f"category {k} joins {c.a} and {c.b}, not {parent_type} and {child_type}")

    def variants(self, k: int, parent_type: str, child_type: str) -> tuple[str, str]:
        """(parent's, child's) geometry variant for category k of the edge parent -> child."""
        c = self.categories[k]
        if (c.a, c.b) == (parent_type, child_type):
            return c.va, c.vb
        return c.vb, c.va

    def placement(self, k: int, parent_type: str, child_type: str) -> np.ndarray:
        """The child's frame in the parent's (canonical) frame for category k."""
        return self.oriented(k, parent_type, child_type)

    def classify(self, t1: str, t2: str, rel: np.ndarray, v1: str | None = None,
                 v2: str | None = None) -> tuple[int | None, float]:
        """The category of a placement `rel` (t2's canonical frame in t1's; parts of geometry
        variants v1, v2 if given): the nearest one of the pair within the tolerances, else None;
        and the distance (relative to part size; inf: no category of the pair has this
        orientation)."""
        if t1 > t2:
            t1, t2, rel, v1, v2 = t2, t1, np.linalg.inv(rel), v2, v1
        cands = [k for k in self.by_pair.get((t1, t2), [])  # a category without variants fits any
                 if (v1 is None or self.categories[k].va in ("", v1)) and (v2 is None or self.categories[k].vb in ("", v2))]
        if not cands:
            return None, math.inf
        size = max(self.sizes.get(t1, 1.0), self.sizes.get(t2, 1.0)) or 1.0
        best, best_d = None, math.inf
        cos_tol = math.cos(math.radians(self.angle_tolerance))
        for k in cands:
            m = self.categories[k].matrix
            cos = (float(np.trace(m[:3, :3].T @ rel[:3, :3])) - 1.0) / 2.0
            if cos < cos_tol - 1e-9:
                continue
            d = float(np.linalg.norm(m[:3, 3] - rel[:3, 3])) / size
            if d < best_d:
                best, best_d = k, d
        if best is None or best_d > self.position_tolerance:
            return None, best_d
        return best, best_d

    def to_json(self) -> dict:
        return {"types": list(self.types), "sizes": self.sizes, "bandwidth": self.bandwidth,
                "categories": [c.to_json() for c in self.categories],
                "reverse": {str(k): v for k, v in self.reverse.items()},
                "symmetries": {f"{t}|{v}": [[round(float(x), 9) for x in S.ravel()] for S in syms]
                               for (t, v), syms in self.symmetries.items()},
                "default_variant": self.default_variant,
                "position_tolerance": self.position_tolerance, "angle_tolerance": self.angle_tolerance}

    @classmethod
    def from_json(cls, data: dict) -> "EdgeCategories":
        try:
            cats = [Category(int(c["index"]), str(c["a"]), str(c["b"]),
                             np.array(c["matrix"], dtype=np.float64).reshape(4, 4), int(c["count"]),
                             str(c.get("va", "")), str(c.get("vb", ""))) for c in data["categories"]]
            syms = {tuple(k.split("|", 1)): np.array(v, dtype=np.float64).reshape(-1, 3, 3)
                    for k, v in data.get("symmetries", {}).items()}
            return cls(tuple(data["types"]), cats, {k: float(v) for k, v in data["sizes"].items()}, syms,  # type: ignore[arg-type]
                       dict(data.get("default_variant", {})), float(data["bandwidth"]),
                       {int(k): int(v) for k, v in data.get("reverse", {}).items()},
                       float(data.get("position_tolerance", 0.05)), float(data.get("angle_tolerance", 20.0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise GrammarkitError(f"malformed edge categories ({type(exc).__name__}: {exc})") from None


def _samples(types_of: Sequence[str], edges: Iterable[tuple[int, int]], frames: np.ndarray,
             variants: Sequence[str] | None = None):
    """(pool key, rel, (u, v)) per direction sampled: A < B by name, both ways for one type;
    the pool key is (A, variant of A, B, variant of B)."""
    var = variants or [""] * len(types_of)
    for u, v in edges:
        tu, tv = types_of[u], types_of[v]
        dirs = [(u, v)] if tu < tv else [(v, u)] if tv < tu else [(u, v), (v, u)]
        for a, b in dirs:
            yield (types_of[a], var[a], types_of[b], var[b]), relative_placement(frames[a], frames[b]), (a, b)


def learn_categories(graphs: Sequence[Any], frames: Sequence[Sequence[Sequence[float]] | None],
                     library: PartLibrary, *, bandwidth: float = 0.02,
                     variants: Sequence[Sequence[str] | None] | None = None) -> EdgeCategories:
    """Cluster the canonical relative placements of every edge of `graphs` (TypedGraphs with
    per-node 4x4 frames, flattened row-major, and optionally per-node geometry variants) per
    type pair and variant pair."""
    from grammarkit.tiling import ANGLE_SCALE_DEG, mean_shift

    ec = EdgeCategories(tuple(sorted(library.sizes)), [], dict(library.sizes), dict(library.symmetries),
                        dict(library.default), bandwidth)
    pools: dict[tuple[str, str, str, str], list[np.ndarray]] = {}
    for i, (g, fr) in enumerate(zip(graphs, frames)):
        if fr is None:
            continue
        var = variants[i] if variants is not None else None
        F = canonical_frames(ec, g.types, fr, var, g.edges)
        for key, rel, _ in _samples(g.types, g.edges, F, var):
            pools.setdefault(key, []).append(rel)
    if not pools:
        raise GrammarkitError("no part frames to learn edge categories from: build the dataset with "
                              "frames (`grammarkit dataset` stores them unless --no-frames)")
    cats: list[Category] = []
    for (a, va, b, vb) in sorted(pools):
        rels = pools[(a, va, b, vb)]
        # learn.py's placement features; a finer bandwidth (see the module docstring)
        bw = bandwidth * max(library.sizes.get(a, 1.0), library.sizes.get(b, 1.0))
        rot_scale = bw / (2 * math.sqrt(2) * math.sin(math.radians(ANGLE_SCALE_DEG) / 2))
        X = np.array([np.concatenate([r[:3, 3], rot_scale * r[:3, :3].ravel()]) for r in rels])
        modes, labels = mean_shift(X, bw)
        for k in range(len(modes)):
            members = np.flatnonzero(labels == k)
            # the member closest to the cluster mean: an actual docking of the input shapes
            centre = X[members].mean(axis=0)
            rep = members[int(np.argmin(np.linalg.norm(X[members] - centre, axis=1)))]
            cats.append(Category(len(cats), a, b, rels[rep].copy(), int(len(members)), va, vb))
    ec.categories = cats
    ec.types = tuple(sorted({t for c in cats for t in (c.a, c.b)}))
    ec.__post_init__()
    for c in cats:
        if c.a == c.b:
            k, _ = ec.classify(c.a, c.b, np.linalg.inv(c.matrix), c.vb or None, c.va or None)
            ec.reverse[c.index] = c.index if k is None else k
    return ec


def canonical_frames(cats: EdgeCategories, types: Sequence[str], frames, variants=None,  # noqa: ANN001
                     edges: Iterable[tuple[int, int]] = ()) -> np.ndarray:
    """(n, 4, 4) canonical frames of a shape's parts (frames flattened row-major or 4x4), each
    anchored by its neighbours along `edges`."""
    F = np.asarray(frames, dtype=np.float64).reshape(len(types), 4, 4)
    nbrs: list[list[int]] = [[] for _ in types]
    for u, v in edges:
        nbrs[u].append(v)
        nbrs[v].append(u)
    return np.array([cats.canonical_frame(t, variants[i] if variants else None, F[i],
                                          F[nbrs[i], :3, 3] if nbrs[i] else None)
                     for i, t in enumerate(types)])


def edge_labels(g: Any, frames: Sequence[Sequence[float]], cats: EdgeCategories,
                variants: Sequence[str] | None = None) -> dict[tuple[int, int], int | None]:
    """Category of every edge of a graph with frames, in both directions (u, v) and (v, u):
    the category of v's placement in u's frame (canonical frames)."""
    F = canonical_frames(cats, g.types, frames, variants, g.edges)
    out: dict[tuple[int, int], int | None] = {}
    for u, v in g.edges:
        for a, b in ((u, v), (v, u)):
            k, _ = cats.classify(g.types[a], g.types[b], relative_placement(F[a], F[b]),
                                 variants[a] if variants else None, variants[b] if variants else None)
            out[(a, b)] = k
    return out
