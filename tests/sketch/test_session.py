"""Sketching a whole building: stages, the generated grammar, session files and their errors."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cli import main

from .conftest import LIBRARY, ROOT

pytestmark = pytest.mark.usefixtures("torch_or_skip")
EXAMPLE = ROOT / "docs" / "images" / "sketch_session.json"


def draw_stage(session, t, snippet, values, seed=0):
    """The strokes of a target snippet on the stage's current canvas (traced visible lines)."""
    from grammarkit_sketch.drawing import model_strokes
    from grammarkit_sketch.stages import StageDeriver

    canvas = session.canvas(t, longest=400)
    model = StageDeriver(session.library, canvas.stage).derive(snippet, values)
    view = canvas.view if canvas.stage.framing == "anchor" else canvas.stage.camera().resolve(model.vertices, canvas.size)
    return model_strokes(model, view, canvas.stage.host_box(), jitter=1.0, seed=seed), canvas.size


@pytest.fixture(scope="module")
def session():
    from grammarkit_sketch.session import Session

    s = Session(library=LIBRARY, name="test building")
    for t, snippet, values in (("Mass", "mass_podium", {"podium_h": 8, "tower_h": 40, "setback": 3}),
                               ("Roof", "roof_pyramid", {"roof_deg": 35}),
                               ("Facade", "facade_banded", {"floor_h": 3.4, "band_h": 0.4, "ground_h": 4.5})):
        strokes, size = draw_stage(s, t, snippet, values)
        r = s.add_strokes(t, strokes, size)
        assert r.snippet == snippet, (t, r.top)
    return s


def test_stages_are_framed_on_the_recognised_building(session):
    roof = session.canvas("Roof")
    top = session.stages["Mass"].recognition.values
    w, d = roof.stage.anchor_size  # the tower's top face: the lot less the set-back on each side
    assert w == pytest.approx(16 - 2 * top["setback"], abs=0.01) and d == pytest.approx(12 - 2 * top["setback"], abs=0.01)
    floor = session.canvas("Floor")
    floor_h = session.stages["Facade"].recognition.values["floor_h"]
    # the most common storey of the front: here the tower's (the lot less the set-backs) ...
    assert floor.stage.anchor_size[0] == pytest.approx(16 - 2 * top["setback"], abs=0.01)
    assert floor.stage.anchor_size[1] == pytest.approx(floor_h, abs=0.5)  # ... of a typical height
    assert "Floor face" in floor.anchor


def test_the_generated_grammar_is_one_checked_derivable_grammar(session, tmp_path):
    text = session.grammar_text(tmp_path, source="unit test")
    assert "grammar test_building" in text and "import" not in text
    for line in ("use mass_podium as Mass", "use roof_pyramid as Roof", "use facade_banded as Facade",
                 "use floor_windows as Floor", "use window_simple as Window", "use ledge_slab as Ledge"):
        assert line in text
    assert text.count("# default: not sketched") == 3
    assert "Lot --> footprint(rect(lot_w, lot_d)) Mass" in text
    tower_h = session.stages["Mass"].recognition.values["tower_h"]
    assert f"attr tower_h = {round(tower_h, 3):g}" in text
    out = tmp_path / "b.grammar"
    out.write_text(text)
    assert not [d for d in grammarkit.check(out) if d.severity == "error"]
    model = grammarkit.derive(str(out))
    assert model.bindings == {"Mass": "mass_podium", "Roof": "roof_pyramid", "Facade": "facade_banded",
                              "Floor": "floor_windows", "Window": "window_simple", "Ledge": "ledge_slab"}
    assert model.attrs["Mass.tower_h"] == pytest.approx(round(tower_h, 3))
    assert model.mesh.is_watertight
    assert grammarkit.format(text) == text  # printed canonically


