"""Holes: sites that must be filled wherever they open inside the shape (issue 28).

`constraint filled(T, "s")` holds when every T part whose site s (each of its turned and
mirrored images) opens *inside* the shape has a neighbour there. A site image opens inside when
its probe point, a quarter of the part's diagonal beyond the site along its facing, lies

- within the shape's **outline**: the footprint of all parts seen along the up axis (the union
  of their bounding rectangles, each grown by the contact tolerance) with its enclosed holes
  filled, rasterised on a grid of at most `MAX_CELLS` cells a side; and
- between the shape's lowest and highest points along the up axis.

So a tile on the border of a tiling may leave its outer side open, while a tile next to a
missing one (a hole: the gap is enclosed by the outline) may not. `learn` writes `filled` for
every site that all examples fill wherever it opens inside (and is not already `required`),
the violation names the part and the site.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MAX_CELLS", "Footprint", "check_filled", "open_sites"]

MAX_CELLS = 1024
_PROBE = 0.25  # probe distance beyond a site, in part diagonals


class Footprint:
    """The shape's outline along the up axis, holes filled, as a boolean raster."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, up_axis: int, tolerance: float):
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
        for (x0, y0), (x1, y1) in zip(a.tolist(), b.tolist()):
            grid[x0:x1, y0:y1] = True
        self.grid = binary_fill_holes(grid)

    def inside(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ij = np.floor((points[:, self.h] - self.origin) / self.cell).astype(np.int64)
        ok = (ij >= 0).all(axis=1) & (ij < np.array(self.grid.shape)).all(axis=1)
        ok &= (points[:, self.k] >= self.zlo) & (points[:, self.k] <= self.zhi)
        out = np.zeros(len(points), dtype=bool)
        out[ok] = self.grid[ij[ok, 0], ij[ok, 1]]
        return out


def open_sites(rules: Any, shape: Any, wanted: dict[str, list[str]], tolerance: float):  # noqa: ANN201
    """Per (part index, type, site): (inside mask, filled mask) over the site's images, for the
    sites in `wanted` (type -> names). Empty without an up axis (no outline to speak of)."""
    from .validate import _up, site_occupancy

    up = _up(rules)
    if up is None or not len(shape.nodes):
        return
    k = int(np.argmax(np.abs(up)))
    outline = Footprint(shape.lo, shape.hi, k, tolerance)
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
    shape = _Shape(assembly, graph)
    tol = float(graph.graph.get("tolerance", 1e-6))
    out = []
    for i, _, _, inside, filled in open_sites(rules, shape, {t: [site]}, tol):
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
