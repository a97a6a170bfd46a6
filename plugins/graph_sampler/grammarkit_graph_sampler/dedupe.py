"""Which variants count as new: node-type histograms (the paper) or graph isomorphism.

`histogram` (default, as Kalojanov et al. 2019): a variant is new when its multiset of part
types has not been seen. It is conservative: different graphs with the same type counts are
dropped. `isomorphism`: new when no kept shape's typed graph is isomorphic to it; the stable
colours of colour refinement (Weisfeiler-Lehman run to the end) bucket candidates and
networkx's VF2, nodes matched within their colour, decides within a bucket.

Before either: a *geometric key* (`geometric_key`), a hash of the shape's parts as (source
geometry, placement) rows, translation removed, rounded and sorted. Equal keys mean the same
parts at the same places, hence the same shape graph: a duplicate without any graph test. Most
duplicates are of this kind (a piece replaced by a congruent one gives back the recipient),
and an attempt can test it before it measures any contact (the sampler ships the known keys
to its workers, as it does the known histograms).
"""
from __future__ import annotations

import hashlib
from typing import Sequence

import networkx as nx
import numpy as np

from grammarkit.tiling import histogram_key

MODES = ("histogram", "isomorphism")


def source_geometry(meshes, transforms, types, quantum: float) -> tuple[np.ndarray, np.ndarray, list]:
    """Per source part: the id of its geometry class (equal ids: the same mesh in its own frame,
    rounded to `quantum`, and the same type) and the pose (4x4) that places that frame in the
    world; a part whose transform is not rigid is a class of its own, placed by the identity.
    Third: per class, its vertices in its frame (for `Orientations`)."""
    classes: dict[bytes, int] = {}
    ids, poses, local_of = [], [], []
    for mesh, T, t in zip(meshes, transforms, types):
        T = np.asarray(T, dtype=np.float64)
        R = T[:3, :3]
        V = np.asarray(mesh.vertices, dtype=np.float64)
        if T.shape == (4, 4) and np.allclose(R @ R.T, np.eye(3), atol=1e-9) and np.linalg.det(R) > 0:
            local, pose = (V - T[:3, 3]) @ R, T
        else:
            local, pose = V, np.eye(4)
        key = (str(t).encode() + b"\0" + np.round(local / quantum).astype(np.int64).tobytes()
               + np.asarray(mesh.faces, dtype=np.int64).tobytes()) if pose is T \
            else b"own:" + str(len(ids)).encode()
        if key not in classes:
            classes[key] = len(classes)
            local_of.append(local)
        ids.append(classes[key])
        poses.append(pose)
    return np.array(ids, dtype=np.int64), np.array(poses, dtype=np.float64).reshape(-1, 4, 4), local_of


