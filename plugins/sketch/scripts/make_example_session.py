"""Write an example session.json: the strokes a person would draw, stage by stage, to sketch a
target building (the visible lines of each target snippet, traced with a shaky hand).

    python plugins/sketch/scripts/make_example_session.py [-o docs/images/sketch_session.json]

Each stage's canvas depends on what the earlier stages were recognised as (the roof canvas is
framed on the recognised mass's top face), so the script runs the session as it goes, exactly
as an interactive tool would: ask for the stage's canvas, draw on it, add the strokes.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

# refinement steps per stage: the later stages' anchors are not the canonical ones the networks
# were trained on (docs/sketch.md, "Limitations"), and refinement on the real anchor is the remedy
REFINE = 10
TARGET = [  # (object type, snippet, parameter values)
    ("Mass", "mass_stepped", {"base_h": 16.0, "upper_h": 9.0, "step": 2.5}),
    ("Roof", "roof_hip", {"roof_deg": 32.0, "roof_over": 0.6}),
    ("Facade", "facade_classic", {"ground_h": 4.8, "floor_h": 3.3, "cornice_h": 0.7, "shop_w": 2.6}),
    ("Floor", "floor_windows", {"win_w": 1.3, "pier_w": 1.6, "sill_h": 0.8, "head_h": 0.5}),
    ("Window", "window_sill", {"sill_h": 0.16, "sill_d": 0.26, "depth": 0.3}),
    ("Ledge", "ledge_cornice", {"lower_d": 0.25, "upper_d": 0.6}),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path,
                    default=Path(__file__).resolve().parents[3] / "docs" / "images" / "sketch_session.json")
    ap.add_argument("--models", default=None)
    ap.add_argument("--library", default=None)
    ap.add_argument("--longest", type=int, default=512, help="longest canvas side, pixels")
    ap.add_argument("--jitter", type=float, default=1.5, help="hand shake, pixels")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    from grammarkit.fileio import atomic_output
    from grammarkit_sketch.drawing import model_strokes
    from grammarkit_sketch.session import SESSION_FORMAT, SESSION_VERSION, Session
    from grammarkit_sketch.stages import StageDeriver

    session = Session(models=args.models, library=args.library, name="sketched_building")
    stages = []
    for k, (t, snippet, values) in enumerate(TARGET):
        canvas = session.canvas(t, longest=args.longest)
        model = StageDeriver(session.library, canvas.stage).derive(snippet, values)
        view = canvas.view
        if canvas.stage.framing == "fit":  # the mass: framed on itself, anywhere on the canvas
            view = canvas.stage.camera().resolve(model.vertices, canvas.size)
        strokes = model_strokes(model, view, canvas.stage.host_box(), jitter=args.jitter, seed=args.seed + k)
        r = session.add_strokes(t, strokes, canvas.size, refine=REFINE)
        print(f"{t:<7} drew {snippet:<15} ({len(strokes):>3} strokes on {canvas.size[0]}x{canvas.size[1]}) "
              f"-> {r.snippet} p={r.probability:.2f}")
        stages.append({"type": t, "canvas": list(canvas.size), "strokes": strokes,
                       "drawn_from": {"snippet": snippet, "values": values}})
    data = {"format": SESSION_FORMAT, "version": SESSION_VERSION, "name": "sketched_building",
            "lot": list(session.lot), "refine": REFINE, "stages": stages}
    with atomic_output(args.output) as tmp:
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
