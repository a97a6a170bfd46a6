"""Recognition with the shipped weights: from Python and from `grammarkit recognize`."""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from grammarkit.cli import main

from .conftest import LIBRARY, sketch_of

pytestmark = pytest.mark.usefixtures("torch_or_skip")

CASES = [  # (snippet, normalised parameters): instances in the middle of the ranges
    ("mass_podium", [0.5, 0.3, 0.5]), ("mass_stepped", [0.5, 0.5, 0.5]),
    ("roof_hip", [0.5, 0.5]), ("roof_gable", [0.6, 0.4]), ("roof_mansard", [0.5] * 5),
    ("facade_classic", [0.5] * 4), ("facade_banded", [0.5] * 3),
    ("floor_windows", [0.5] * 4), ("floor_ribbon", [0.5, 0.5]),
    ("window_framed", [0.5] * 3), ("window_mullion", [0.5, 0.5]),
    ("ledge_cornice", [0.5, 0.5]), ("ledge_balcony", [0.5, 0.5]),
]


@pytest.fixture(scope="module")
def rec():
    from grammarkit_sketch.recognizer import get_recognizer

    return get_recognizer(None, LIBRARY)


@pytest.mark.parametrize("snippet, u", CASES)
def test_recognises_snippets_and_their_parameters(rec, library, snippet, u):
    t = library.snippets[snippet].object_type
    img, values = sketch_of(library, rec.models.types[t].stage, snippet, u, seed=11)
    r = rec.recognize(img, t)
    assert r.snippet == snippet and r.probability > 0.5
    assert len(r.top) == min(3, len(rec.models.types[t].classes))
    assert r.top[0].snippet == snippet and r.top[0].probability >= r.top[-1].probability
    # error in normalised units, measured to the values that derive the same geometry (a floor
    # height shows only through the number of floors)
    from grammarkit_sketch.dataset import equivalence_interval

    err = []
    for k in r.estimated:
        p = next(p for p in library.snippets[snippet].params if p.name == k)
        lo, hi = equivalence_interval(rec.deriver(r.stage), snippet, values, k, p.lo, p.hi)
        v = r.values[k]
        err.append(0.0 if lo <= v <= hi else min(abs(v - lo), abs(v - hi)) / (p.hi - p.lo))
    assert np.sqrt(np.mean(np.square(err))) < 0.12
    assert 0.0 < r.score <= 1.0


@pytest.mark.parametrize("score", ["chamfer", "paper"])
def test_refinement_never_lowers_the_score(rec, library, score):
    img, _ = sketch_of(library, rec.models.types["Roof"].stage, "roof_gable", [0.3, 0.7], seed=5)
    plain = rec.recognize(img, "Roof", score=score)
    for method in ("pattern", "greedy", "metropolis"):
        r = rec.recognize(img, "Roof", refine_steps=4, method=method, seed=2, score=score)
        assert r.score >= plain.network_score == plain.score
        assert r.refine_steps == 4 and r.evaluations > 1 and r.method == method


def test_refinement_finds_the_view_of_a_sketch_drawn_off_the_stage_camera(rec, library):
    """A roof drawn 2.5 deg off in pitch and yaw, exact lines: the view search recovers the
    offsets, and the search with it ends nearer the true parameters than without."""
    from grammarkit_sketch.dataset import line_mask, stage_view
    from grammarkit_sketch.drawing import DrawStyle, draw
    from grammarkit_sketch.refine import Scorer, refine

    stage = rec.models.types["Roof"].stage
    info = library.snippets["roof_hip"]
    u_true = np.array([0.4, 0.6])
    values = {p.name: p.value(x) for p, x in zip(info.params, u_true)}
    model = rec.deriver(stage).derive("roof_hip", values)
    style = DrawStyle(sketchy=False, width=2.0, pitch_offset=2.5, yaw_offset=-2.5)
    ink = draw(model, stage_view(stage, model, stage.canvas_size(), style), style, stage.host_box())
    start = np.array([0.55, 0.45])
    errs = {}
    for view in (0.0, 3.0):
        sc = Scorer(rec.deriver(stage), info, ["roof_deg", "roof_over"], values, line_mask(ink, stage),
                    view_range=view)
        u, s, _ = refine(sc, start, 10)
        errs[view] = np.abs(u - u_true).max()
    sc = Scorer(rec.deriver(stage), info, ["roof_deg", "roof_over"], values, line_mask(ink, stage),
                view_range=3.0)
    assert sc(sc.start(u_true)) < sc(np.r_[u_true, 0.5 + 2.5 / 6, 0.5 - 2.5 / 6])
    assert errs[3.0] < errs[0.0] and errs[3.0] <= 0.03


