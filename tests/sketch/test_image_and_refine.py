"""Reading sketches (and refusing bad ones), the refinement score and the two searches."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from grammarkit_sketch.image import SketchError, check_aspect, distance_map, load_ink, to_input
from grammarkit_sketch.refine import GREEDY_STEP, greedy, metropolis, score_from_distance


def _square(size=200, width=3):
    a = np.full((size, size), 255, np.uint8)
    a[40:40 + width, 40:160] = 0
    a[40:160, 40:40 + width] = 0
    return a


def test_reads_paths_images_and_arrays(tmp_path):
    a = _square()
    Image.fromarray(a).save(tmp_path / "s.png")
    from_path = load_ink(tmp_path / "s.png")
    from_array = load_ink(a)
    rgba = Image.fromarray(np.dstack([np.zeros((200, 200, 3), np.uint8), 255 - a]), "RGBA")
    from_rgba = load_ink(rgba)  # black lines on a transparent background
    assert np.allclose(from_path, from_array) and np.allclose(from_array, from_rgba, atol=0.01)
    assert from_path.max() == pytest.approx(1.0) and from_path[0, 0] == 0.0


@pytest.mark.parametrize("make, message", [
    (lambda p: None, "sketch image not found"),
    (lambda p: p.write_text("not an image"), "not a readable image"),
    (lambda p: Image.new("L", (300, 300), 255).save(p, format="PNG"), "blank: no strokes"),
    (lambda p: Image.new("L", (20, 300), 0).save(p, format="PNG"), "at least 32 pixels"),
    (lambda p: Image.new("L", (300, 300), 10).save(p, format="PNG"), "mostly dark"),
])
def test_bad_images_are_refused_with_the_reason(tmp_path, make, message):
    p = tmp_path / "bad.png"
    make(p)
    with pytest.raises(SketchError, match=message) as err:
        load_ink(p)
    assert str(p) in str(err.value)


def test_a_grey_scan_is_levelled():
    a = _square().astype(np.float32)
    scan = (a * 0.6 + 90).astype(np.uint8)  # grey paper, grey lines
    assert load_ink(scan)[0, 0] == 0.0  # the paper becomes white
    assert np.abs(to_input(load_ink(scan), "anchor") - to_input(load_ink(a), "anchor")).max() < 0.05


def test_canvas_aspect_is_checked():
    ink = np.zeros((100, 300), np.float32)
    check_aspect(ink, (600, 200), "x")
    with pytest.raises(SketchError, match="300x100 pixels .* canvas of this object type is 256x256"):
        check_aspect(ink, (256, 256), "x")


def test_input_levels_thin_lines_to_black():
    a = np.zeros((512, 512), np.float32)
    a[100, 50:450] = 1.0  # one-pixel line, a quarter pixel after reduction
    x = to_input(a, "anchor")
    assert x.shape == (128, 128) and x.max() == pytest.approx(1.0)


def test_score_is_one_for_a_perfect_match_and_falls_with_distance():
    x = np.zeros((128, 128), np.float32)
    x[40, 20:100] = 1
    d = distance_map(x)
    assert score_from_distance(d, d) == 1.0
    y = np.roll(x, 2, axis=0)
    z = np.roll(x, 6, axis=0)
    assert 1.0 > score_from_distance(distance_map(y), d) > score_from_distance(distance_map(z), d)
    assert distance_map(np.zeros((8, 8))).min() == 8  # nothing drawn: as far as can be


def _bowl(target):
    return lambda u: float(np.exp(-np.abs(np.asarray(u) - target).sum() * 10))


def test_greedy_walks_to_the_optimum_with_shrinking_steps():
    target = np.array([0.3, 0.71])
    u, s = greedy(_bowl(target), np.array([0.5, 0.5]), 40)
    assert np.abs(u - target).max() <= GREEDY_STEP  # within a final step
    calls = []

    def counting(u):
        calls.append(np.asarray(u).copy())
        return _bowl(target)(u)
    greedy(counting, np.array([0.5, 0.5]), 12)
    steps = {round(abs(c - 0.5).max(), 6) for c in calls[1:5]}
    assert steps == {GREEDY_STEP}  # first sweep: +/- 0.02 on each parameter


def test_metropolis_keeps_the_best_state_and_is_seeded():
    target = np.array([0.2, 0.8, 0.5])
    f = _bowl(target)
    start = np.array([0.5, 0.5, 0.5])
    u1, s1 = metropolis(f, start, 60, seed=3)
    u2, s2 = metropolis(f, start, 60, seed=3)
    assert np.array_equal(u1, u2) and s1 == s2
    assert s1 >= f(start) and s1 == pytest.approx(f(u1))


def test_line_mask_keeps_a_fine_pen_whole():
    """A 1 px line on a 184 px wide canvas is 0.7 px at the 128 px score canvas: resizing and
    thresholding the grey image broke it into dashes (a sketch then scored ~0 against its own
    model); the mask is found at the drawing's resolution and pooled."""
    from grammarkit_sketch.dataset import line_mask, quick_size
    from grammarkit_sketch.stages import StageSpec

    stage = StageSpec("Window", "face", (1.4, 2.2), 0.0, 0.0)
    w, h = stage.canvas_size()
    ink = np.zeros((h, w), np.float32)
    ink[h // 3, 10:w - 10] = 0.8  # a fine, slightly grey pen
    ink[20:h - 20, w // 2] = 0.8
    m = line_mask(ink, stage)
    W, H = quick_size(stage)
    assert m.shape == (H, W)
    row = m[int(round(h // 3 * H / h)) - 1:int(round(h // 3 * H / h)) + 2].any(axis=0)
    col = m[:, int(round(w // 2 * W / w)) - 1:int(round(w // 2 * W / w)) + 2].any(axis=1)
    assert row[8:W - 8].all() and col[16:H - 16].all()  # unbroken


def test_chamfer_score_is_one_for_a_match_falls_with_distance_and_is_capped():
    from grammarkit_sketch.refine import CHAMFER_CAP, chamfer_score

    x = np.zeros((128, 128), bool)
    x[40, 20:100] = True
    d = distance_map(x)
    assert chamfer_score(x, d, x, d) == 1.0
    s = [chamfer_score(y, distance_map(y), x, d) for y in (np.roll(x, k, axis=0) for k in (1, 3, 20, 60))]
    assert 1.0 > s[0] > s[1] > s[2]
    assert s[2] == s[3] == pytest.approx(np.exp(-CHAMFER_CAP))  # a stroke far off: the cap
    assert chamfer_score(np.zeros_like(x), d, x, d) == pytest.approx(np.exp(-CHAMFER_CAP))


def test_pattern_search_shrinks_its_steps_to_the_optimum():
    from grammarkit_sketch.refine import PATTERN_MIN_STEP, PATTERN_STEP, pattern

    target = np.array([0.31, 0.77])
    u, s = pattern(_bowl(target), np.array([0.5, 0.5]), 40)
    assert np.abs(u - target).max() <= PATTERN_MIN_STEP
    calls = []

    def counting(u):
        calls.append(np.asarray(u).copy())
        return _bowl(target)(u)
    pattern(counting, np.array([0.5, 0.5]), 1)
    assert abs(calls[1][0] - 0.5) == pytest.approx(PATTERN_STEP)  # the first move: a large step


def test_scan_leaves_a_wrong_basin_that_local_steps_cannot():
    from grammarkit_sketch.refine import pattern, scan

    def two_basins(u):  # a small bump at 0.2, the optimum at 0.8
        x = float(u[0])
        return max(0.5 * np.exp(-((x - 0.2) / 0.05) ** 2), np.exp(-((x - 0.8) / 0.05) ** 2))
    u, _ = pattern(two_basins, np.array([0.2]), 20)
    assert abs(u[0] - 0.2) < 0.05  # stuck in the bump
    u, s = scan(two_basins, np.array([0.2]), 11)
    assert abs(u[0] - 0.8) < 0.06 and s > 0.9


def test_a_flat_score_gives_the_parameter_back_to_the_network():
    from grammarkit_sketch.refine import keep_network_values

    def score(u):  # flat in u[0] below 0.4 (the drawing cannot tell), a bowl in u[1]
        return float(np.exp(-max(0.0, u[0] - 0.4) * 5 - abs(u[1] - 0.7) * 5))
    u_net = np.array([0.3, 0.5])
    u, s = keep_network_values(score, np.array([0.0, 0.7]), score([0.0, 0.7]), u_net, 0.003)
    assert u[0] == 0.3  # the flat part: the network's value
    assert u[1] == pytest.approx(0.7, abs=0.01)  # the score decides: stays (within tolerance)
    assert s == score(u) >= score([0.0, 0.7]) * 0.997
    # moves back only as far as the score allows, never below `at_least`
    u, s = keep_network_values(score, np.array([0.0, 0.7]), score([0.0, 0.7]), np.array([0.9, 0.7]), 0.1)
    assert 0.39 < u[0] <= 0.421 and s >= score([0.0, 0.7]) * 0.9  # bisection: within 0.9 / 32
    u, s = keep_network_values(score, np.array([0.0, 0.7]), 1.0, np.array([0.9, 0.7]), 0.1, at_least=1.0)
    assert u[0] <= 0.4 and s == 1.0


class _BowlScorer:
    """A stand-in for refine.Scorer: exp(-|u - optimum|^2 / 0.02), no view search."""

    def __init__(self, optimum):
        self.optimum = np.asarray(optimum, float)

    def start(self, u):
        return np.asarray(u, float)

    def __call__(self, u):
        d = np.asarray(u, float) - self.optimum
        return float(np.exp(-(d @ d) / 0.02))


def test_the_prior_weighs_the_score_against_the_networks_estimate():
    import math

    from grammarkit_sketch.refine import refine, with_prior

    scorer = _BowlScorer([0.8])
    f = with_prior(scorer, np.array([0.5]), 0.1)
    assert f(np.array([0.6])) == pytest.approx(scorer(np.array([0.6])) * math.exp(-0.5))
    # maximum of exp(-(u-0.8)^2/0.02 - (u-0.5)^2/0.02) is at the midpoint 0.65
    u, s, _ = refine(scorer, np.array([0.5]), 20, prior_sigma=0.1)
    assert u[0] == pytest.approx(0.65, abs=0.01) and s == pytest.approx(scorer(u))
    u_alone, _, _ = refine(scorer, np.array([0.5]), 20)
    assert u_alone[0] == pytest.approx(0.8, abs=0.01)  # the score alone goes to its optimum
    u_narrow, _, _ = refine(scorer, np.array([0.5]), 20, prior_sigma=0.01)
    assert abs(u_narrow[0] - 0.5) < 0.01  # a network far surer than the score keeps its value
    with pytest.raises(ValueError, match="prior sigma"):
        refine(scorer, np.array([0.5]), 5, prior_sigma=0.0)


def test_the_prior_is_the_regressors_validation_error_with_a_floor():
    from types import SimpleNamespace

    from grammarkit_sketch.recognizer import PRIOR_FLOOR, prior_sigma

    tm = SimpleNamespace(metrics={"val_rmse.roof_hip": 0.05, "val_rmse.roof_flat": 0.001})
    assert prior_sigma(tm, "roof_hip") == 0.05
    assert prior_sigma(tm, "roof_flat") == PRIOR_FLOOR
    assert prior_sigma(tm, "roof_gable") is None  # no metric: no prior
