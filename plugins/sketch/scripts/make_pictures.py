"""The pictures of docs/sketch.md (docs/images/sketch_*.png), from the shipped models.

    python plugins/sketch/scripts/make_pictures.py [--out docs/images]

- sketch_pipeline.png: a roof sketch, its distance transform D(I), the recognised model drawn
  over the sketch, and the recognised roof derived on a building;
- sketch_stages.png: one training drawing per object type (the fixed cameras and framings);
- sketch_styles.png: one roof drawn in the training style and in the robustness styles;
- sketch_session.png: the canvases of the example session with the recognised snippets, and
  the building its generated grammar derives.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]


def label(img, text):  # noqa: ANN001, ANN201
    from PIL import Image, ImageDraw

    img = img.convert("RGB")
    out = Image.new("RGB", (img.width, img.height + 22), "white")
    out.paste(img, (0, 22))
    ImageDraw.Draw(out).text((6, 5), text, fill=(20, 20, 20))
    return out


def row(images, pad=8):  # noqa: ANN001, ANN201
    from PIL import Image

    h = max(i.height for i in images)
    w = sum(i.width for i in images) + pad * (len(images) + 1)
    out = Image.new("RGB", (w, h + 2 * pad), "white")
    x = pad
    for i in images:
        out.paste(i, (x, pad + (h - i.height) // 2))
        x += i.width + pad
    return out


def grey(a):  # noqa: ANN001, ANN201
    from PIL import Image

    return Image.fromarray((255 - np.clip(a, 0, 1) * 255).astype(np.uint8), "L")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    args = ap.parse_args()
    from PIL import Image

    from grammarkit.geometry.render import Camera, render, save_image
    from grammarkit_sketch.dataset import line_mask, stage_view
    from grammarkit_sketch.drawing import draw, test_style, training_style
    from grammarkit_sketch.image import distance_map, load_ink
    from grammarkit_sketch.recognizer import get_recognizer
    from grammarkit_sketch.stages import StageDeriver

    rec = get_recognizer(None, ROOT / "grammars" / "library.grammar")
    lib = rec.library
    out = args.out

    # -- pipeline ------------------------------------------------------------------------------
    stage = rec.models.types["Roof"].stage
    model = StageDeriver(lib, stage).derive("roof_hip", {"roof_deg": 38.0, "roof_over": 0.7})
    style = test_style("sketchy", np.random.default_rng(3))
    ink = draw(model, stage_view(stage, model, stage.canvas_size(), style), style, stage.host_box())
    sketch = grey(ink)
    save_image(sketch, out / "sketch_roof.png")  # the sketch the docs' examples recognise
    r = rec.recognize(sketch, "Roof", refine_steps=10)
    d = distance_map(line_mask(load_ink(sketch), stage))  # what the refinement scores compare
    dt = Image.fromarray((255 * (1 - np.clip(d / 24.0, 0, 1))).astype(np.uint8), "L").resize(sketch.size)
    overlay = rec.preview(sketch, r, size=max(sketch.size))
    text = (f"grammar g\nimport \"{ROOT / 'grammars' / 'library.grammar'}\"\n"
            "Lot --> footprint(rect(16, 12)) Mass\nuse mass_box as Mass\n"
            f"{r.use_line()}\n")
    import grammarkit

    building = grammarkit.derive(text, attrs={"mass_h": 14, **{s.split('=')[0]: float(s.split('=')[1])
                                                              for s in r.set_options()}})
    shaded = render(building, Camera(), style="shaded+lines", size=sketch.size)
    save_image(row([label(sketch, "sketch (Roof canvas)"), label(dt, "distance transform D(I)"),
                    label(overlay, f"{r.snippet} p={r.probability:.2f}, score {r.score:.2f}"),
                    label(shaded, "derived on a building")]), out / "sketch_pipeline.png")

    # -- stages --------------------------------------------------------------------------------
    rng = np.random.default_rng(7)
    pics = []
    for t, snippet in (("Mass", "mass_stepped"), ("Roof", "roof_mansard"), ("Facade", "facade_classic"),
                       ("Floor", "floor_balcony"), ("Window", "window_framed"), ("Ledge", "ledge_balcony")):
        st = rec.models.types[t].stage
        m = StageDeriver(lib, st).derive(snippet)
        sty = training_style(rng)
        ink = draw(m, stage_view(st, m, st.canvas_size(), sty), sty, st.host_box())
        img = grey(ink)
        k = 200 / max(img.size)
        img = img.resize((int(img.width * k), int(img.height * k)), Image.Resampling.LANCZOS)
        pics.append(label(img, f"{t}: {snippet}"))
    save_image(row(pics), out / "sketch_stages.png")

    # -- styles --------------------------------------------------------------------------------
    pics = []
    m = StageDeriver(lib, stage).derive("roof_gable", {"roof_deg": 40.0, "roof_over": 0.5})
    for kind in ("sketchy", "plain", "jitter", "missing", "overdrawn", "thick", "perspective"):
        sty = test_style(kind, np.random.default_rng(5))
        ink = draw(m, stage_view(stage, m, stage.canvas_size(), sty), sty, stage.host_box())
        img = grey(ink).resize((180, int(180 * ink.shape[0] / ink.shape[1])), Image.Resampling.LANCZOS)
        pics.append(label(img, kind))
    save_image(row(pics), out / "sketch_styles.png")

    # -- the example session -------------------------------------------------------------------
    from grammarkit_sketch.session import Session

    example = out / "sketch_session.json"
    s = Session.from_file(example, library=ROOT / "grammars" / "library.grammar")
    pics = []
    for t in s.library.types:
        img = s.stage_picture(t, size=220)
        r = s.stages[t].recognition
        pics.append(label(img, f"{t}: {r.snippet}"))
    building = s.derive()
    shaded = render(building, Camera(), style="shaded+lines", size=(300, 300))
    save_image(row(pics[:3] + [label(shaded, "the generated grammar")]), out / "sketch_session.png")
    save_image(row(pics[3:]), out / "sketch_session_facade.png")
    print("wrote", *(p.name for p in sorted(out.glob("sketch_*.png"))))


if __name__ == "__main__":
    main()
