"""Undoing a turned page before recognition (rectify.py, issue 30): the turn is found from the
drawing's own lines, undone on stages seen straight on, left alone on oblique ones, and it
brings the recognised parameters back to what an upright drawing gives."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytestmark = pytest.mark.usefixtures("torch_or_skip")


def _ink(library, stage, snippet, values, rotation, seed=3):
    from grammarkit_sketch.dataset import stage_view
    from grammarkit_sketch.drawing import draw, test_style
    from grammarkit_sketch.stages import StageDeriver

    model = StageDeriver(library, stage).derive(snippet, values)
    style = replace(test_style("sketchy", np.random.default_rng(seed)), rotation=rotation)
    return draw(model, stage_view(stage, model, stage.canvas_size(), style), style, stage.host_box())


@pytest.mark.parametrize("t, snippet", [("Window", "window_simple"), ("Floor", "floor_windows"),
                                        ("Facade", "facade_grid")])
@pytest.mark.parametrize("rotation", [-4.5, 3.0])
def test_the_page_turn_is_found_and_undone(library, stages, t, snippet, rotation):
    from grammarkit_sketch.image import to_input
    from grammarkit_sketch.rectify import rectify_input

    st = stages[t]
    upright = to_input(_ink(library, st, snippet, {}, 0.0), st.framing)
    turned = to_input(_ink(library, st, snippet, {}, rotation), st.framing)
    x, turn = rectify_input(turned, st)
    assert turn == pytest.approx(-rotation, abs=0.8)  # rotate_ink(turned, turn) undoes it
    # the rectified input is closer to the upright drawing than the turned one is
    assert np.abs(x - upright).mean() < 0.75 * np.abs(turned - upright).mean()
    assert rectify_input(upright, st)[1] == 0.0  # an upright drawing is left as drawn


def test_oblique_stages_are_left_as_drawn(library, stages):
    from grammarkit_sketch.image import to_input
    from grammarkit_sketch.rectify import frontal, rectify_input

    for t in ("Mass", "Roof", "Ledge"):
        st = stages[t]
        assert not frontal(st)
        snippet = library.snippets_of(t)[0].name
        x = to_input(_ink(library, st, snippet, {}, 4.0), st.framing)
        out, turn = rectify_input(x, st)
        assert turn == 0.0 and out is not None and np.array_equal(out, x)


def test_recognition_reads_a_turned_storey_as_an_upright_one(library, stages):
    from grammarkit_sketch.recognizer import get_recognizer

    rec = get_recognizer()
    st = stages["Floor"]
    values = {"spandrel_h": 1.1, "pane_w": 2.0}
    upright = rec.recognize_ink(_ink(library, st, "floor_ribbon", values, 0.0), "Floor", snippet="floor_ribbon")
    turned = _ink(library, st, "floor_ribbon", values, 4.0)
    fixed = rec.recognize_ink(turned, "Floor", snippet="floor_ribbon")
    paper = rec.recognize_ink(turned, "Floor", snippet="floor_ribbon", rectify=False)
    assert fixed.page_turn == pytest.approx(-4.0, abs=0.8) and paper.page_turn == 0.0
    assert fixed.to_dict()["page_turn"] == round(fixed.page_turn, 2)
    def err(r):
        return max(abs(r.normalized[k] - upright.normalized[k]) for k in upright.estimated)
    assert err(fixed) < err(paper)
    assert fixed.network_score > paper.network_score  # the turned-back lines match the drawing


def test_the_command_says_when_it_turned_the_page_back(library, stages, tmp_path):
    import json

    from click.testing import CliRunner
    from PIL import Image

    from grammarkit.cli import main

    st = stages["Floor"]
    ink = _ink(library, st, "floor_ribbon", {"spandrel_h": 1.1, "pane_w": 2.0}, -4.0)
    p = tmp_path / "floor.png"
    Image.fromarray((255 - ink * 255).astype(np.uint8), "L").save(p)
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Floor"])
    assert res.exit_code == 0, res.output
    assert "the page was turned +4" in res.stdout
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Floor", "--no-rectify", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["page_turn"] == 0.0
