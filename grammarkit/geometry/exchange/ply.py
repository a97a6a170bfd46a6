"""Binary PLY (Z up): every solid (and the surface layer) as one mesh with face colours."""
from __future__ import annotations

from typing import Any

from .scene import world_mesh


def encode_ply(obj: Any) -> bytes:
    return world_mesh(obj).export(file_type="ply", encoding="binary")
