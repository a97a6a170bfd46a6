"""grammarkit studio: write, see and sample grammars in the browser (`grammarkit studio FILE`).

A local web app (Starlette + uvicorn, the optional extra `grammarkit[studio]`): an editor with
highlighting and inline diagnostics, a three.js view that re-derives on every valid edit,
sliders for `@range`/`@enum` attrs, the derivation tree linked both ways to the 3D parts, seeds
and variations, GLB/OBJ/STL export, a gallery of sampled variants, and a sketch canvas per
object type read by the sketch recognizer (the grammarkit_sketch plugin). See docs/studio.md.

    from grammarkit_studio import serve, running
    serve("grammars/paris.grammar")                       # blocks; prints the URL
    with running("grammars/paris.grammar") as studio:     # background thread
        studio.url

This module is light: the server stack is imported by `serve`/`running` only.
"""
from __future__ import annotations

from typing import Any

__all__ = ["serve", "running", "Studio", "missing_extra"]

EXTRA_HINT = 'python -m pip install "grammarkit[studio]"'


def missing_extra() -> str | None:
    """The name of a missing server package, or None when the studio extra is installed."""
    from importlib.util import find_spec

    for name in ("starlette", "uvicorn", "websockets"):
        if find_spec(name) is None:
            return name
    return None


def __getattr__(name: str) -> Any:
    if name in ("serve", "running"):
        from . import server

        return getattr(server, name)
    if name == "Studio":
        from .app import Studio

        return Studio
    raise AttributeError(f"module 'grammarkit_studio' has no attribute {name!r}")
