"""Binary STL (Z up): every solid as one mesh, no colours or names."""
from __future__ import annotations

from typing import Any

from .scene import world_mesh


def encode_stl(obj: Any) -> bytes:
    # STL is for solids (3D printing): a split model's surface layer is left out
    return world_mesh(obj, surfaces=False).export(file_type="stl")
