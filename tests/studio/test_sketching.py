"""The sketch canvas's server side: each object type's canvas has the recognizer's aspect ratio
and shows the anchor's outline, strokes drawn on it become a line drawing the recognizer reads
(a drawing of the wrong shape is a clear error), a recognised snippet and its parameters become
grammar text through grammarkit's printer (the text checks and derives with the new binding and
values), and without the recognizer plugin the page is told so."""
from __future__ import annotations

import base64
import io
import sys
from pathlib import Path

import numpy as np
import pytest

import grammarkit
from grammarkit.dsl import load
from grammarkit.errors import GrammarkitError
from grammarkit_studio.sketching import (CANVAS_LONGEST, SketchError, apply_snippet, recognize_sketch,
                                         sketch_canvas, strokes_to_image)
from grammarkit_studio.work import Work

from _studio import gable_roof

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"


def test_strokes_to_image():
    image = strokes_to_image([[[10, 10], [90, 10], [90, 60]], [[20, 40]]], 100, 80)
    px = np.asarray(image)
    assert px.shape == (80, 100) and px[10, 50] < 128 and px[35, 90] < 128 and px[40, 20] < 128
    assert px[60, 20] == 255  # paper where nothing was drawn
    for bad in ([], [[["a", 1]]], [[[1, float("nan")]]], "x"):
        with pytest.raises(SketchError):
            strokes_to_image(bad, 100, 80)
    with pytest.raises(SketchError):
        strokes_to_image([[[1, 1]]], 10**6, 80)


def test_apply_snippet_rebinds_and_sets_values_through_the_printer():
    text = PARIS.read_text()
    merged = load(PARIS)
    new = apply_snippet(text, PARIS, merged, "Roof", "roof_gable", {"roof_deg": 41.5, "mass_h": 44})
    assert "use roof_gable as Roof" in new and "use roof_mansard as Roof" not in new
    assert "attr mass_h = 44" in new and "attr roof_deg = 41.5" in new
    assert new == grammarkit.format(new)  # canonical text: what the printer prints
    assert 'import "library.grammar"' in new and "# A Haussmann-style" in new  # imports, comments kept
    assert not [d for d in grammarkit.check(new, filename=str(PARIS)) if d.severity == "error"]
    model = grammarkit.derive(load(new, filename=str(PARIS)))
    assert model.bindings["Roof"] == "roof_gable"
    # a grammar attr replaces the snippet attr of its name
    assert model.attrs["roof_deg"] == 41.5 and "Roof.roof_deg" not in model.attrs and model.attrs["mass_h"] == 44
    with pytest.raises(SketchError, match="not a Roof snippet"):
        apply_snippet(text, PARIS, merged, "Roof", "window_framed", {})


def on_canvas(strokes, width: int, height: int) -> list:
    return [[[x * width, y * height] for x, y in s] for s in strokes]


@pytest.fixture(scope="module")
def recognizer():
    pytest.importorskip("torch", reason="the sketch recognizer needs the learning extra")
    return pytest.importorskip("grammarkit_sketch")


def test_each_type_has_its_canvas_with_the_anchor_outline(recognizer):
    from PIL import Image

    merged = load(PARIS)
    models = recognizer.get_recognizer().models
    for t in ("Roof", "Floor", "Mass"):
        out = sketch_canvas(t, merged)
        w, h = models.type_model(t).stage.canvas_size()
        assert out["object_type"] == t and out["stage_canvas"] == [w, h]
        assert max(out["width"], out["height"]) == CANVAS_LONGEST
        assert abs(out["width"] / out["height"] - w / h) < 0.01  # the recognizer's aspect
        assert out["png"].startswith("data:image/png;base64,")
        img = np.asarray(Image.open(io.BytesIO(base64.b64decode(out["png"].split(",", 1)[1]))).convert("L"))
        assert img.shape == (out["height"], out["width"])
        outline = (img < 235) & (img > 120)  # the anchor's outline, light grey on white paper
        assert 0.001 < outline.mean() < 0.05 and (img > 250).mean() > 0.9
    assert sketch_canvas("Floor", merged)["width"] > 3 * sketch_canvas("Floor", merged)["height"]
    with pytest.raises(SketchError, match="no 'Chimney' snippets.*Roof"):
        sketch_canvas("Chimney", merged)


