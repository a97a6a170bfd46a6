"""The operation handlers, one module per family; importing this package registers them all
in `context.HANDLERS` (each handler's registration is beside it)."""
from __future__ import annotations

from ..context import HANDLERS
from . import insert, lots, mass, material, roofs, transform  # noqa: F401 - imported to register

__all__ = ["HANDLERS"]
