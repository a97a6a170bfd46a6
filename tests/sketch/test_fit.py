"""Analysis by synthesis after the networks: the pen-invariant ("pen") score, the canvas
samples the benchmark fits against, and the re-ranking of the likely classes by their fit."""
from __future__ import annotations

import numpy as np
import pytest

from grammarkit_sketch.dataset import line_mask, render_input, sample_drawing, stage_view
from grammarkit_sketch.drawing import DrawStyle, draw
from grammarkit_sketch.refine import Scorer
from grammarkit_sketch.stages import StageDeriver


def _facade(library, stages):
    stage = stages["Facade"]
    info = library.snippets_of("Facade")[0]
    return stage, info, StageDeriver(library, stage)


def _ink(deriver, stage, info, u, style):
    model = deriver.derive(info.name, {p.name: p.value(x) for p, x in zip(info.params, u)})
    return draw(model, stage_view(stage, model, None, style), style, stage.host_box())


def test_the_centre_score_does_not_depend_on_the_pen_width(library, stages):
    stage, info, deriver = _facade(library, stages)
    u = np.full(len(info.params), 0.5)
    names = [p.name for p in info.params]
    scores = {}
    for kind in ("chamfer", "pen"):
        for width in (2.0, 7.0):
            target = line_mask(_ink(deriver, stage, info, u, DrawStyle(sketchy=False, width=width)), stage)
            scorer = Scorer(deriver, info, names, info.defaults(), target, kind)
            scores[kind, width] = scorer(u)
    # the felt pen's band costs the chamfer score; centre lines of either pen match the model
    assert scores["chamfer", 7.0] < 0.8 * scores["chamfer", 2.0]
    assert scores["pen", 7.0] == pytest.approx(scores["pen", 2.0], rel=0.1)
    assert scores["pen", 7.0] > scores["chamfer", 7.0]


def test_the_centre_score_still_tells_parameters_apart(library, stages):
    stage, info, deriver = _facade(library, stages)
    names = [p.name for p in info.params]
    u = np.full(len(names), 0.5)
    target = line_mask(_ink(deriver, stage, info, u, DrawStyle(sketchy=False, width=7.0)), stage)
    scorer = Scorer(deriver, info, names, info.defaults(), target, "pen")
    far = u.copy()
    far[0] = 0.95
    assert scorer(u) > scorer(far)


def test_a_canvas_sample_is_the_training_sample_and_its_drawing(library, stages):
    stage, info, deriver = _facade(library, stages)
    a = sample_drawing(deriver, info, np.random.default_rng([3, 1]), "sketchy", "thick+partial")
    b = sample_drawing(deriver, info, np.random.default_rng([3, 1]), "sketchy", "thick+partial")
    assert a is not None and b is not None
    x, u, ink = a
    assert np.array_equal(x, b[0]) and np.array_equal(ink, b[2])  # deterministic
    assert ink.shape == stage.canvas_size()[::-1] and x.shape == (128, 128)
    assert np.array_equal(u, b[1]) and ((0 <= u) & (u <= 1)).all()


def test_rerank_picks_the_class_whose_fit_matches_best(library, torch_or_skip):
    from grammarkit_sketch.recognizer import get_recognizer
    from grammarkit_sketch.image import to_input

    rec = get_recognizer()
    stage = rec.models.types["Roof"].stage
    deriver = StageDeriver(rec.library, stage)
    info = rec.library.snippets["roof_hip"]
    u = np.full(len(info.params), 0.5)
    ink = _ink(deriver, stage, info, u, DrawStyle(sketchy=False, width=2.0))
    x, target = to_input(ink, stage.framing), line_mask(ink, stage)
    assert np.allclose(x, render_input(stage, deriver.derive(info.name, {p.name: p.value(v) for p, v in
                                                                         zip(info.params, u)}),
                                       DrawStyle(sketchy=False, width=2.0)))
    # a drawing of the hip roof offered with the gable roof first: the fits decide
    plain = rec.recognize_input(x, "Roof", target=target, refine_steps=2, score="pen")
    picked = rec.recognize_input(x, "Roof", target=target, refine_steps=2, score="pen", rerank=True)
    again = rec.recognize_input(x, "Roof", target=target, refine_steps=2, score="pen", rerank=True)
    assert picked.snippet == again.snippet and picked.values == again.values  # deterministic
    fits = {c.snippet: rec.recognize_input(x, "Roof", target=target, refine_steps=2, score="pen",
                                           snippet=c.snippet).score
            for c in plain.top if c.probability >= 0.05}
    assert picked.snippet == max(fits, key=fits.get)
    assert picked.score == pytest.approx(max(fits.values()))
    assert "rerank" in picked.timings
