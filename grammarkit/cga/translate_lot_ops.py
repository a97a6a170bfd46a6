"""Translation handlers of CGA's lot, roof and face-edge operations that live outside
translate.py (same signature as translate.py's handlers: `(t, args, block, star, frame, rctx,
ctx, span, out) -> (items, block_out)`).

translate.py merges `LOT_HANDLERS` into its handler table after its own entries, so an entry
here replaces translate.py's handler of the same CGA operation.
"""
from __future__ import annotations

from typing import Any, Callable

LOT_HANDLERS: dict[str, Callable[..., Any]] = {}