def test_inserted_parts_resolve_from_the_output_folder(tmp_path):
    from grammarkit_sketch.session import Session

    s = Session(library=LIBRARY)
    strokes, size = draw_stage(s, "Roof", "roof_mansard", {})
    s.add_strokes("Roof", strokes, size, snippet="roof_mansard")
    out = tmp_path / "deep" / "b.grammar"
    out.parent.mkdir()
    out.write_text(s.grammar_text(out.parent))
    assert 'i("../' in out.read_text()
    assert grammarkit.derive(str(out)).bindings["Roof"] == "roof_mansard"


def test_a_stage_without_an_anchor_says_so():
    from grammarkit_sketch.session import Session, SessionError

    s = Session(library=LIBRARY)
    s.stages.clear()
    # the default facade (facade_grid) has no ledges: nowhere to put a sketched ledge
    with pytest.raises(SessionError, match="no Ledge anchor"):
        s.canvas("Ledge")


def test_the_example_session_runs_from_the_command_line(tmp_path):
    out = tmp_path / "building.grammar"
    pics = tmp_path / "canvases"
    res = CliRunner().invoke(main, ["sketch-session", str(EXAMPLE), "-o", str(out), "--canvases", str(pics)])
    assert res.exit_code == 0, res.output
    data = json.loads(EXAMPLE.read_text())
    for st in data["stages"]:
        assert st["drawn_from"]["snippet"] in res.output
    assert sorted(p.name for p in pics.glob("*.png")) == [f"{i + 1:02d}_{t}.png" for i, t in
                                                         enumerate(["Mass", "Roof", "Facade", "Floor", "Window", "Ledge"])]
    res = CliRunner().invoke(main, ["check", str(out)])
    assert res.exit_code == 0, res.output
    glb = tmp_path / "b.glb"
    res = CliRunner().invoke(main, ["derive", str(out), "-o", str(glb)])
    assert res.exit_code == 0 and glb.stat().st_size > 1000, res.output


def _session_file(tmp_path, data):
    p = tmp_path / "s.json"
    p.write_text(data if isinstance(data, str) else json.dumps(data))
    return p


@pytest.mark.parametrize("data, message", [
    ('{"format": "grammarkit-sketch-session",\n "stages": [}', "s.json:2:13: not valid JSON"),
    ({"stages": []}, 'expected "format": "grammarkit-sketch-session"'),
    ({"format": "grammarkit-sketch-session", "stages": []}, '"stages" must be a non-empty list'),
    ({"format": "grammarkit-sketch-session", "version": 9, "stages": [{}]}, "format version 9"),
    ({"format": "grammarkit-sketch-session", "stages": [{"type": "Chimney", "strokes": [[[1, 2]]]}]},
     "stage 1: unknown object type 'Chimney'"),
    ({"format": "grammarkit-sketch-session", "stages": [{"type": "Mass", "strokes": [[[1, 2], [3, 4]]]},
                                                         {"type": "mass", "strokes": [[[1, 2]]]}]},
     "stage 2: object type Mass is sketched twice"),
    ({"format": "grammarkit-sketch-session", "stages": [{"type": "Mass", "strokes": [[[1, "a"]]]}]},
     "stroke 1 has a bad point [1, 'a']"),
    ({"format": "grammarkit-sketch-session", "stages": [{"type": "Mass", "strokes": []}]},
     "strokes must be a non-empty list"),
    ({"format": "grammarkit-sketch-session", "stages": [
        {"type": "Roof", "canvas": [300, 300], "strokes": [[[10, 10], [200, 200]]]}]},
     "the canvas of this object type is"),
])
def test_bad_session_files_are_clear_errors(tmp_path, data, message):
    p = _session_file(tmp_path, data)
    res = CliRunner().invoke(main, ["sketch-session", str(p), "-o", str(tmp_path / "o.grammar")])
    assert res.exit_code == 1, res.output
    assert message in res.output and "Traceback" not in res.output
    assert not (tmp_path / "o.grammar").exists()