def test_a_parameter_on_a_plateau_is_set_to_its_middle(rec, library):
    """facade_grid's floor height shows only through the number of floors: after refinement it
    is the middle of the values giving that number, and the geometry is the same."""
    from grammarkit_sketch.dataset import equivalence_interval
    from grammarkit_sketch.refine import centre_on_plateaus

    stage = rec.models.types["Facade"].stage
    info = library.snippets["facade_grid"]
    d = rec.deriver(stage)
    p = info.params[info.param_names.index("floor_h")]
    values = {**info.defaults(), "floor_h": p.lo + 0.05 * (p.hi - p.lo)}
    lo, hi = equivalence_interval(d, "facade_grid", values, "floor_h", p.lo, p.hi)
    assert hi - lo > 0.1 * (p.hi - p.lo)
    out = centre_on_plateaus(d, info, values, ["floor_h"])
    assert out["floor_h"] == pytest.approx((lo + hi) / 2)
    a, b = d.derive("facade_grid", values), d.derive("facade_grid", out)
    assert np.allclose(np.sort(np.round(a.vertices, 4), axis=0), np.sort(np.round(b.vertices, 4), axis=0))
    # a parameter that changes the drawing continuously is left where it is
    roof = library.snippets["roof_hip"]
    v = {**roof.defaults()}
    assert centre_on_plateaus(rec.deriver(rec.models.types["Roof"].stage), roof, v, ["roof_deg"]) == v


def test_bad_refinement_options_are_clear_errors(rec, library):
    from grammarkit.errors import GrammarkitError

    img, _ = sketch_of(library, rec.models.types["Roof"].stage, "roof_gable", [0.3, 0.7], seed=5)
    with pytest.raises(GrammarkitError, match="unknown refinement score 'l2'; expected one of chamfer, paper"):
        rec.recognize(img, "Roof", refine_steps=2, score="l2")
    with pytest.raises(GrammarkitError, match=r"view range must be a number of degrees in \[0, 10\], got -1"):
        rec.recognize(img, "Roof", refine_steps=2, view_range=-1)


def test_python_api_defaults_to_the_shipped_models_and_their_library(library):
    from grammarkit_sketch import get_recognizer, recognize

    img, _ = sketch_of(library, get_recognizer().models.types["Roof"].stage, "roof_pyramid", [0.5], seed=3)
    r = recognize(img, "roof")  # type names are case-insensitive
    assert r.object_type == "Roof" and r.snippet == "roof_pyramid"
    assert r.use_line() == "use roof_pyramid as Roof"
    assert r.set_options() == [f"Roof.roof_deg={float(r.values['roof_deg']):.4g}"]


def test_the_shipped_weights_match_the_library_and_are_small():
    from grammarkit_sketch.models import SHIPPED, load_models
    from grammarkit_sketch.library import load_library

    assert SHIPPED.is_file() and SHIPPED.stat().st_size < 6e6
    models = load_models(SHIPPED, load_library(LIBRARY))  # refused ("retrain") if the library changed
    assert list(models.types) == ["Mass", "Roof", "Facade", "Floor", "Window", "Ledge"]
    assert models.library_files and models.meta["library_file"] == "library.grammar"


@pytest.fixture(scope="module")
def roof_png(tmp_path_factory, rec, library):
    img, values = sketch_of(library, rec.models.types["Roof"].stage, "roof_hip", [0.4, 0.6], seed=8)
    p = tmp_path_factory.mktemp("sk") / "roof.png"
    img.save(p)
    return p, values


def test_cli_prints_top3_values_score_use_and_set(roof_png):
    p, _ = roof_png
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--library", str(LIBRARY)])
    assert res.exit_code == 0, res.output
    out = res.output
    assert out.splitlines()[0] == f"{p}: Roof sketch"
    assert "roof_hip" in out.splitlines()[1] and "<- recognised" in out.splitlines()[1]
    assert len([ln for ln in out.splitlines()[1:4] if ln.startswith("  roof_")]) == 3
    assert "roof_deg" in out and "in [15, 50]" in out and "match score:" in out
    assert "use roof_hip as Roof" in out
    assert "--set Roof.roof_deg=" in out and "--set Roof.roof_over=" in out


def test_cli_set_values_reproduce_the_recognised_model(roof_png, tmp_path):
    p, _ = roof_png
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--json", "--refine", "2"])
    data = json.loads(res.output)
    assert data["snippet"] == "roof_hip" and data["refine_steps"] == 2 and data["score"] >= data["network_score"]
    building = tmp_path / "b.grammar"
    building.write_text(f'grammar b\nimport "{LIBRARY}"\nLot --> footprint(rect(16, 12)) Mass\n'
                        f'{data["use"]}\n')
    from grammarkit.split import derive

    sets = dict(s.split("=") for s in data["set"])
    model = derive(str(building), attrs=sets)
    assert model.attrs["Roof.roof_deg"] == pytest.approx(float(sets["Roof.roof_deg"]))
    assert model.bindings["Roof"] == "roof_hip"


