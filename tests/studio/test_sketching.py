"""The sketch canvas's server side: strokes become a line drawing, a recognised snippet and its
parameters become grammar text through grammarkit's printer (the text checks and derives with
the new binding and values), and without the recognizer plugin the page is told so."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import grammarkit
from grammarkit.dsl import load
from grammarkit_studio.sketching import SketchError, apply_snippet, recognize_sketch, strokes_to_image

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


def test_without_the_recognizer_the_page_is_told():
    pytest.importorskip("PIL")
    try:
        import grammarkit_sketch  # noqa: F401
        pytest.skip("the sketch recognizer is installed; tests/sketch covers it")
    except ImportError:
        pass
    with pytest.raises(SketchError, match="sketch recognizer is not installed"):
        recognize_sketch([[[1, 1], [50, 50]]], 100, 100, "Roof", PARIS.read_text(), PARIS, load(PARIS))
