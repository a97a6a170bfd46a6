"""Helpers shared by the importer tests: translate CGA text (which must succeed) and pick one
rule's line of the translation."""
from __future__ import annotations

import numpy as np

from grammarkit.cga import translate_cga

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def imported(text: str, **kw):
    result = translate_cga(text, filename="t.cga", **kw)
    assert result.ok, [d.format(text) for d in result.diagnostics]
    return result


def line(result, rule: str) -> str:
    return next(ln for ln in result.text.splitlines() if ln.startswith(rule + " -->"))


def bbox(model) -> np.ndarray:
    """The model's bounding box over both layers (the solid and the open surfaces): 2 x 3."""
    parts = [np.asarray(model.mesh.vertices).reshape(-1, 3)]
    if model.surface_vertices is not None:
        parts.append(np.asarray(model.surface_vertices).reshape(-1, 3))
    v = np.vstack(parts)
    return np.array([v.min(axis=0), v.max(axis=0)])
