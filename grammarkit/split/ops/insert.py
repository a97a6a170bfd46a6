"""i(): insert an asset (a mesh file or a built-in) fitted to the scope."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ... import confine
from ...registry import Param
from ..shape import VOLUME, Shape
from .helpers import lazy_module, operation

geometry_solids = lazy_module("grammarkit.geometry.solids")


def fitted_size(extent: tuple, size: tuple) -> tuple[float, float, float]:
    """The size an asset of bounding box `extent` gets in a scope of `size`: the scope's size,
    except that a zero size keeps the asset's proportion on that axis (scaled like the others),
    as CGA's `i()` does (the same rule as grammarkit.geometry.solids.insert_fitted)."""
    given = [s / e for s, e in zip(size, extent) if s > 1e-12 and e > 1e-12]
    default = sum(given) / len(given) if given else 1.0
    return tuple(s if (s > 1e-12 and e > 1e-12) else e * default  # type: ignore[return-value]
                 for s, e in zip(size, extent))


def _trimmed(solid: Any, s: Shape) -> Any:
    """Clip an inserted solid or surface by the shape's trim planes (CGA: the bisector planes
    at the corners of the faces comp(f) made; a cornice inserted along a facade is mitred at
    the building's corners). The planes are in world coordinates; the solid is in the scope's."""
    box = None  # the solid's bounding box, asked again only after a cut (asking evaluates the solid)
    for point, normal in s.trims:
        ln = [sum(normal[k] * s.ax[i][k] for k in range(3)) for i in range(3)]  # world -> scope
        lp = [sum((point[k] - s.o[k]) * s.ax[i][k] for k in range(3)) for i in range(3)]
        offset = ln[0] * lp[0] + ln[1] * lp[1] + ln[2] * lp[2]
        if box is None:
            box = solid.bounding_box()
        x0, y0, z0, x1, y1, z1 = box
        # the lowest value of dot(n, p) over the bounding box: nothing to cut when it is kept
        low = sum(min(n * a, n * b) for n, a, b in zip(ln, (x0, y0, z0), (x1, y1, z1)))
        if low >= offset - 1e-9:
            continue
        solid = solid.trim_by_plane(tuple(ln), offset)
        box = None
    return solid


_FOUND: dict[tuple[str, str], Path] = {}
MISSING_FILE = ("error", "skip")


def _mesh_path(rel: str, base: str) -> tuple[Path, bool]:
    """The file an i() path names and whether it exists; a file found is remembered (a facade
    inserts the same window hundreds of times), a missing one is looked for again next time."""
    hit = _FOUND.get((rel, base))
    if hit is not None:
        return hit, True
    path = Path(rel) if Path(rel).is_absolute() else (Path(base) / rel).resolve()
    if not path.is_file():
        return path, False
    if len(_FOUND) < 4096:
        _FOUND[(rel, base)] = path
    return path, True


@operation("i", (Param("path", "string"),
                 Param("fit", "name", required=False, default="scale", names="fits",
                       doc="how the asset is fitted to the scope (a fit from the registry)"),
                 Param("missing", "axis", required=False, default="error", choices=MISSING_FILE,
                       doc="a mesh file that is not found: `error` stops the derivation, `skip` "
                       "leaves the shape out with a warning (CityEngine's behaviour)")),
           doc="Insert a mesh file fitted to the scope (`fit=scale`: scaled to it).")
def op_insert(ctx: Any, s: Shape, args: Any, block: Any) -> Shape | None:
    from ..assets import builtin_asset, load_asset, load_asset_mesh

    rel = str(args[0])  # the compiler made constant paths absolute (relative to their file)
    fit = str(args[1]) if len(args) > 1 else "scale"
    if rel.startswith("builtin:"):
        asset = builtin_asset(rel)
        path = Path(rel)
    else:
        confine.check(rel, base=ctx.base_dir or ".", what="mesh file")  # before is_file: tells no existence
        path, found = _mesh_path(rel, ctx.base_dir or ".")
        if not found:
            if len(args) > 2 and str(args[2]) == "skip":
                # CityEngine warns "asset not found" and inserts nothing: the shape is left out
                where = f"{s.rule_span}: " if s.rule_span is not None else ""
                ctx.warn(f"{where}in rule {s.rule_name!r}: i(): mesh file not found: {path} (the "
                         "shape is left out, as CityEngine does)")
                return None
            raise ValueError(f"i(): mesh file not found: {path}")
        asset = load_asset(str(path)) if fit == "scale" else None
    if fit == "scale":  # the built-in fit, on the manifold directly (no mesh round trip)
        solid, size = geometry_solids.insert_fitted(asset, s.sz)
        if s.trims and s.trim_on:
            solid = _trimmed(solid, s)
            if solid.is_empty():
                return None  # trimmed away entirely
        return _untextured(s.derived(s.o, size, None, VOLUME, solid=solid))
    if rel.startswith("builtin:"):
        raise ValueError(f"i(): fit {fit!r} needs a mesh file, not the built-in {rel!r}")
    fits = ctx.registries.fits if ctx.registries is not None else {}
    spec = fits.get(fit)
    if spec is None or spec.fit is None:
        raise ValueError(f"i(): unknown fit {fit!r}; known fits: {', '.join(sorted(fits)) or 'none'}")
    from ...geometry.convert import to_manifold

    mesh = load_asset_mesh(str(path)).copy()
    lo = mesh.bounds[0]
    mesh.apply_translation(-lo)  # the asset's bounding box minimum at the origin
    target = fitted_size(tuple(float(e) for e in mesh.extents), s.sz)
    out = spec.fit(mesh, target)
    solid = to_manifold(out, what=f"{path.name} fitted by {fit!r} (plugin {spec.plugin or '?'})")
    x0, y0, z0, x1, y1, z1 = solid.bounding_box()
    size = (x1 - x0, y1 - y0, z1 - z0)
    if not all(math.isfinite(v) for v in size) or min(size) < 0:
        raise ValueError(f"fit {fit!r} returned an empty or broken mesh for {path.name}")
    return _untextured(s.derived(s.o, size, None, VOLUME, solid=solid.translate((-x0, -y0, -z0))))


def _untextured(s: Shape) -> Shape:
    """An inserted mesh is new geometry: the UVs baked into the shape it replaces are not its
    own (grammarkit does not read assets' UVs; the material attributes stay)."""
    if s.tex is not None and s.tex.uv:
        s.tex = s.tex.replace(uv=())
    return s
