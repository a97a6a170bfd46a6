"""Assemblies: the data that tiling grammars talk about.

An `Assembly` is a list of typed `Part`s. Each part's mesh is stored in world coordinates
(contacts, validation and docking all work in one frame); `transform` records how the part
was placed relative to its source geometry (identity when read from a file), so written
assemblies keep provenance. Reading and writing (GLB/OBJ/folder, type in node extras or a
`Type.N` name) lives in `grammarkit.tiling.io`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh


@dataclass
class Part:
    id: str  # unique within the assembly, e.g. "Tower.3"
    type: str  # the part type, e.g. "Tower"
    mesh: trimesh.Trimesh  # world coordinates
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    meta: dict[str, Any] = field(default_factory=dict)  # e.g. {"source": "small.glb"}

    @property
    def centroid(self) -> np.ndarray:
        """Area-weighted centroid of the part's surface (works for open meshes too).

        Unlike the bounding-box centre it moves rigidly with the part, which docking by
        centroid alignment (Kabsch) and centroid-distance matching rely on; it is the value
        `shape_graph` stores as the node attribute `centroid`."""
        from .frames import surface_centroid

        return surface_centroid(np.asarray(self.mesh.vertices, dtype=np.float64),
                                np.asarray(self.mesh.faces))

    def transformed(self, matrix: np.ndarray, new_id: str | None = None) -> "Part":
        mesh = self.mesh.copy()
        mesh.apply_transform(matrix)
        return Part(new_id or self.id, self.type, mesh, matrix @ self.transform, dict(self.meta))


@dataclass
class Assembly:
    parts: list[Part]
    name: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.parts)

    def by_id(self) -> dict[str, Part]:
        return {p.id: p for p in self.parts}

    @property
    def bounds(self) -> np.ndarray:
        los = np.array([p.mesh.bounds[0] for p in self.parts])
        his = np.array([p.mesh.bounds[1] for p in self.parts])
        return np.array([los.min(axis=0), his.max(axis=0)])

    @property
    def scale(self) -> float:
        """Length of the bounding-box diagonal: the unit for relative tolerances."""
        lo, hi = self.bounds
        return float(np.linalg.norm(hi - lo))

    def _repr_png_(self) -> bytes:
        """A shaded picture for Jupyter (grammarkit's CPU renderer, default camera)."""
        import io

        from ..geometry.render import render

        buf = io.BytesIO()
        render(self, style="shaded+lines", size=(480, 480)).save(buf, format="PNG")
        return buf.getvalue()

    def type_histogram(self) -> dict[str, int]:
        hist: dict[str, int] = {}
        for p in self.parts:
            hist[p.type] = hist.get(p.type, 0) + 1
        return dict(sorted(hist.items()))
