"""Centre lines (strokes.py): one line width for every pen, in training and recognition alike;
the per-type classifier input and the graft of one file's regressors onto another's
classifiers (train_shipped.py's step 2)."""
from __future__ import annotations

import numpy as np
import pytest

from grammarkit_sketch.strokes import CENTRE_LINES, centre_lines, classifier_input, thin


def _rect(width):
    img = np.zeros((96, 96), dtype=bool)
    h = width // 2
    img[20 - h:20 - h + width, 10:86] = True  # top
    img[76 - h:76 - h + width, 10:86] = True  # bottom
    img[20:76, 10 - h:10 - h + width] = True  # left
    img[20:76, 86 - h:86 - h + width] = True  # right
    return img


@pytest.mark.parametrize("width", [1, 3, 5, 7])
def test_every_pen_width_thins_to_the_same_one_pixel_outline(width):
    skel = thin(_rect(width))
    # one pixel wide: no 2 x 2 block of line pixels anywhere
    blocks = skel[:-1, :-1] & skel[1:, :-1] & skel[:-1, 1:] & skel[1:, 1:]
    assert not blocks.any()
    # on the rectangle's centre line, within a pixel, and about as long as it
    ys, xs = np.nonzero(skel)
    near = (np.abs(ys - 20) <= 1) | (np.abs(ys - 76) <= 1) | (np.abs(xs - 10) <= 1) | (np.abs(xs - 86) <= 1)
    assert near.mean() > 0.97
    assert abs(skel.sum() - thin(_rect(1)).sum()) <= 0.1 * thin(_rect(1)).sum()


def test_thinning_keeps_a_drawing_connected_and_a_batch_is_thinned_image_by_image():
    from scipy.ndimage import label

    img = _rect(5)
    assert label(thin(img), structure=np.ones((3, 3)))[1] == 1  # still one closed outline
    batch = np.stack([_rect(1), _rect(7), np.zeros((96, 96), dtype=bool)])
    out = thin(batch)
    assert out.shape == batch.shape and not out[2].any()
    assert np.array_equal(out[1], thin(_rect(7)))


def test_centre_lines_keep_the_dtype_and_scale():
    x = _rect(5).astype(np.float32) * 0.9
    got = centre_lines(x)
    assert got.dtype == np.float32 and set(np.unique(got)) <= {0.0, 1.0}
    u8 = (_rect(5) * 255).astype(np.uint8)
    assert centre_lines(u8).dtype == np.uint8 and centre_lines(u8).max() == 255
    assert classifier_input(x, "as-drawn") is x
    assert np.array_equal(classifier_input(x, CENTRE_LINES), got)
    with pytest.raises(ValueError, match="unknown classifier input 'skeleton'"):
        classifier_input(x, "skeleton")


def test_train_config_names_the_input_of_each_type():
    from grammarkit_sketch.training import TrainConfig

    assert TrainConfig().input_of("Roof") == "as-drawn"
    cfg = TrainConfig(classifier_input={"Roof": CENTRE_LINES})
    assert cfg.input_of("roof") == CENTRE_LINES and cfg.input_of("Mass") == "as-drawn"
    assert cfg.to_dict()["classifier_input"] == {"Roof": CENTRE_LINES}


def test_the_classifier_input_option_is_checked(tmp_path):
    from click.testing import CliRunner

    from grammarkit.cli import main

    from .conftest import LIBRARY

    for bad, message in (("skeleton", "unknown classifier input 'skeleton'"),
                         ("Roof=centre-lines,Mass", "expected TYPE=KIND, got 'Mass'")):
        res = CliRunner().invoke(main, ["train", "sketch", "--library", str(LIBRARY), "-o",
                                        str(tmp_path / "m"), "--samples", "24", "--classifier-input", bad])
        assert res.exit_code == 2 and message in res.output, res.output


def test_a_trained_type_reads_what_its_file_says(tmp_path, torch_or_skip):
    """Trained with centre lines, a type's file says so, and recognition thins its input too:
    the classifier's logits of a drawing equal those of the drawing's centre lines."""
    from click.testing import CliRunner

    from grammarkit.cli import main
    from grammarkit_sketch.models import graft_regressors, load_models
    from grammarkit_sketch.recognizer import get_recognizer

    from .conftest import LIBRARY

    out = tmp_path / "c.models"
    res = CliRunner().invoke(main, ["train", "sketch", "--library", str(LIBRARY), "-o", str(out),
                                    "--types", "Ledge", "--samples", "20", "--classifier-epochs", "1",
                                    "--regressor-epochs", "1", "--no-cache", "--classifiers-only",
                                    "--classifier-input", "Ledge=centre-lines"])
    assert res.exit_code == 0, res.output
    # not a terminal: the progress comes as plain lines (rich's bars would show nothing until the end)
    assert "Ledge: rendering 3 x 20 sketches: 0 of 60" in res.output
    assert "Ledge: rendering 3 x 20 sketches: 60 of 60" in res.output
    models = load_models(out)
    tm = models.types["Ledge"]
    assert tm.metrics["classifier_input"] == CENTRE_LINES and not tm.regressors
    rec = get_recognizer(out)
    x = np.zeros((128, 128), dtype=np.float32)
    x[60:65, 10:120] = 1.0
    assert np.allclose(rec.logits(tm, x), rec.logits(tm, centre_lines(x)))
    # the shipped regressors grafted onto these classifiers
    shipped = load_models()
    only_ledge = type(shipped)(shipped.library_hash, shipped.library_name, {"Ledge": shipped.types["Ledge"]},
                               shipped.meta, shipped.path, shipped.library_files)
    both = graft_regressors(models, only_ledge)
    assert set(both.types["Ledge"].regressors) == set(shipped.types["Ledge"].regressors)
    assert both.types["Ledge"].classifier is tm.classifier
    assert both.meta["regressors_from"]["config"] == shipped.meta["config"]
    other = type(shipped)("0" * 12, shipped.library_name, {}, {}, "other.pt", {})
    with pytest.raises(Exception, match="trained on another library"):
        graft_regressors(models, other)
