"""Holes: sites that must be filled wherever they open inside the shape (issue 28).

`constraint filled(T, "s")` holds when every T part whose site s (each of its turned and
mirrored images) opens *inside* the shape has a neighbour there. A site image opens inside when
its probe point, a quarter of the part's diagonal beyond the site along its facing, lies

- within the shape's **outline**: the footprint of all parts seen along the up axis (the union
  of each part's convex outline, its vertices' 2D convex hull grown by the contact tolerance,
  so the outline turns with the shape: a tiling turned by 30 degrees has the same outline,
  turned) with its enclosed holes filled, rasterised on a grid of at most `MAX_CELLS` cells
  a side; and
- between the shape's lowest and highest points along the up axis.

So a tile on the border of a tiling may leave its outer side open, while a tile next to a
missing one (a hole: the gap is enclosed by the outline) may not. `learn` writes `filled` for
every site that all examples fill wherever it opens inside (and is not already `required`),
the violation names the part and the site.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["MAX_CELLS", "Footprint", "check_filled", "open_sites", "shape_outline"]

MAX_CELLS = 1024
_PROBE = 0.25  # probe distance beyond a site, in part diagonals


class Footprint:
    """The shape's outline along the up axis, holes filled, as a boolean raster."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, up_axis: int, tolerance: float,
                 meshes: Sequence[Any] | None = None):
        """`lo`, `hi`: the parts' bounding boxes; `meshes` (one per part, world coordinates):
        each part's convex outline is rasterised instead of its bounding rectangle."""
        from scipy.ndimage import binary_fill_holes

        self.k = up_axis
        self.h = [a for a in range(3) if a != up_axis]
        self.zlo = float(lo[:, up_axis].min()) - tolerance
        self.zhi = float(hi[:, up_axis].max()) + tolerance
        lo2, hi2 = lo[:, self.h] - tolerance, hi[:, self.h] + tolerance
        self.origin = lo2.min(axis=0)
        span = hi2.max(axis=0) - self.origin
        small = np.maximum(np.min(hi2 - lo2, axis=1), 1e-12)
        # cells a third of the smallest part across (a one-part hole spans several), bounded
        self.cell = float(max(np.min(small) / 3.0, span.max() / MAX_CELLS, 1e-12))
        shape = np.maximum(np.ceil(span / self.cell).astype(np.int64), 1)
        grid = np.zeros(tuple(shape), dtype=bool)
        # cells whose centres lie in a part's (grown) rectangle
        a = np.clip(np.ceil((lo2 - self.origin) / self.cell - 0.5).astype(np.int64), 0, shape)
        b = np.clip(np.floor((hi2 - self.origin) / self.cell - 0.5).astype(np.int64) + 1, 0, shape)
        outlines = _Outlines(self.h, tolerance) if meshes is not None else None
        for i, ((x0, y0), (x1, y1)) in enumerate(zip(a.tolist(), b.tolist())):
            eq = outlines.of(meshes[i]) if outlines is not None and meshes is not None else None
            if eq is None:  # a rectangle along the axes: its bounding rectangle
                grid[x0:x1, y0:y1] = True
                continue
            if x1 <= x0 or y1 <= y0:
                continue
            gx, gy = np.meshgrid(np.arange(x0, x1), np.arange(y0, y1), indexing="ij")
            centres = self.origin + (np.stack([gx.ravel(), gy.ravel()], axis=1) + 0.5) * self.cell
            keep = (centres @ eq[:, :2].T + eq[:, 2] <= tolerance).all(axis=1)
            grid[gx.ravel()[keep], gy.ravel()[keep]] = True
        self.grid = binary_fill_holes(grid)

    def inside(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ij = np.floor((points[:, self.h] - self.origin) / self.cell).astype(np.int64)
        ok = (ij >= 0).all(axis=1) & (ij < np.array(self.grid.shape)).all(axis=1)
        ok &= (points[:, self.k] >= self.zlo) & (points[:, self.k] <= self.zhi)
        out = np.zeros(len(points), dtype=bool)
        out[ok] = self.grid[ij[ok, 0], ij[ok, 1]]
        return out


class _Outlines:
    """Per part, its convex outline along the up axis as half-planes (rows a, b, c: a x + b y
    + c <= 0 inside), computed once per distinct shape up to translation; None for a part
    whose outline is its bounding rectangle (an axis-aligned box: the fast path)."""

    def __init__(self, h: list[int], tolerance: float):
        self.h = h
        self.tolerance = tolerance
        self.known: dict[bytes, np.ndarray | None] = {}

    def of(self, mesh: Any) -> np.ndarray | None:
        V = np.asarray(mesh.vertices, dtype=np.float64)[:, self.h]
        if len(V) < 3:
            return None
        lo = V.min(axis=0)
        span = float(np.abs(V.max(axis=0) - lo).max()) or 1.0
        rel = V - lo
        key = np.unique(np.round(rel / (1e-6 * span)).astype(np.int64), axis=0).tobytes()
        if key not in self.known:
            self.known[key] = self._hull(rel, span)
        eq = self.known[key]
        if eq is None:
            return None
        out = eq.copy()
        out[:, 2] -= eq[:, :2] @ lo  # shifted back to where the part is
        return out

    def _hull(self, rel: np.ndarray, span: float) -> np.ndarray | None:
        from scipy.spatial import ConvexHull, QhullError

        try:
            hull = ConvexHull(rel)
        except (QhullError, ValueError):
            return None  # flat or degenerate along the up axis: its rectangle
        ext = rel.max(axis=0) - rel.min(axis=0)
        if hull.volume >= float(np.prod(ext)) * (1 - 1e-6) or hull.volume <= 1e-12 * span * span:
            return None  # fills its bounding rectangle (or has no area): the rectangle is exact
        return np.asarray(hull.equations, dtype=np.float64)


def shape_outline(rules: Any, shape: Any, tolerance: float) -> Footprint | None:
    """The shape's outline along the grammar's up axis; None without an up axis or parts."""
    from .validate import _up

    up = _up(rules)
    if up is None or not len(shape.nodes):
        return None
    k = int(np.argmax(np.abs(up)))
    return Footprint(shape.lo, shape.hi, k, tolerance,
                     [shape.part(i).mesh for i in range(len(shape.nodes))])


def open_sites(rules: Any, shape: Any, wanted: dict[str, list[str]], tolerance: float,  # noqa: ANN201
               outline: Footprint | None = None):
    """Per (part index, type, site): (inside mask, filled mask) over the site's images, for the
    sites in `wanted` (type -> names). Empty without an up axis (no outline to speak of).
    `outline`: the shape's, when the caller has it already (shape_outline)."""
    from .validate import site_occupancy

    if outline is None:
        outline = shape_outline(rules, shape, tolerance)
    if outline is None:
        return
    for i, t, name, pos, facing, filled in site_occupancy(rules, shape, wanted):
        probe = pos + facing * (_PROBE * float(shape.diag[i]))
        yield i, t, name, outline.inside(probe), filled


def check_filled(graph: Any, args: dict[str, Any], context: dict | None = None) -> list[str]:
    from .validate import _Shape

    context = context or {}
    rules, assembly = context.get("rules"), context.get("assembly")
    t, site = str(args["type"]), str(args["site"])
    if rules is None or assembly is None:
        return []  # no geometry: nothing to say where a site opens
    if t in rules.parts and not any(s.name == site for s in rules.sites.get(t, ())):
        return [f"filled({t}, {site!r}): {t} has no site {site!r}"]
    tol = float(graph.graph.get("tolerance", 1e-6))
    # One validate checks every `filled` constraint against the same graph in one context: the
    # shape and its outline (most of the check's time on a facade) are built once for them all.
    cached = context.get("filled_outline")
    if cached is not None and cached[0] is graph and cached[1] == tol:
        shape, outline = cached[2], cached[3]
    else:
        shape = _Shape(assembly, graph)
        outline = shape_outline(rules, shape, tol)
        context["filled_outline"] = (graph, tol, shape, outline)
    if outline is None:
        return []
    out = []
    for i, _, _, inside, filled in open_sites(rules, shape, {t: [site]}, tol, outline):
        holes = int((inside & ~filled).sum())
        if holes:
            out.append(f"part {shape.nodes[i]} ({t}): site {t}.{site} opens inside the shape and has nothing "
                       f"docked ({holes} of its {len(filled)} position(s)): a hole")
    return out


def filled_sites(rules: Any, shapes: list, skip: set[tuple[str, str]]) -> list[tuple[str, str]]:
    """(type, site) pairs every example fills wherever they open inside (and that open inside
    somewhere: a site always on the outline says nothing), `skip` aside: what `learn` writes
    as `constraint filled(T, "s")`."""
    wanted = {t: [s.name for s in sts if (t, s.name) not in skip] for t, sts in rules.sites.items()}
    seen: dict[tuple[str, str], int] = {}
    broken: set[tuple[str, str]] = set()
    for shape in shapes:
        tol = float(shape.graph.graph.get("tolerance", 1e-6))
        for _, t, name, inside, filled in open_sites(rules, shape, wanted, tol):
            seen[(t, name)] = seen.get((t, name), 0) + int(inside.sum())
            if (inside & ~filled).any():
                broken.add((t, name))
    return sorted(k for k, n in seen.items() if n and k not in broken)
