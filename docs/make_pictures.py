"""Render the pictures of docs/operations.md (one per operation) and docs/gallery.md.

    python docs/make_pictures.py            # all pictures
    python docs/make_pictures.py --only ops # or: gallery

Each operation picture derives a tiny grammar (shown in docs/operations.md next to it) with
the split engine and renders it with the CPU renderer; images are written atomically.
"""
from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"

# name -> grammar text (kept short: they are also the examples in docs/operations.md)
OPERATIONS: dict[str, str] = {
    "footprint_extrude": """
Lot --> footprint(lshape(10, 8, 4, 4)) extrude(3) color("#c8b89a") Mass.
""",
    "taper": """
Lot --> footprint(rect(8, 6)) taper(5, 0.4) color("#c8b89a") Spire.
""",
    "comp": """
Lot --> footprint(rect(8, 6)) extrude(4) comp(f) { front: extrude(0.4) color("#d9534f") F. | right: extrude(0.4) color("#5cb85c") R. | top: extrude(0.4) color("#5bc0de") T. | all: NIL | volume: Mass. }
""",
    "split": """
Lot --> footprint(rect(10, 4)) split(x) { 1: extrude(5) color("#444444") A. | { ~2: extrude(3) color("#c8b89a") B. | 0.3: extrude(4) color("#8a3b2e") C. }* | 1: extrude(5) color("#444444") A. }
""",
    "repeat_pattern": """
Lot --> footprint(rect(10, 2)) Bay
Bay --> repeat(x, 1.8, 0.3) (W P)* W
W --> extrude(2) color("#c8b89a") W.
P --> extrude(3) color("#8a3b2e") P.
""",
    "offset": """
Lot --> footprint(rect(8, 6)) offset(-1) { inside: extrude(1) color("#c8b89a") In. | border: extrude(2.5) color("#8a3b2e") Border. }
""",
    "recess": """
Lot --> footprint(rect(8, 6)) extrude(5) color("#d8cbb0") comp(f) { front: Facade | all: NIL | volume: Mass. }
Facade --> split(x) { ~1: W. | { 1.4: Win | ~1: W. }* }
Win --> split(y) { 1: W. | 2.2: [ extrude(0.08) color("#f2efe8") Frame. ] offset(-0.12) recess(0.3) color("#2f3d48") Glass. | ~1: W. }
""",
    "roofGable": """
Lot --> footprint(rect(8, 6)) extrude(3) color("#d8cbb0") comp(f) { top: roofGable(35, overhang=0.4, ridge=x) color("#8a3b2e") Roof. | all: NIL | volume: Mass. }
""",
    "roofGable_ridge_y": """
Lot --> footprint(rect(8, 6)) extrude(3) color("#d8cbb0") comp(f) { top: roofGable(35, overhang=0.4, ridge=y) color("#8a3b2e") Roof. | all: NIL | volume: Mass. }
""",
    "roofHip": """
Lot --> footprint(lshape(12, 10, 5, 5)) extrude(3) color("#d8cbb0") comp(f) { top: roofHip(35, overhang=0.3) color("#7b4a3a") Roof. | all: NIL | volume: Mass. }
""",
    "roofPyramid": """
Lot --> footprint(rect(7, 7)) extrude(3) color("#d8cbb0") comp(f) { top: roofPyramid(40, overhang=0.3) color("#6d3a2c") Roof. | all: NIL | volume: Mass. }
""",
    "roofShed": """
Lot --> footprint(rect(8, 6)) extrude(3) color("#d8cbb0") comp(f) { top: roofShed(20, overhang=0.3) color("#5f6b73") Roof. | all: NIL | volume: Mass. }
""",
    "roofMansard": """
Lot --> footprint(rect(8, 6)) extrude(3) color("#d8cbb0") comp(f) { top: roofMansard(70, 2, 18, overhang=0.15) color("#5f6b73") Roof. | all: NIL | volume: Mass. }
""",
    "transforms": """
Lot --> footprint(rect(8, 6)) extrude(2) color("#d8cbb0") Base
Base --> [ s(2, 2, 3) center(xy) t(0, 0, 2) r(0, 0, 30) color("#8a3b2e") Tower. ] Base.
""",
    "insert": """
Lot --> footprint(rect(6, 4)) extrude(3) color("#d8cbb0") comp(f) { top: Top | all: NIL | volume: Mass. }
Top --> [ t(1, 1, 0) s(1.2, 0.6, 3) i("../../grammars/parts/chimney.glb") color("#a0522d") Chimney. ] color("#8c8c88") Deck.
""",
    "stochastic": """
Lot --> footprint(rect(12, 12)) split(x) { { ~2: Row }* }
Row --> split(y) { { ~2: Cell }* }
Cell --> 40%: extrude(rand(1, 4)) color("#8a3b2e") A. | 30%: extrude(1) color("#c8b89a") B. | else: NIL
""",
}

GALLERY = ["paris", "skyscraper", "lshape"]


def _render(model, path: Path, size: int) -> None:
    from grammarkit.geometry.render import render, save_image

    save_image(render(model.mesh, style="shaded+lines", size=(size, size)), path)


def operations(size: int = 360) -> None:
    from grammarkit.dsl import load
    from grammarkit.split import derive

    for name, text in OPERATIONS.items():
        src = IMAGES / f".op_{name}.grammar"  # so that relative i() paths resolve from docs/images
        src.write_text(text)
        try:
            model = derive(load(src), seed=2)
        finally:
            src.unlink()
        _render(model, IMAGES / f"op_{name}.png", size)
        print("wrote", IMAGES / f"op_{name}.png")


def gallery(size: int = 560) -> None:
    from grammarkit.dsl import load
    from grammarkit.split import derive, variations

    for name in GALLERY:
        g = load(ROOT / "grammars" / f"{name}.grammar")
        _render(derive(g, seed=0), IMAGES / f"gallery_{name}.png", size)
        print("wrote", IMAGES / f"gallery_{name}.png")
    g = load(ROOT / "grammars" / "paris.grammar")
    for var, model in variations(g, 3, seed=7):
        _render(model, IMAGES / f"gallery_paris_var{var.index}.png", 360)
        print("wrote", IMAGES / f"gallery_paris_var{var.index}.png", var.bindings.get("Roof"))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", choices=("ops", "gallery"))
    args = ap.parse_args()
    IMAGES.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "ops"):
        operations()
    if args.only in (None, "gallery"):
        gallery()


if __name__ == "__main__":
    main()
