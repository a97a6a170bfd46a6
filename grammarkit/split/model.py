"""The result of a derivation: one watertight mesh, the tagged terminals, and the derivation tree."""
from __future__ import annotations


import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import manifold3d
import numpy as np

from ..errors import DerivationError
from .closings import drop_unspanned_closings
from .engine import WELD, Derivation, Tag
from .pinches import coincident_groups, separate
from .union import SLIVER_VOLUME, LazySolid, free_parts, may_have_slivers, with_free_parts
from .scene import CUT_COLOR, DEFAULT_COLOR, UNTAGGED, rgba_of, export_scene

Manifold = manifold3d.Manifold


__all__ = ["Model", "Part", "TreeNode", "compose"]


@dataclass(frozen=True)
class Part:
    """A terminal shape with its semantic tags and scope (world coordinates)."""

    id: int
    name: str  # terminal name (`Glass.`) or the rule it ended in
    rule: str
    object_type: str | None
    color: str | None
    material: str | None
    kind: str  # "face" or "volume"
    node: int  # index in the derivation tree
    origin: tuple[float, float, float]
    axes: tuple[tuple[float, float, float], ...]
    size: tuple[float, float, float]

    def to_dict(self) -> dict:
        return {"id": self.id, "name": self.name, "rule": self.rule, "object_type": self.object_type,
                "color": self.color, "material": self.material, "kind": self.kind, "node": self.node,
                "origin": list(self.origin), "axes": [list(a) for a in self.axes], "size": list(self.size)}


@dataclass
class TreeNode:
    """A shape of the derivation: the rule applied to it, its scope, seed and source line."""

    id: int
    parent: int
    rule: str
    kind: str  # "face" or "volume"
    via: str  # how it was made: "axiom", "rule" (a successor) or the block operation's name
    origin: tuple[float, float, float]
    axes: tuple[tuple[float, float, float], ...]
    size: tuple[float, float, float]
    seed: int
    file: str | None
    line: int | None
    terminal: str | None = None
    children: list["TreeNode"] = field(default_factory=list)

    def to_dict(self, nested: bool = False) -> dict:
        d = {"id": self.id, "parent": self.parent, "rule": self.rule, "kind": self.kind, "via": self.via,
             "origin": [round(v, 6) for v in self.origin], "axes": [[round(v, 6) for v in a] for a in self.axes],
             "size": [round(v, 6) for v in self.size], "seed": self.seed, "file": self.file,
             "line": self.line, "terminal": self.terminal}
        if nested:
            d["children"] = [c.to_dict(True) for c in self.children]
        return d


