"""CGA's scope axes -> grammarkit's, per kind of shape.

CityEngine's scopes follow two conventions, and the importer tracks which one a shape is in
(statically, per rule: a rule reached in both is translated once for each):

- `Y` (**y-up**): the initial lot and every volume extruded from it. CGA's y is the lot
  normal (up) and z lies in the lot plane, pointing to the street (the front). grammarkit's
  footprints and volumes are z-up with the front edge at y = 0 (`comp` "front" faces -y), so
  CGA (x, y, z) = grammarkit (x, z, -y): `split(y)` is grammarkit's `split(z)`, and
  `split(z)` is `split(y)` with the parts in reverse order (CGA's z runs from the back to
  the street, grammarkit's y from the street to the back).
- `Z` (**face**): faces made by `comp(f)` and volumes extruded from them. Both systems put x
  along the face's first edge, y up the face and z along the normal: the identity.

Volumes of kind `Z` (a facade tile extruded into a balcony) have their CGA "top" at +y, which
is grammarkit's "back" (`comp` names faces by the volume's own axes): `comp_selectors`
maps the names.
"""
from __future__ import annotations

from typing import Literal

Frame = Literal["Y", "Z"]

# CGA axis -> (grammarkit axis, reversed direction)
_AXES: dict[str, dict[str, tuple[str, bool]]] = {
    "Y": {"x": ("x", False), "y": ("z", False), "z": ("y", True)},
    "Z": {"x": ("x", False), "y": ("y", False), "z": ("z", False)},
}

# CGA scope size/position names -> grammarkit names
_SCOPE: dict[str, dict[str, str]] = {
    "Y": {"sx": "sx", "sy": "sz", "sz": "sy", "tx": "tx", "ty": "tz", "tz": "ty"},
    "Z": {"sx": "sx", "sy": "sy", "sz": "sz", "tx": "tx", "ty": "ty", "tz": "tz"},
}

# CGA comp(f) selector -> grammarkit selectors (first match wins in both systems)
_SELECTORS: dict[str, dict[str, tuple[str, ...]]] = {
    "Y": {"front": ("front",), "back": ("back",), "left": ("left",), "right": ("right",),
          "top": ("top",), "bottom": ("bottom",), "side": ("side",), "all": ("all",),
          "vertical": ("vertical",), "horizontal": ("horizontal",), "aslant": ("aslant",),
          "nutant": ("nutant",)},
    "Z": {"front": ("top",), "back": ("bottom",), "left": ("left",), "right": ("right",),
          "top": ("back",), "bottom": ("front",), "side": ("top", "bottom", "left", "right"),
          "all": ("all",),
          # CGA's horizontal faces look along its y (up the facade): grammarkit's +-y, the
          # quadrants `back`/`front` (exact for boxes); vertical ones are the other four
          "horizontal": ("back", "front"), "vertical": ("top", "bottom", "left", "right")},
}


def axis(frame: Frame, cga_axis: str) -> tuple[str, bool]:
    """(grammarkit axis, reversed) for a CGA split axis in this frame."""
    return _AXES[frame][cga_axis]


def scope_name(frame: Frame, cga_name: str) -> str | None:
    """`scope.sy` in CGA -> `scope.sz` in grammarkit (frame Y); None for names not mapped."""
    prefix, _, attr = cga_name.partition(".")
    if prefix != "scope" or attr not in _SCOPE[frame]:
        return None
    return "scope." + _SCOPE[frame][attr]


def comp_selectors(frame: Frame, selector: str) -> tuple[str, ...] | None:
    return _SELECTORS[frame].get(selector)


def center_axes(frame: Frame, axes: str) -> str | None:
    """`center(xz)` -> grammarkit's axes string, letters sorted (`xy`), or None."""
    try:
        mapped = {_AXES[frame][a][0] for a in axes}
    except KeyError:
        return None
    return "".join(sorted(mapped))


# CGA setback edge selector -> (grammarkit selectors, approximation note or None). Edges are
# classified by their outward normal in the face's plane: on a lot (frame Y) CGA's scope
# quadrants front/back/left/right are grammarkit's, no edge is top/bottom and `side` is every
# edge; on a facade (frame Z) top/bottom are grammarkit's top/bottom (the scope's +-y) and
# front/back take no edge. World quadrants keep their names (grammarkit's world is z-up with
# +y north, CGA's y-up with +z south). CGA's object and street quadrants fall back to the
# scope ones (street.* needs CityEngine's street-width attributes, which grammarkit lots lack).
_EDGE_BASE: dict[str, dict[str, tuple[str, ...]]] = {
    "Y": {"front": ("front",), "back": ("back",), "left": ("left",), "right": ("right",), "top": (),
          "bottom": (), "side": ("all",), "all": ("all",), "remainder": ("remainder",)},
    "Z": {"front": (), "back": (), "left": ("left",), "right": ("right",), "top": ("top",), "bottom": ("bottom",),
          "side": ("side",), "all": ("all",), "remainder": ("remainder",)},
}
_WORLD = {"world.south": ("south",), "world.north": ("north",), "world.west": ("west",), "world.east": ("east",),
          "world.side": ("all",), "world.up": (), "world.down": ()}


def edge_selectors(frame: Frame, selector: str) -> tuple[tuple[str, ...] | None, str | None]:
    """(grammarkit selectors, approximation note) for a CGA setback selector; (None, None) if
    there is no counterpart."""
    if selector in _WORLD:
        return _WORLD[selector], None
    if selector in ("streetSide", "noStreetSide"):
        # CGA 2012's street selectors read CityEngine's street-adjacency attributes; without
        # them (an initial shape that is no block's lot, as every grammarkit lot) CityEngine
        # selects no edge for either, and the remainder is the whole face (PyPRT 1.12)
        return (), (f"{selector} selects no edge: it needs CityEngine's street attributes, "
                    f"which grammarkit lots lack (as CityEngine without them)")
    prefix, _, rest = selector.rpartition(".")
    base = _EDGE_BASE[frame]
    if prefix in ("object", "street") and rest in base:
        return base[rest], (f"{selector} is taken as the scope's {rest} (grammarkit lots have no "
                            f"{'street' if prefix == 'street' else 'object'} frame)")
    if prefix:
        return None, None
    return base.get(selector), None