def test_cli_preview_and_canvas(roof_png, tmp_path):
    p, _ = roof_png
    prev = tmp_path / "prev.png"
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--preview", str(prev)])
    assert res.exit_code == 0, res.output
    img = np.asarray(Image.open(prev).convert("RGB")).astype(int)
    red = (img[..., 0] > 150) & (img[..., 1] < 90)
    grey = (np.abs(img[..., 0] - img[..., 1]) < 10) & (img[..., 0] < 200)
    assert red.sum() > 200 and grey.sum() > 100  # the model over the sketch
    canvas = tmp_path / "canvas.png"
    res = CliRunner().invoke(main, ["recognize", "--type", "Floor", "--canvas", str(canvas)])
    assert res.exit_code == 0 and "the Floor canvas" in res.output
    w, h = Image.open(canvas).size
    assert w > 3 * h


@pytest.mark.parametrize("make, args, message", [
    (lambda p: Image.new("L", (256, 228), 255).save(p), ["--type", "Roof"], "blank: no strokes"),
    (lambda p: p.write_bytes(b"\x89PNG not really"), ["--type", "Roof"], "not a readable image"),
    (lambda p: Image.fromarray(np.pad(np.zeros((10, 10), np.uint8), 100, constant_values=255)).save(p),
     ["--type", "Floor"], "canvas of this object type is"),
    (lambda p: None, ["--type", "Roof"], "sketch image not found"),
    (lambda p: Image.new("L", (64, 64), 255).save(p), ["--type", "Chimney"],
     "unknown object type 'Chimney'; the library 'library' has Mass, Roof, Facade, Floor, Window, Ledge"),
])
def test_cli_bad_input_is_a_clear_error(tmp_path, make, args, message):
    p = tmp_path / "s.png"
    make(p)
    res = CliRunner().invoke(main, ["recognize", str(p), *args])
    assert res.exit_code == 1
    assert message in res.output and "Traceback" not in res.output


def test_models_of_a_changed_library_are_refused_with_retrain(tmp_path):
    lib = tmp_path / "library.grammar"
    lib.write_text(LIBRARY.read_text().replace("@range(15, 50)", "@range(15, 51)"))
    (tmp_path / "parts").symlink_to(LIBRARY.parent / "parts")
    img = tmp_path / "s.png"
    Image.fromarray(np.pad(np.zeros((10, 10), np.uint8), 100, constant_values=255)).save(img)
    res = CliRunner().invoke(main, ["recognize", str(img), "--type", "Roof", "--library", str(lib)])
    assert res.exit_code == 1 and "retrain" in res.output


def test_a_file_that_is_not_a_models_file(tmp_path):
    bad = tmp_path / "bad.models"
    bad.write_bytes(b"hello")
    res = CliRunner().invoke(main, ["recognize", str(bad), "--type", "Roof", "--models", str(bad)])
    assert res.exit_code == 1 and "not a sketch models file" in res.output
    res = CliRunner().invoke(main, ["recognize", str(bad), "--type", "Roof", "--models", str(tmp_path / "no")])
    assert res.exit_code == 1 and "models file not found" in res.output


def test_parameter_reach_tells_a_roof_pitch_from_a_dormer_width(rec, library):
    """The roof pitch moves the ridge by tens of pixels over its range; the dormer width moves
    the dormers' sides by a few: weakly visible."""
    from grammarkit_sketch.visibility import parameter_reach

    stage = rec.models.types["Roof"].stage
    hip = parameter_reach(rec.deriver(stage), library.snippets["roof_hip"], ["roof_deg"], bases=2)
    mansard = parameter_reach(rec.deriver(stage), library.snippets["roof_mansard"], ["dormer_w"], bases=2)
    assert hip[0].hausdorff > 15 and not hip[0].weak
    assert 0 < mansard[0].hausdorff < 6 and mansard[0].weak
    assert hip[0].chamfer > mansard[0].chamfer > 0


def test_cli_runs_the_papers_refinement_beside_the_default(roof_png):
    p, _ = roof_png
    outs = {}
    for extra in ([], ["--method", "metropolis", "--score", "paper", "--view-range", "0"]):
        res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--refine", "3", "--json", *extra])
        assert res.exit_code == 0, res.output
        outs[bool(extra)] = json.loads(res.output)
    assert (outs[False]["method"], outs[False]["score_kind"]) == ("pattern", "chamfer")
    assert (outs[True]["method"], outs[True]["score_kind"]) == ("metropolis", "paper")
    for d in outs.values():
        assert d["refine_steps"] == 3 and d["evaluations"] > 1 and d["score"] >= d["network_score"]
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--score", "l1"])
    assert res.exit_code == 2 and "'l1' is not one of 'chamfer', 'paper'" in res.output
