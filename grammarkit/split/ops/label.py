"""label(name): the shape becomes an occluder for the occlusion queries (grammarkit.split.occlusion)."""
from __future__ import annotations

from typing import Any

from ...registry import Param
from ..shape import Shape
from .helpers import operation


@operation("label", (Param("name", "string"),),
           doc="Make the shape (as it is now) an occluder with this label for inside(), "
               "overlaps() and touches() of shapes derived later.")
def op_label(ctx: Any, s: Shape, args: Any, block: Any) -> Shape:
    """`label("name")`: the shape (as it is now) becomes an occluder named `name` for the
    occlusion queries of shapes derived later."""
    from ..occlusion import active  # manifold3d: imported when a label is made, not with the specs

    name = args[0]
    if not isinstance(name, str) or not name:
        raise ValueError(f"label(): the label must be a non-empty string, got {name!r}")
    derivation = active()
    if derivation is not None:
        derivation.occluder(s, name)
    return s
