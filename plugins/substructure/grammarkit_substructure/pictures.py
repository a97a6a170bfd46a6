"""A picture per operation: the model with both subgraphs highlighted (grammarkit's CPU renderer).

Parts of the removed piece S are red, parts of the copied piece S' blue, parts in both
(recursive operations, overlapping pieces) purple, the attachment parts of the cut (kept,
reconnected) yellow, everything else grey.
"""
from __future__ import annotations

import io
from typing import Sequence

import numpy as np
import trimesh

REMOVED = (214, 69, 65)
COPIED = (52, 120, 214)
BOTH = (150, 80, 190)
ATTACH = (240, 196, 40)
OTHER = (205, 205, 200)


def operation_png(meshes: Sequence[trimesh.Trimesh], op, size: tuple[int, int] = (480, 480)) -> bytes:
    """PNG bytes of `meshes` (the model, donor = host) with `op`'s pieces coloured."""
    from grammarkit.geometry.render import render

    removed, copied = set(op.removed), set(op.copied)
    attach = {b for _, _, b, _ in op.pairs}
    coloured = []
    for i, m in enumerate(meshes):
        c = BOTH if i in removed and i in copied else REMOVED if i in removed else \
            COPIED if i in copied else ATTACH if i in attach else OTHER
        mesh = trimesh.Trimesh(np.asarray(m.vertices), np.asarray(m.faces), process=False)
        mesh.visual.face_colors = np.tile(np.array([*c, 255], dtype=np.uint8), (len(mesh.faces), 1))
        coloured.append(mesh)
    buf = io.BytesIO()
    render(coloured, style="shaded+lines", size=size).save(buf, format="PNG")
    return buf.getvalue()