class Orientations:
    """Per (geometry class, rotation): a 64-bit hash of the set of the part's vertices about
    its centre, rounded to `quantum`. A part turned by one of its own symmetries (an octagonal
    tower by 45 degrees, a wall by 180) has the same vertex set, so the same hash: geometric
    keys see through part symmetries. A hash, not a counter: equal in every worker process."""

    def __init__(self, local_vertices: list, quantum: float):
        local = [np.asarray(v, dtype=np.float64).reshape(-1, 3) for v in local_vertices]
        self.means = np.array([v.mean(axis=0) if len(v) else np.zeros(3) for v in local]).reshape(-1, 3)
        self.local = [v - m for v, m in zip(local, self.means)]
        self.quantum = float(quantum)
        self._memo: dict = {}

    def __call__(self, geo: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        out = np.empty(len(geo), dtype=np.int64)
        # one rounding for all parts (a numpy call per part was most of a key's cost)
        rounded = np.ascontiguousarray(np.round(np.asarray(rotations, dtype=np.float64), 9))
        for k, (g, R) in enumerate(zip(geo.tolist(), rotations)):
            key = (g, rounded[k].tobytes())
            h = self._memo.get(key)
            if h is None:
                rows = np.round(self.local[g] @ R.T / self.quantum).astype(np.int64)
                rows = rows[np.lexsort(rows.T[::-1])]
                h = int.from_bytes(hashlib.blake2b(rows.tobytes(), digest_size=8).digest(), "little", signed=True)
                if len(self._memo) < 100_000:
                    self._memo[key] = h
            out[k] = h
        return out


def geometric_key(geo: np.ndarray, poses: np.ndarray, quantum: float, orient: Orientations) -> bytes:
    """A 16-byte key of a shape whose parts are geometry classes `geo` (n,) at world `poses`
    (n, 4, 4): rows (class, vertex set about the part's centre (`Orientations`), centre to
    `quantum` after moving the lowest centre to the origin), sorted. Equal keys: the same
    parts at the same places up to a translation of the whole (so the same shape graph, up to
    the order of the nodes). Float noise can only split one geometry into two keys (a
    duplicate then goes on to the graph test), never join two."""
    R = poses[:, :3, :3]
    centre = np.einsum("nij,nj->ni", R, orient.means[geo]) + poses[:, :3, 3]
    centre = centre - centre.min(axis=0)
    rows = np.concatenate([geo[:, None], orient(geo, R)[:, None],
                           np.round(centre / quantum).astype(np.int64)], axis=1)
    rows = rows[np.lexsort(rows.T[::-1])]
    return hashlib.blake2b(rows.tobytes(), digest_size=16).digest()


def typed_graph(types: Sequence[str], edges) -> nx.Graph:
    g = nx.Graph()
    for i, t in enumerate(types):
        g.add_node(i, type=t)
    g.add_edges_from(edges)
    return g


def _digest(data: bytes) -> int:
    return int.from_bytes(hashlib.blake2b(data, digest_size=8).digest(), "little", signed=True)


def stable_colours(types: Sequence[str], edges) -> tuple[list[int], int]:
    """Colour refinement (1-dimensional Weisfeiler-Lehman) of the typed graph run until the
    colour classes stop splitting: per node a colour (a hash of its type and, round after round,
    of its neighbours' colours; the same in every graph and process, so isomorphic graphs get
    equal colours on matching nodes) and a hash of the multiset of final colours.

    An isomorphism maps nodes to nodes of the same colour, so the colours both bucket the
    graphs (a stricter key than networkx's three-round WL hash: castles whose gates sit
    elsewhere on the ring are told apart) and prune VF2 (`node_match` on the colour)."""
    n = len(types)
    names: dict[str, int] = {}
    colour = [names.setdefault(str(t), _digest(str(t).encode())) for t in types]
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for u, v in edges:
        nbrs[u].append(v)
        nbrs[v].append(u)
    classes = len(set(colour))
    while True:
        new = [_digest(np.array([colour[i], *sorted(colour[j] for j in nbrs[i])], dtype=np.int64).tobytes())
               for i in range(n)]
        count = len(set(new))
        colour = new
        if count <= classes:
            break
        classes = count
    return colour, _digest(np.sort(np.array(colour, dtype=np.int64)).tobytes())


class Deduper:
    """Remembers the shapes kept so far; `add` returns True for a new one."""

    def __init__(self, mode: str = "histogram"):
        if mode not in MODES:
            raise ValueError(f"dedupe must be one of {', '.join(MODES)}, not {mode!r}")
        self.mode = mode
        self.histograms: set = set()
        self.geometric: set = set()  # geometric keys of every shape seen (kept or duplicate)
        self._buckets: dict[tuple, list[nx.Graph]] = {}
        self.graph_tests = 0  # isomorphism tests run (VF2), for the statistics
        # typed graph and WL key of the shapes tested lately: `is_new` then `add` of the same
        # candidate (the sampler's merge, then its keep) built and hashed it twice
        self._recent: dict[tuple, tuple] = {}

    def known(self) -> set:
        """What an attempt can test before it measures contacts: the known histograms
        (`histogram`) or geometric keys (`isomorphism`)."""
        return self.histograms if self.mode == "histogram" else self.geometric

    def key(self, types: Sequence[str], edges) -> tuple:
        if self.mode == "histogram":
            return histogram_key(types)
        return self._graph_and_key(types, edges)[1]

    def _graph_and_key(self, types: Sequence[str], edges) -> tuple:
        """The typed graph (its nodes carry their stable colour as `colour`) and its bucket key
        (histogram, hash of the stable colours)."""
        memo = (tuple(types), tuple(map(tuple, edges)))
        found = self._recent.get(memo)
        if found is None:
            if len(self._recent) >= 512:
                self._recent.clear()
            g = typed_graph(types, edges)
            colour, digest = stable_colours(types, edges)
            nx.set_node_attributes(g, dict(enumerate(colour)), "colour")
            found = self._recent[memo] = (g, (histogram_key(types), digest))
        return found

    def is_new(self, types: Sequence[str], edges, geo: bytes | None = None) -> bool:
        return self._check(types, edges, geo, add=False)

    def add(self, types: Sequence[str], edges, geo: bytes | None = None) -> bool:
        """True (and remembered) when the shape is new. `geo`: its `geometric_key`, if known."""
        return self._check(types, edges, geo, add=True)

    def note_duplicate(self, geo: bytes | None) -> None:
        """Remember the geometric key of a shape found to be a duplicate (`is_new` False)."""
        if geo is not None and self.mode == "isomorphism":
            self.geometric.add(geo)

    def _check(self, types, edges, geo, *, add: bool) -> bool:
        if self.mode == "histogram":
            key = histogram_key(types)
            if key in self.histograms:
                return False
            if add:
                self.histograms.add(key)
                if geo is not None:
                    self.geometric.add(geo)
            return True
        if geo is not None and geo in self.geometric:
            return False  # the same parts at the same places as a shape seen before
        g, key = self._graph_and_key(types, edges)
        # equal stable colours imply equal types; matching them prunes VF2 to colour classes
        match = nx.algorithms.isomorphism.categorical_node_match("colour", None)
        bucket = self._buckets.get(key, [])
        self.graph_tests += len(bucket)
        new = not any(nx.is_isomorphic(g, other, node_match=match) for other in bucket)
        if add:
            if geo is not None:
                self.geometric.add(geo)  # a duplicate's key too: its next copy needs no graph test
            if new:
                self._buckets.setdefault(key, []).append(g)
                self.histograms.add(key[0])
        return new
