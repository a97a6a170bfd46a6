"""Wavefront OBJ: one `o`/`g` group per solid, `usemtl`-free vertex colours (`v x y z r g b`,
sRGB, split at colour seams: OBJ readers weld by position) and a `# extras {...}` line, in the
model's Z-up frame."""
from __future__ import annotations

import json
from typing import Any

import numpy as np

from ...jsonable import to_jsonable
from .scene import solids_of


def _split_color_seams(faces: np.ndarray, face_material: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(vertex index of each new vertex, new faces): one vertex per (vertex, material) pair in
    use, so that per-face colours survive formats that only store vertex colours. 1-D keys."""
    faces = np.asarray(faces, dtype=np.int64)
    n_mat = int(face_material.max()) + 1 if len(face_material) else 1
    keys = faces.reshape(-1) * n_mat + np.repeat(np.asarray(face_material, dtype=np.int64), 3)
    uniq, inv = np.unique(keys, return_inverse=True)
    return uniq // n_mat, inv.reshape(-1, 3)


def _fmt_rows(fmt: str, rows: np.ndarray) -> str:
    """Format a 2-D array as text lines, one `fmt % row` per line, in one call."""
    if len(rows) == 0:
        return ""
    return ((fmt + "\n") * len(rows)) % tuple(rows.reshape(-1).tolist())


def encode_obj(obj: Any) -> bytes:
    """OBJ with one `o`/`g` group per solid (vertex colours as `v x y z r g b`, sRGB in 0..1)
    and the solid's extras as a `# extras {...}` comment line that `load_mesh` reads back."""
    scene = solids_of(obj)
    out = ["# written by grammarkit (Z up, metres)\n"]
    offset = 1
    for solid in scene.solids:
        if len(solid.faces) == 0:
            continue
        src, faces = _split_color_seams(solid.world_faces(), solid.face_material)
        v = solid.world_vertices()[src]
        rgba = solid.face_rgba()
        vcol = np.zeros((len(src), 3), dtype=np.float64)
        vcol[faces.reshape(-1)] = np.repeat(rgba[:, :3], 3, axis=0) / 255.0
        out.append(f"o {solid.name}\ng {solid.name}\n")
        if solid.extras:
            out.append("# extras " + json.dumps(to_jsonable(solid.extras), sort_keys=True) + "\n")
        out.append(_fmt_rows("v %.9g %.9g %.9g %.4g %.4g %.4g", np.column_stack([v, vcol])))
        out.append(_fmt_rows("f %d %d %d", faces + offset))
        offset += len(v)
    return "".join(out).encode("utf-8")