def compose(ctx: Derivation, where: Any) -> tuple[Any, Any]:
    """Unite the added solids, subtract the cuts (one batched boolean each); check the result.
    Also sorts the face terminals and recesses into views of the solid and the surface layer
    (`ctx.surface`, see `surface_layer`)."""
    if ctx.surfaces_mode == "solid":
        drop_unspanned_closings(ctx)  # before anything reads `adds` or `solid_of`
    on_solid = ctx.is_on_solid
    tags = ctx.tags
    cuts = []
    for cut in ctx.cuts:
        if on_solid(cut[1]):
            cuts.append(cut[0])
            _mark_body(tags[ctx.solid_of[cut[1][0]][1]])
    ctx.painting = []
    for f in ctx.faces:
        if on_solid(f[5]):
            ctx.painting.append(f)
            _mark_body(tags[ctx.solid_of[f[5][0]][1]])
        elif ctx.surfaces_mode == "solid" and f[0] not in ctx.holes:  # off every solid: a closed part
            ctx.add_slab(f[0], f[1], f[2], f[3], f[4], where)
    if ctx.surfaces_mode == "solid":
        _close_reveals(ctx, where)
    # parts inside an opening and clear of every other part leave the union (union.py)
    free = free_parts(ctx) if ctx.surfaces_mode == "solid" else {}
    for index, holes in ctx.openings.items():  # openings cut out of their own solid only
        ctx.adds[index] = Manifold.batch_boolean([ctx.adds[index], *holes], manifold3d.OpType.Subtract)
    if free:
        ctx.adds = [a for i, a in enumerate(ctx.adds) if i not in free]
        ctx.add_boxes = [b for i, b in enumerate(ctx.add_boxes) if i not in free]
    adds, post = ctx.adds, ctx.post_adds
    ctx.surface = surface_layer(ctx)
    if not adds and not post:
        if len(ctx.surface[1]):
            empty = Manifold()
            return empty, empty.to_mesh()
        raise DerivationError("the derivation produced nothing: no volume (solid) and no surface (every "
                              "shape was deleted, or ended with no area)", where, code="empty-model")
    ctx.check_triangles(ctx.est_tris, where)
    if not adds:
        adds, post = post, []
    boxes = ctx.add_boxes if adds is ctx.adds and len(ctx.add_boxes) == len(adds) else None
    groups = None
    if not post and len(adds) >= MIN_GROUPED:
        if boxes is None:
            boxes = [tuple(m.bounding_box()) for m in adds]
        # the R-tree costs ~1.5 ms per 150 solids: asked when the boxes fall apart along an
        # axis (then there are separate groups), or when there are many solids
        if len(adds) >= ALWAYS_GROUPED or _gap_along_an_axis(boxes):
            groups = _disjoint_groups(adds, boxes)
    if groups is not None and len(groups) > 1:
        body = _compose_groups(adds, cuts, groups)  # slivers dropped group by group
    else:
        body = adds[0] if len(adds) == 1 else Manifold.batch_boolean(adds, manifold3d.OpType.Add)
        if cuts:
            body = Manifold.batch_boolean([body, *cuts], manifold3d.OpType.Subtract)
        if post:
            body = Manifold.batch_boolean([body, *post], manifold3d.OpType.Add)
        body = _drop_slivers(body)
    mesh = body.to_mesh()
    status = body.status()
    if status != manifold3d.Error.NoError:
        raise DerivationError(f"the mesh boolean failed ({status.name})", where, code="boolean-failed")
    if free:
        body, mesh = with_free_parts(body, mesh, list(free.values()))
    n = len(mesh.tri_verts)
    if n == 0 and not len(ctx.surface[1]):
        raise DerivationError("the resulting mesh is empty (everything was cut away?)", where,
                              code="empty-model")
    # Solids touching exactly along an edge or at a point leave distinct vertices at one
    # position, which a reader welding by position turns into non-manifold edges: pull them
    # apart (sub-millimetre; see pinches.py). Costs ~0.1 ms when there is nothing to do.
    groups = coincident_groups(mesh.vert_properties) if n and not free else None  # (free: done)
    if groups:  # the moved mesh's manifold is built when asked for (Model.manifold)
        _none, moved = separate(body, mesh, groups, build=False)
        body, mesh = LazySolid(moved, lambda solid=body: solid), moved
    ctx.check_triangles(n, where)
    return body, mesh


def _mark_body(tag: list) -> None:
    """A solid with face terminals painted on it (or cut into) is a body; a closing solid
    (comp(f)'s volume kept by the default mode) keeps its role."""
    if tag[6] != "closing":
        tag[6] = "body"


def _close_reveals(ctx: Derivation, where: Any) -> None:
    """`surfaces="solid"`: the reveal of a recess with no solid behind it (its face was off
    every solid, so it is a slab) becomes a closed part, its walls THICKNESS thick."""
    from ..geometry.closing import close_mesh
    from ..geometry.surfaces import reveal_triangles

    keep = []
    for cut in ctx.cuts:
        _solid, on, tag, o, ax, sz, poly, depth = cut
        if ctx.is_on_solid(on):
            keep.append(cut)
            continue
        V, F = reveal_triangles(o, ax, sz, poly, depth)
        solid = close_mesh(V, F) if len(F) else None
        if solid is not None:
            solid = solid.as_original()  # a new original ID (close_mesh caches)
            ctx.id_tag[solid.original_id()] = tag
            ctx.adds.append(solid)
            ctx.add_boxes.append(tuple(solid.bounding_box()))
            ctx.est_tris += solid.num_tri()
    ctx.cuts = keep
    ctx.check_triangles(ctx.est_tris, where)


