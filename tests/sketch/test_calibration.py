"""Issue 30: temperature scaling, expected calibration error, the redraw answer, and the
drawing perturbations (page turned, perspective off, strokes broken off)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from .conftest import LIBRARY, sketch_of


def test_fit_temperature_recovers_the_temperature_that_made_the_labels():
    from grammarkit_sketch.calibration import fit_temperature, softmax

    rng = np.random.default_rng(0)
    logits = rng.normal(0, 4, (4000, 5))
    p = softmax(logits, 2.5)
    labels = np.array([rng.choice(5, p=row) for row in p])
    assert fit_temperature(logits, labels) == pytest.approx(2.5, rel=0.1)
    # never below 1: a set the network gets all right does not sharpen it
    assert fit_temperature(logits, logits.argmax(1)) == pytest.approx(1.0, abs=1e-3)


def test_expected_calibration_error_by_hand():
    from grammarkit_sketch.calibration import expected_calibration_error, reliability

    conf = np.array([0.95, 0.95, 0.95, 0.95, 0.55, 0.55])
    ok = np.array([True, True, True, False, True, False])
    # bin 9: 4 drawings, accuracy 0.75, confidence 0.95; bin 5: 2 drawings, 0.5 vs 0.55
    assert expected_calibration_error(conf, ok) == pytest.approx(4 / 6 * 0.2 + 2 / 6 * 0.05)
    bins = reliability(conf, ok)
    assert len(bins) == 10 and bins[9]["n"] == 4 and bins[5]["n"] == 2
    assert expected_calibration_error(np.ones(5), np.ones(5, bool)) == 0.0


def test_redraw_threshold_flags_unlikely_answers_but_at_most_a_share():
    from grammarkit_sketch.calibration import redraw_threshold

    conf = np.r_[np.full(97, 0.99), [0.3, 0.35, 0.4]]
    ok = np.r_[np.ones(97, bool), [False, False, False]]
    t = redraw_threshold(conf, ok, max_share=0.03)
    assert 0.4 < t <= 0.6 and (conf < t).sum() == 3
    assert redraw_threshold(conf, ok, max_share=0.01) <= 0.35  # capped: at most 1 of 100
    assert redraw_threshold(np.full(10, 0.99), np.ones(10, bool)) == 0.0


def test_rotate_and_break_strokes():
    from grammarkit_sketch.augment import break_strokes, rotate_ink

    ink = np.zeros((101, 101), np.float32)
    ink[50, 10:91] = 1.0
    turned = rotate_ink(ink, 5.0)
    ys, xs = np.nonzero(turned > 0.4)
    slope = np.polyfit(xs, ys, 1)[0]
    assert abs(abs(slope) - np.tan(np.radians(5))) < 0.02
    a = break_strokes(ink, np.random.default_rng(3), share=0.3)
    b = break_strokes(ink, np.random.default_rng(3), share=0.3)
    assert np.array_equal(a, b)  # the same seed, the same drawing
    kept = (a > 0.5).sum() / (ink > 0.5).sum()
    assert 0.5 < kept <= 0.7


def test_test_styles_combine_a_pen_with_a_perturbation():
    from grammarkit_sketch.drawing import test_style, training_style

    rng = np.random.default_rng(1)
    s = test_style("thick+rotated", rng)
    assert s.width == 7.0 and 3 <= abs(s.rotation) <= 5 and s.partial == 0
    s = test_style("overdrawn+partial", rng)
    assert s.strokes == 5 and 0.15 <= s.partial <= 0.3
    s = test_style("thick+perspective", rng)
    assert 3 <= abs(s.pitch_offset) <= 6
    with pytest.raises(ValueError, match="PEN\\+PERTURBATION"):
        test_style("thick+upside-down", rng)
    from grammarkit_sketch.augment import MAX_PARTIAL, MAX_PERSPECTIVE, MAX_ROTATION

    for _ in range(20):
        a = training_style(rng, "augmented")
        assert abs(a.rotation) <= MAX_ROTATION and abs(a.pitch_offset) <= MAX_PERSPECTIVE
        assert 0 <= a.partial <= MAX_PARTIAL


def test_a_rotated_style_draws_a_turned_sketch(library, stages):
    from PIL import Image

    from grammarkit_sketch.dataset import stage_view
    from grammarkit_sketch.drawing import draw, test_style
    from grammarkit_sketch.stages import StageDeriver

    stage = stages["Roof"]
    model = StageDeriver(library, stage).derive("roof_pyramid", {})
    style = test_style("sketchy", np.random.default_rng(0))
    view = stage_view(stage, model, stage.canvas_size(), style)
    flat = draw(model, view, style, stage.host_box())
    turned = draw(model, view, replace(style, rotation=4.0), stage.host_box())
    assert flat.shape == turned.shape and np.abs(flat - turned).mean() > 0.005
    Image.fromarray((255 - turned * 255).astype(np.uint8))  # a valid image


@pytest.fixture()
def rec():
    pytest.importorskip("torch")
    from grammarkit_sketch.recognizer import get_recognizer

    return get_recognizer(None, LIBRARY)


def test_temperature_flattens_probabilities_and_keeps_the_ranking(rec, library):
    tm = rec.models.types["Roof"]
    img, _ = sketch_of(library, tm.stage, "roof_pyramid", [0.5], seed=3)
    saved = dict(tm.metrics)
    try:
        tm.metrics["temperature"], tm.metrics["redraw_below"] = 1.0, 0.0
        a = rec.recognize(img, "Roof")
        tm.metrics["temperature"] = 4.0
        b = rec.recognize(img, "Roof")
        assert [c.snippet for c in a.top] == [c.snippet for c in b.top]
        assert b.probability < a.probability and not b.redraw
        tm.metrics["redraw_below"] = 0.999
        c = rec.recognize(img, "Roof")
        assert c.redraw and c.to_dict()["redraw"] is True and c.redraw_below == 0.999
        assert not rec.recognize(img, "Roof", snippet="roof_pyramid").redraw  # the user chose
    finally:
        tm.metrics.clear()
        tm.metrics.update(saved)


def test_the_cli_says_not_sure_below_the_threshold(rec, library, tmp_path, monkeypatch):
    from click.testing import CliRunner

    from grammarkit.cli import main
    from grammarkit_sketch import recognizer

    tm = rec.models.types["Roof"]
    img, _ = sketch_of(library, tm.stage, "roof_pyramid", [0.5], seed=3)
    path = tmp_path / "roof.png"
    img.save(path)
    saved = dict(tm.metrics)
    monkeypatch.setattr(recognizer, "get_recognizer", lambda *a, **k: rec)
    try:
        tm.metrics["temperature"], tm.metrics["redraw_below"] = 5.0, 0.99
        r = CliRunner().invoke(main, ["recognize", str(path), "--type", "Roof",
                                      "--library", str(LIBRARY)])
    finally:
        tm.metrics.clear()
        tm.metrics.update(saved)
    assert r.exit_code == 0, r.output
    assert "not sure (probability" in r.output and "redraw the sketch" in r.output


def test_fine_tune_starts_from_the_trained_weights_and_keeps_the_regressors(rec):
    from grammarkit_sketch.training import TrainConfig, fine_tune_classifier

    tm = rec.models.types["Ledge"]
    before = dict(tm.metrics)
    cfg = TrainConfig(samples=4, classifier_epochs=1, lr=5e-4, style="augmented", seed=7, cache=None)
    tuned = fine_tune_classifier(rec.library, tm, cfg)
    ft = tuned.metrics["fine_tune"]
    assert ft["style"] == "augmented" and ft["val_accuracy_after"] >= ft["val_accuracy_before"]
    assert tuned.regressors is tm.regressors and tuned.classes == tm.classes
    assert set(tuned.classifier) == set(tm.classifier)
    assert tm.metrics == before  # the original is not modified
    again = fine_tune_classifier(rec.library, tm, cfg)  # same settings and seed, same weights
    assert all((again.classifier[k].float() == tuned.classifier[k].float()).all() for k in tuned.classifier)


def test_fine_tune_can_switch_what_the_classifier_reads(rec):
    """Trained weights as the starting point of a classifier that reads the other input: the
    type records the input its weights belong to, whichever weights win."""
    from grammarkit_sketch.training import TrainConfig, fine_tune_classifier

    tm = rec.models.types["Window"]
    was = tm.metrics.get("classifier_input", "as-drawn")
    other = "centre-lines" if was == "as-drawn" else "as-drawn"
    cfg = TrainConfig(samples=4, classifier_epochs=1, lr=5e-4, style="augmented", seed=3, cache=None)
    tuned = fine_tune_classifier(rec.library, tm, cfg, input_kind=other)
    ft = tuned.metrics["fine_tune"]
    kept = all((tuned.classifier[k].float() == tm.classifier[k].float()).all() for k in tm.classifier)
    assert ft["input"] == tuned.metrics.get("classifier_input", "as-drawn") == (was if kept else other)
    assert tm.metrics.get("classifier_input", "as-drawn") == was  # the original is not modified


def test_regressor_fine_tune_keeps_a_regressor_unless_it_improves(rec):
    from grammarkit_sketch.training import TrainConfig, fine_tune_regressors

    tm = rec.models.types["Ledge"]
    before = {k: {n: v.clone() for n, v in r.state.items()} for k, r in tm.regressors.items()}
    cfg = TrainConfig(samples=4, regressor_epochs=2, lr=3e-4, batch=4, style="augmented", seed=7,
                      cache=None, val_share=0.5)
    tuned = fine_tune_regressors(rec.library, tm, cfg)
    ft = tuned.metrics["fine_tune_regressors"]
    assert ft["style"] == "augmented" and ft["epochs"] == 2
    assert tuned.classifier is tm.classifier and tuned.classes == tm.classes
    for name, reg in tuned.regressors.items():
        same = all((reg.state[k].float() == before[name][k].float()).all() for k in reg.state)
        assert same == (name not in ft["changed"]), name  # replaced exactly when it improved
        if reg.params:
            start, after = tuned.metrics[f"fine_tune_rmse.{name}"]
            assert after <= start
    assert all((tm.regressors[n].state[k] == before[n][k]).all() for n in before for k in before[n])
    again = fine_tune_regressors(rec.library, tm, cfg)  # same settings and seed, same weights
    for name, reg in tuned.regressors.items():
        assert all((again.regressors[name].state[k].float() == reg.state[k].float()).all() for k in reg.state)


def test_calibration_script_reads_held_out_logits_with_their_classes(rec):
    import importlib.util

    from .conftest import ROOT

    path = ROOT / "plugins" / "sketch" / "scripts" / "calibrate_shipped.py"
    spec = importlib.util.spec_from_file_location("calibrate_shipped", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    logits, labels = script.held_out_logits(rec, "Ledge", 1, sets=(("augmented", 5001),))
    tm = rec.models.types["Ledge"]
    assert logits.shape == (len(labels), len(tm.classes)) and len(labels) >= 2
    assert set(labels) <= set(range(len(tm.classes)))
    with pytest.raises(SystemExit):
        script.main(["-o", str(script.SHIPPED)])  # never the shipped file without the flag


def test_the_shipped_weights_are_fine_tuned_and_calibrated():
    pytest.importorskip("torch")
    from grammarkit_sketch.models import load_models
    from grammarkit_sketch.recognizer import redraw_threshold_of, temperature_of

    m = load_models()
    assert m.meta["fine_tune"]["style"] == "augmented"
    for t, tm in m.types.items():
        assert temperature_of(tm) >= 1.0 and 0.0 <= redraw_threshold_of(tm) <= 0.6, t
        cal = tm.metrics["calibration"]
        assert cal["redraw_share"] <= 0.05 and cal["drawings"] > 0, t


def test_training_with_the_augmented_style_from_the_cli(tmp_path):
    pytest.importorskip("torch")
    from click.testing import CliRunner

    from grammarkit.cli import main
    from grammarkit_sketch.models import load_models

    out = tmp_path / "aug.models"
    r = CliRunner().invoke(main, ["train", "sketch", "--library", str(LIBRARY), "-o", str(out),
                                  "--samples", "20", "--classifier-epochs", "1", "--types", "Ledge",
                                  "--classifiers-only", "--no-cache", "--style", "augmented"])
    assert r.exit_code == 0, r.output
    m = load_models(out)
    assert m.meta["config"]["style"] == "augmented" and list(m.types) == ["Ledge"]
