"""The solid of a volume shape in its scope's coordinates (what the engine adds to the model,
and what comp(e), scatter(), the occlusion queries and the scope operations measure)."""
from __future__ import annotations

from typing import Any

import manifold3d

from ..geometry.footprints import cross_section
from .shape import Shape

Manifold = manifold3d.Manifold


def local_solid(s: Shape) -> tuple[Any, int, int]:
    """The solid of a volume shape in scope coordinates, its original ID and a triangle estimate."""
    sx, sy, sz = s.sz
    if s.solid is not None:
        solid = s.solid
        oid = solid.original_id()
        if oid < 0:
            solid = solid.as_original()
            oid = solid.original_id()
        return solid, oid, solid.num_tri()  # a roof or an inserted mesh: count what it brings
    if sz <= 1e-9 or sx <= 1e-9 or sy <= 1e-9:
        return None, -1, 0
    if s.poly is None:
        solid = Manifold.cube((sx, sy, sz))
        return solid, solid.original_id(), 12
    solid = Manifold.extrude(cross_section(s.poly), sz)
    return solid, solid.original_id(), 4 * sum(len(c) for c in s.poly)