def test_strokes_on_the_types_canvas_are_recognised_into_grammar_text(recognizer):
    merged = load(PARIS)
    text = PARIS.read_text()
    c = sketch_canvas("Roof", merged)
    roofs = {s.name for s in merged.snippets if s.object_type == "Roof"}
    angles = []
    for lift in (0.13, 0.22, 0.31):  # a gable over the anchor, its ridge higher each time
        out = recognize_sketch(on_canvas(gable_roof(lift), c["width"], c["height"]), c["width"], c["height"],
                               "Roof", text, PARIS, merged)
        cands = out["candidates"]
        assert len(cands) == 3 and {c["snippet"] for c in cands} <= roofs
        probs = [c["probability"] for c in cands]
        assert probs == sorted(probs, reverse=True) and 0 < sum(probs) <= 1 + 1e-6
        best = cands[0]
        assert best["snippet"] == "roof_gable" and best["probability"] > 0.9, cands
        assert best["text"] and "use roof_gable as Roof" in best["text"] and 0 < best["score"] <= 1
        for name, value in best["params"].items():
            assert f"attr {name} = " in best["text"]
        angles.append(best["params"]["roof_deg"])
    assert angles == sorted(angles) and angles[-1] - angles[0] > 8  # steeper drawn, steeper recognised
    model = grammarkit.derive(load(best["text"], filename=str(PARIS)))
    assert model.bindings["Roof"] == "roof_gable" and model.attrs["roof_deg"] == pytest.approx(angles[-1])


def test_a_drawing_of_the_wrong_shape_is_a_clear_error(recognizer):
    merged = load(PARIS)
    # the studio's old square canvas: the recognizer names both shapes
    with pytest.raises(GrammarkitError, match=r"256x256.*aspect 1\.00.*256x228.*aspect 1\.12"):
        recognize_sketch(on_canvas(gable_roof(), 256, 256), 256, 256, "Roof", PARIS.read_text(), PARIS, merged)
    with pytest.raises(SketchError, match="nothing to recognise"):
        recognize_sketch([], 512, 456, "Roof", PARIS.read_text(), PARIS, merged)


def test_the_worker_operations_answer_through_work(recognizer):
    work = Work(str(PARIS), str(PARIS.parent))
    c = work.sketch_canvas("Window", PARIS.read_text())
    assert c["width"] < c["height"]  # a window's canvas is upright
    with pytest.raises(GrammarkitError, match="split grammar without errors"):
        work.sketch_canvas("Roof", "grammar broken\nLot --> nope(")


def test_without_the_recognizer_the_page_is_told(monkeypatch):
    pytest.importorskip("PIL")
    # as if grammarkit_sketch were not installed: `import grammarkit_sketch` raises ImportError
    monkeypatch.setitem(sys.modules, "grammarkit_sketch", None)
    merged = load(PARIS)
    with pytest.raises(SketchError, match="no sketch recognizer is installed"):
        recognize_sketch([[[1, 1], [50, 50]]], 100, 100, "Roof", PARIS.read_text(), PARIS, merged)
    with pytest.raises(SketchError, match="no sketch recognizer is installed"):
        sketch_canvas("Roof", merged)
    with pytest.raises(SketchError, match="no sketch recognizer is installed"):
        Work(str(PARIS), str(PARIS.parent)).sketch_canvas("Roof", PARIS.read_text())


def test_the_studio_never_imports_another_plugin():
    """Plugins never import each other (issue 25): the recognizer is found through the plugin
    registry, so no module of the studio names the sketch plugin's package in an import."""
    import ast

    studio = ROOT / "plugins" / "studio" / "grammarkit_studio"
    others = {p.name for p in (ROOT / "plugins").glob("*/grammarkit_*") if p.name != "grammarkit_studio"}
    bad = []
    for f in studio.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module] if isinstance(node, ast.ImportFrom) and node.module and not node.level else [])
            bad += [f"{f.name}:{node.lineno}: {n}" for n in names if n.split(".")[0] in others]
    assert others and not bad, bad


def test_the_studio_works_without_the_sketch_plugin(tmp_path, monkeypatch):
    """With the sketch plugin disabled (as if it were not installed), the worker process derives,
    checks and exports as before, and the sketch canvas says what is missing."""
    from grammarkit.plugins import DISABLE_ENV
    from grammarkit_studio.worker import CallFailed, Worker

    monkeypatch.setenv(DISABLE_ENV, "sketch")  # the worker process inherits it
    worker = Worker(str(PARIS), str(PARIS.parent), "nosketch")
    try:
        text = PARIS.read_text()
        out = worker.call("derive", 120, text=text, attrs={}, seed=0)
        assert out["ok"] and out["glb"][:4] == b"glTF"
        assert worker.call("export", 60, fmt="stl")["data"]
        with pytest.raises(CallFailed, match="no sketch recognizer is installed"):
            worker.call("sketch_canvas", 60, object_type="Roof", text=text)
        # the process is still usable after the refusal
        assert worker.call("check", 60, text=text)["ok"]
    finally:
        worker.close()