def surface_layer(ctx: Derivation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The surface layer: world vertices, triangles and the tag of each triangle, from the
    face terminals that are not views of an emitted solid, the reveals of recesses without a
    solid behind them, and open surfaces (inserted open meshes), in that order."""
    from ..geometry.surfaces import face_triangles, reveal_triangles

    on_solid = ctx.is_on_solid
    pieces: list[tuple[int, np.ndarray, np.ndarray]] = []
    solid_mode = ctx.surfaces_mode == "solid"  # faces off every solid are slabs (compose)
    for tag, o, ax, sz, poly, on in ctx.faces:
        if not solid_mode and not on_solid(on):
            V, F = face_triangles(o, ax, sz, poly)
            if len(F):
                pieces.append((tag, V, F))
    for _solid, on, tag, o, ax, sz, poly, depth in ctx.cuts:
        if not on_solid(on):
            V, F = reveal_triangles(o, ax, sz, poly, depth)
            if len(F):
                pieces.append((tag, V, F))
    pieces.extend(ctx.surfaces)
    if not pieces:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    verts, tris, tags = [], [], []
    offset = 0
    for tag, V, F in pieces:
        verts.append(V)
        tris.append(F + offset)
        tags.append(np.full(len(F), tag, dtype=np.int64))
        offset += len(V)
    return np.concatenate(verts), np.concatenate(tris), np.concatenate(tags)


# Solids whose (grown) bounding boxes touch no other solid's cannot overlap it: such groups are
# united on their own and put side by side with Manifold.compose, which costs nothing, instead
# of one union of everything (a model of many separate parts: pipes, plants, kiosks). Below
# this many solids the single union is as fast; a model of one connected group (a building,
# every part welded to the next) takes the single union exactly as before (its boxes leave no
# gap along any axis, so the groups are not even looked for below ALWAYS_GROUPED solids).
MIN_GROUPED = 16


ALWAYS_GROUPED = 256


def _gap_along_an_axis(boxes: list) -> bool:
    """Whether the boxes' extents along x, y or z leave a gap (a plane between two groups of
    solids): sort-and-sweep, no pairs."""
    arr = np.asarray(boxes, dtype=np.float64)
    for k in range(3):
        lo, hi = arr[:, k], arr[:, k + 3]
        order = np.argsort(lo, kind="stable")
        reach = np.maximum.accumulate(hi[order])
        if (lo[order][1:] > reach[:-1]).any():
            return True
    return False


def _disjoint_groups(solids: list, boxes: list | None = None) -> list[list[int]]:
    """Indices of the solids in groups whose bounding boxes (closed; given, or asked from the
    solids) overlap, transitively; an R-tree finds the neighbours, union-find joins them.
    Groups in order of their first solid."""
    from rtree import index

    props = index.Property()
    props.dimension = 3
    if boxes is None:
        boxes = [tuple(m.bounding_box()) for m in solids]
    tree = index.Index(((i, b, None) for i, b in enumerate(boxes)), properties=props)
    parent = list(range(len(solids)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for i, b in enumerate(boxes):
        for j in tree.intersection(b):
            a, c = find(i), find(j)
            if a != c:
                parent[max(a, c)] = min(a, c)
    groups: dict[int, list[int]] = {}
    for i in range(len(solids)):
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values(), key=lambda g: g[0])


def _compose_groups(adds: list, cuts: list, groups: list[list[int]]) -> Any:
    """The union of `adds` minus `cuts`, group by group (each cut only where its box meets the
    group's), the groups composed side by side."""
    parts = []
    cut_boxes = [tuple(c.bounding_box()) for c in cuts]
    for g in groups:
        solid = adds[g[0]] if len(g) == 1 else Manifold.batch_boolean([adds[i] for i in g], manifold3d.OpType.Add)
        x0, y0, z0, x1, y1, z1 = solid.bounding_box()
        mine = [c for c, (a0, b0, c0, a1, b1, c1) in zip(cuts, cut_boxes)
                if a0 <= x1 and x0 <= a1 and b0 <= y1 and y0 <= b1 and c0 <= z1 and z0 <= c1]
        if mine:
            solid = Manifold.batch_boolean([solid, *mine], manifold3d.OpType.Subtract)
        if len(g) > 1 or mine:  # a lone solid untouched by cuts has no slivers
            solid = _drop_slivers(solid)
        parts.append(solid)
    return Manifold.compose(parts)


def _drop_slivers(body: Any) -> Any:
    if not may_have_slivers(body.to_mesh()):
        return body
    pieces = body.decompose()
    if len(pieces) < 2:
        return body
    keep = [p for p in pieces if abs(p.volume()) > SLIVER_VOLUME]
    if len(keep) == len(pieces) or not keep:
        return body
    return keep[0] if len(keep) == 1 else Manifold.compose(keep)


class Model:
    """One derived building.

    - `mesh`: a trimesh with per-face colours (one watertight manifold; `process=False`)
    - `manifold`: the manifold3d solid
    - `parts`: the terminals with their tags (rule, object type, colour, material) and scopes
    - `tree` / `tree_dict()`: the derivation tree
    - `triangle_tags`: for every triangle, the index into `tags` of what it came from
    - `save(path, format=None)`: write through the exporter registry (GLB: +Y up, a PBR material
      per (material, colour), a node per terminal name; docs/derive.md "Files")
    - `face_labels()`: the terminal name of every triangle; `export_scene()`: what exporters get
    - `to_scene()`: a trimesh.Scene (one node with face colours)
    - `_repr_png_()`: a picture for Jupyter
    """

    def __init__(self, name: str, seed: int, attrs: dict[str, Any], ctx: Derivation, manifold: Any,
                 mesh: Any, warnings: list[str], bindings: dict[str, str]):
        self.name = name
        self.seed = seed
        self.attrs = attrs
        self._manifold = manifold
        self._mesh = mesh
        self._ctx = ctx
        self.warnings = warnings
        self.bindings = bindings

    @property
    def manifold(self) -> Any:
        """The manifold3d solid (built from the mesh on first use where compose deferred it)."""
        if isinstance(self._manifold, LazySolid):
            self._manifold = self._manifold.build()
        return self._manifold

    @manifold.setter
    def manifold(self, value: Any) -> None:
        self._manifold = value

    @property
    def messages(self) -> list[str]:
        """CGA's print(value) messages in derivation order, each `Rule: value` (the rule that
        printed it); past 10,000 the rest are counted in a last line."""
        out = list(self._ctx.messages)
        if self._ctx.messages_dropped:
            out.append(f"... {self._ctx.messages_dropped} more messages not kept")
        return out

    @cached_property
    def reports(self) -> dict[str, dict]:
        """CGA's reports: per key of `report(key, value)`, the number of values `n`, and for
        numbers (booleans count as 0/1) `sum`, `mean`, `min`, `max`; for strings the count of
        each distinct value (`values`). Keys in the order they were first reported."""
        out: dict[str, dict] = {}
        for key, values in self._ctx.reports.items():
            nums = [float(v) for v in values if isinstance(v, (int, float))]
            texts = [v for v in values if isinstance(v, str)]
            entry: dict[str, Any] = {"n": len(values)}
            if nums:
                total = math.fsum(nums)
                entry.update(sum=total, mean=total / len(nums), min=min(nums), max=max(nums))
            if texts:
                counts: dict[str, int] = {}
                for v in texts:
                    counts[v] = counts.get(v, 0) + 1
                entry["values"] = dict(sorted(counts.items()))
            out[key] = entry
        return out

    @cached_property
    def tags(self) -> list[Tag]:
        """Semantic tags of every solid and face terminal (indexed by `triangle_tags`)."""
        return [Tag(*t) for t in self._ctx.tags]

    # -- mesh ----------------------------------------------------------------------------------
    @property
    def vertices(self) -> np.ndarray:
        return np.asarray(self._mesh.vert_properties, dtype=np.float64)[:, :3]

    @property
    def faces(self) -> np.ndarray:
        return np.asarray(self._mesh.tri_verts, dtype=np.int64).reshape(-1, 3)

    @property
    def triangle_count(self) -> int:
        """Every triangle the model holds, both layers: the solid's (`mesh`, `faces`) and the
        surface layer's (`surface_mesh`, `surface_faces`); what a written file holds too.
        `solid_triangle_count` and `surface_triangle_count` are the two parts."""
        return self.solid_triangle_count + self.surface_triangle_count

    @property
    def solid_triangle_count(self) -> int:
        """Triangles of the watertight solid (`mesh`); 0 when the model has no solid."""
        return len(self._mesh.tri_verts)

    @property
    def surface_triangle_count(self) -> int:
        """Triangles of the open surface layer (`surface_mesh`)."""
        return len(self._ctx.surface[1])

    # -- the surface layer -----------------------------------------------------------------
    @property
    def surface_vertices(self) -> np.ndarray:
        """World vertices of the surface layer (face terminals that are not views of an
        emitted solid, recess reveals without a solid behind them, open inserted meshes)."""
        return self._ctx.surface[0]

    @property
    def surface_faces(self) -> np.ndarray:
        return self._ctx.surface[1]

    @property
    def surface_tags(self) -> np.ndarray:
        """Tag index (into `tags`) of every surface triangle."""
        return self._ctx.surface[2]

    @cached_property
    def surface_mesh(self) -> Any:
        """The surface layer as a trimesh with face colours (open: not part of the solid's
        watertight guarantee), or None when the model has no surfaces."""
        import trimesh

        if not len(self.surface_faces):
            return None
        palette = np.array([rgba_of(t.color, CUT_COLOR if t.role == "cut" else DEFAULT_COLOR) for t in self.tags],
                           dtype=np.uint8)
        return trimesh.Trimesh(vertices=self.surface_vertices, faces=self.surface_faces,
                               face_colors=palette[self.surface_tags], process=False,
                               metadata={"name": self.name, "seed": self.seed, "surface": True})

    @cached_property
    def triangle_tags(self) -> np.ndarray:
        """Tag index per triangle: the solid it came from, then face terminals painted on top."""
        mesh = self._mesh
        ntri = len(mesh.tri_verts)
        out = np.full(ntri, -1, dtype=np.int64)
        run_ids = np.asarray(mesh.run_original_id)
        run_index = np.asarray(mesh.run_index, dtype=np.int64) // 3
        id_tag = self._ctx.id_tag
        for k, oid in enumerate(run_ids):
            out[run_index[k]:run_index[k + 1]] = id_tag.get(int(oid), -1)
        self._paint_faces(out)
        return out

    def _paint_faces(self, out: np.ndarray) -> None:
        """Face terminals have no volume: they colour the body triangles lying in their region."""
        raw = self._ctx.tags  # plain lists [name, rule, otype, color, material, node, role]
        solid_of = self._ctx.solid_of
        # a face with a colour, material or texture paints its solid; on a closing solid (the
        # default mode's comp(f) volume) every face does: its region is what CGA shows
        faces = [f for f in self._ctx.painting if raw[f[0]][3] or raw[f[0]][4] or raw[f[0]][7] is not None
                 or raw[solid_of[f[5][0]][1]][6] == "closing"]
        reveal = self._ctx.reveal_tags
        if reveal:  # the walls of an opening paint the opening's triangles (tagged "cut") only
            self._paint_region(out, [f for f in faces if f[0] not in reveal], ("body", "closing"))
            self._paint_region(out, [f for f in faces if f[0] in reveal], ("cut",))
        else:
            self._paint_region(out, faces, ("body", "closing"))

    def _paint_region(self, out: np.ndarray, faces: list, roles: tuple) -> None:
        """Each face's tag onto the triangles of a tag with one of `roles` in its region."""
        if not faces:
            return
        raw = self._ctx.tags
        is_body = np.array([t[6] in roles for t in raw] + [False], dtype=bool)
        idx = np.nonzero(is_body[out])[0]
        if len(idx) == 0:
            return
        V = self.vertices
        T = self.faces[idx]
        a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
        cen = (a + b + c) / 3.0
        nrm = np.cross(b - a, c - a)
        ln = np.linalg.norm(nrm, axis=1)
        ok = ln > 1e-12
        nrm[ok] /= ln[ok, None]
        tol = 2 * WELD
        # Group faces by plane and in-plane axes (vectorised: one key row per face), then per
        # facade plane one triangle selection and a (faces x triangles) rectangle test.
        O = np.array([f[1] for f in faces], dtype=np.float64)
        AX = np.array([f[2] for f in faces], dtype=np.float64)
        SZ = np.array([f[3][:2] for f in faces], dtype=np.float64)
        TAG = np.array([f[0] for f in faces], dtype=np.int64)
        keys = np.column_stack([np.round(AX[:, 0], 6), np.round(AX[:, 2], 6),
                                np.round(np.einsum("ij,ij->i", O, AX[:, 2]), 5)])
        _, first, gid = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        gid = gid.reshape(-1)
        order = np.argsort(gid, kind="stable")  # members of a group in face order
        bounds = np.searchsorted(gid[order], np.arange(len(first) + 1))
        for g in np.argsort(first, kind="stable").tolist():  # groups in order of first appearance
            members = order[bounds[g]:bounds[g + 1]]
            m0 = members[0]
            o0 = O[m0]
            ex, ey, ez = AX[m0]
            d = cen - o0
            m = (np.abs(d @ ez) < 4 * WELD) & (nrm @ ez > 0.99)
            if not m.any():
                continue
            rows = np.nonzero(m)[0]
            U, W = d[rows] @ ex, d[rows] @ ey
            rel = O[members] - o0
            starts = np.column_stack([rel @ ex, rel @ ey])
            sizes = SZ[members]
            inside = ((U[None, :] > starts[:, :1] - tol) & (U[None, :] < starts[:, :1] + sizes[:, :1] + tol)
                      & (W[None, :] > starts[:, 1:] - tol) & (W[None, :] < starts[:, 1:] + sizes[:, 1:] + tol))
            for k, fi in enumerate(members.tolist()):
                poly = faces[fi][4]
                if poly is not None and inside[k].any():
                    cols = np.nonzero(inside[k])[0]
                    inside[k, cols] = _in_contours(U[cols] - starts[k, 0], W[cols] - starts[k, 1], poly)
            hit = inside.any(axis=0)
            if not hit.any():
                continue
            last = len(members) - 1 - np.argmax(inside[::-1], axis=0)  # the latest face wins
            out[idx[rows[hit]]] = TAG[members][last[hit]]

    @cached_property
    def mesh(self) -> Any:
        import trimesh

        tags = self.triangle_tags
        palette = np.array([rgba_of(t.color, CUT_COLOR if t.role == "cut" else DEFAULT_COLOR) for t in self.tags]
                           + [rgba_of(None, DEFAULT_COLOR)], dtype=np.uint8)
        meta = {"name": self.name, "seed": self.seed}
        if not len(tags):
            # no solid (a model of face terminals only): an empty mesh without colours (trimesh
            # makes face colours of shape (0, 5) from an empty array, and such a mesh cannot be copied)
            return trimesh.Trimesh(vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), dtype=np.int64),
                                   process=False, metadata=meta)
        colors = palette[tags]  # -1 picks the default colour appended last
        return trimesh.Trimesh(vertices=self.vertices, faces=self.faces, face_colors=colors, process=False,
                               metadata=meta)

    def _uvs(self, V: np.ndarray, F: np.ndarray, tags: np.ndarray, uv_set: int) -> np.ndarray | None:
        """Texture coordinates (n, 3, 2) of triangles `F` (with tags `tags`, -1: none) in uv set
        `uv_set`, NaN where the terminal has none; None when no triangle has any. Each tag's
        UVs are an affine map of the world position (grammarkit.split.ops.texturing)."""
        raw = self._ctx.tags
        maps = np.full((len(raw) + 1, 2, 4), np.nan)
        any_uv = False
        for i, t in enumerate(raw):
            tex = t[7]
            m = tex.get_uv(uv_set) if tex is not None else None
            if m is not None:
                maps[i] = m
                any_uv = True
        if not any_uv or not len(F):
            return None
        M = maps[tags]  # (n, 2, 4); -1 picks the NaN row appended last
        P = V[F]  # (n, 3, 3)
        return np.einsum("nkj,ncj->nck", M[:, :, :3], P) + M[:, None, :, 3]

    @cached_property
    def triangle_uvs(self) -> np.ndarray | None:
        """CGA texture coordinates of uv set 0 at the three corners of every solid triangle
        (shape (n, 3, 2); NaN where the terminal has none), or None when the model has no UVs
        (docs/cga.md, "Texturing")."""
        return self._uvs(self.vertices, self.faces, self.triangle_tags, 0)

    @cached_property
    def surface_uvs(self) -> np.ndarray | None:
        """Like `triangle_uvs`, for the surface layer's triangles."""
        return self._uvs(self.surface_vertices, self.surface_faces, self.surface_tags, 0)

    @property
    def triangle_materials(self) -> list[str | None]:
        return [self.tags[t].material if t >= 0 else None for t in self.triangle_tags]

    # -- parts and tree ------------------------------------------------------------------------
    @cached_property
    def parts(self) -> list[Part]:
        ctx = self._ctx
        out = []
        for i, (t, o, ax, sz) in enumerate(ctx.leaves):
            tag = self.tags[t]
            out.append(Part(i, tag.name, tag.rule, tag.object_type, tag.color, tag.material,
                            "face" if tag.role == "face" else "volume", tag.node, o, ax, sz))
        return out

    @cached_property
    def _tree_nodes(self) -> list[TreeNode]:
        terminal = {self.tags[t].node: self.tags[t].name for t, *_ in self._ctx.leaves}
        nodes = []
        for i, (parent, rule, kind, o, ax, sz, seed, span, via) in enumerate(self._ctx.nodes):
            nodes.append(TreeNode(i, parent, rule, "face" if kind == "F" else "volume", via, o, ax, sz, seed,
                                  span.file if span else None, span.line if span else None, terminal.get(i)))
        for n in nodes:
            if n.parent >= 0:
                nodes[n.parent].children.append(n)
        return nodes

    @property
    def tree(self) -> TreeNode:
        return self._tree_nodes[0]

    @property
    def shape_count(self) -> int:
        return len(self._ctx.nodes)

    def tree_dict(self) -> dict:
        """JSON-able derivation tree: a flat node list (parents by id) plus model facts."""
        return {
            "grammar": self.name, "seed": self.seed, "attrs": self.attrs, "bindings": self.bindings,
            "shape_count": self.shape_count, "terminal_count": len(self._ctx.leaves),
            "triangles": self.triangle_count, "warnings": self.warnings, "reports": self.reports,
            "messages": self.messages,
            "nodes": [n.to_dict() for n in self._tree_nodes],
        }

    def tree_json(self, indent: int | None = None) -> str:
        return json.dumps(self.tree_dict(), indent=indent)

    def face_labels(self) -> list[str]:
        """The terminal name of every triangle (what the GLB groups nodes by), e.g. for a
        segmentation data set: `model.face_labels()[i]` labels `model.faces[i]`."""
        names = [t.name for t in self.tags] + [UNTAGGED]
        return [names[i] for i in self.triangle_tags.tolist()]

    def export_scene(self) -> Any:
        """The building for the exporters (`grammarkit.geometry.exporters.Scene`): one solid,
        its triangles grouped by terminal name, a material per (material name, colour), and
        per group the rules, source lines and semantic tags (docs/derive.md, "Files")."""
        return export_scene(self)

    def save(self, path: Any, format: str | None = None, textures: str = "embed",
             texture_seams: bool = False) -> Any:
        """Write the model through grammarkit's exporters (format from `format` or the suffix:
        glb, gltf, obj, stl, ply), atomically; returns the path. Colours, materials, terminal
        groups and attrs are kept (see docs/derive.md, "Files"). glTF/GLB texture images (CGA
        texturing, docs/cga.md) are embedded, or with `textures="reference"` referenced by
        URIs relative to the written file. A textured closed solid is written seamless and
        untextured, so that it reads back watertight everywhere; `texture_seams=True` writes
        it with TEXCOORD_0 (textured in viewers, open pieces to trimesh)."""
        from dataclasses import replace as replace_spec
        from functools import partial
        from pathlib import Path

        from ..geometry.exporters import encode_glb, encode_gltf, encode_with, exporter_for
        from ..fileio import write_files

        path = Path(path)
        spec = exporter_for(path, format)
        if textures not in ("embed", "reference"):
            raise ValueError(f"textures must be 'embed' or 'reference', got {textures!r}")
        if textures != "embed" or texture_seams:
            encoders = {"glb": encode_glb, "gltf": encode_gltf}
            if spec.format in encoders:
                spec = replace_spec(spec, encode=partial(encoders[spec.format], textures=textures,
                                                         base=path.parent, texture_seams=texture_seams))
        write_files({path: encode_with(spec, self)})
        return path

    def _repr_png_(self) -> bytes:
        """A shaded picture for Jupyter (grammarkit's CPU renderer, default camera)."""
        import io

        from ..geometry.render import render

        buf = io.BytesIO()
        render(self, style="shaded+lines", size=(480, 480)).save(buf, format="PNG")
        return buf.getvalue()

    def to_scene(self) -> Any:
        """A trimesh.Scene with the building as one node whose extras carry the model facts."""
        import trimesh

        scene = trimesh.Scene()
        extras = {"grammar": self.name, "seed": self.seed,
                  "attrs": {k: v for k, v in self.attrs.items() if isinstance(v, (int, float, str, bool))},
                  "materials": sorted({t.material for t in self.tags if t.material})}
        if self._ctx.reports:
            extras["reports"] = self.reports
        scene.add_geometry(self.mesh, node_name=self.name or "building", geom_name=self.name or "building",
                           metadata=extras)
        scene.metadata.update(extras)
        return scene

    def __repr__(self) -> str:
        return (f"Model({self.name!r}, seed={self.seed}, shapes={self.shape_count}, "
                f"terminals={len(self._ctx.leaves)}, triangles={self.triangle_count})")


def _in_contours(u: np.ndarray, v: np.ndarray, contours: Any) -> np.ndarray:
    """Even-odd point-in-polygon test for points (u, v) against several contours."""
    inside = np.zeros(len(u), dtype=bool)
    for c in contours:
        pts = np.asarray(c, dtype=float)
        x0, y0 = pts[:, 0], pts[:, 1]
        x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
        for k in range(len(pts)):
            cond = (y0[k] > v) != (y1[k] > v)
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = x0[k] + (v - y0[k]) * (x1[k] - x0[k]) / (y1[k] - y0[k])
            inside ^= cond & (u < xc)
    return inside

