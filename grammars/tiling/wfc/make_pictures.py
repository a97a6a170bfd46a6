"""Render the tiling pictures of docs/tiling.md (support, the coast tile set) with `grammarkit render`.

    python grammars/tiling/wfc/make_pictures.py [--out docs/images]

Writes tiling_support.png (a carried stack, a block hanging on a side contact, a lifted stack),
tiling_wfc_coast.png (a valid coast tiling) and tiling_wfc_broken.png (one shore turned round).
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make_coast  # noqa: E402

from grammarkit.tiling import Assembly, Part, write_assembly  # noqa: E402


def support_scene() -> Assembly:
    parts = []

    def add(t: str, at, size) -> None:  # noqa: ANN001
        m = trimesh.creation.box(extents=size)
        T = np.eye(4)
        T[:3, 3] = at
        m.apply_transform(T)
        parts.append(Part(f"{t}.{len(parts)}", t, m, T))

    for x, z0, arm_x, arm_z in ((0, 1, 0, 4.5), (3, 1, 4, 3.5), (7, 2, 7, 5.5)):
        add("Post", (x, 0, z0), (1, 1, 2))
        add("Post", (x, 0, z0 + 2), (1, 1, 2))
        add("Arm", (arm_x, 0, arm_z), (1, 1, 1))
    return Assembly(parts, name="support")


def coast_pair() -> tuple[Assembly, Assembly]:
    a = make_coast.coast(6, 5, 2, 0)
    out = []
    for p in a.parts:
        if p.id == "Shore.2":
            p = p.transformed(trimesh.transformations.rotation_matrix(math.pi, (0, 0, 1), point=p.transform[:3, 3]))
        out.append(p)
    return a, Assembly(out, name="broken")


def render(model: Path, image: Path, *args: str) -> None:
    subprocess.run([sys.executable, "-m", "grammarkit", "render", str(model), "-o", str(image), *args], check=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=HERE.parents[2] / "docs" / "images")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        good, bad = coast_pair()
        write_assembly(support_scene(), t / "support.glb")
        write_assembly(good, t / "coast.glb")
        write_assembly(bad, t / "broken.glb")
        render(t / "support.glb", args.out / "tiling_support.png", "--size", "560x300", "--pitch", "10", "--yaw", "0")
        render(t / "coast.glb", args.out / "tiling_wfc_coast.png", "--size", "420x300", "--pitch", "25")
        render(t / "broken.glb", args.out / "tiling_wfc_broken.png", "--size", "420x300", "--pitch", "25")
    return 0


if __name__ == "__main__":
    sys.exit(main())
