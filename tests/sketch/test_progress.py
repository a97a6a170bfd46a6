"""Long commands speak (issue 32 item 5): sketch-session reports each stage to a progress
callback (the CLI shows it with rich on stderr), stdout keeps the summary or clean JSON."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from grammarkit.cli import main

from .conftest import LIBRARY
from .test_session import draw_stage

pytestmark = pytest.mark.usefixtures("torch_or_skip")


@pytest.fixture(scope="module")
def one_stage_file(tmp_path_factory):
    from grammarkit_sketch.session import Session

    s = Session(library=LIBRARY)
    strokes, size = draw_stage(s, "Roof", "roof_hip", {"roof_deg": 35})
    p = tmp_path_factory.mktemp("progress") / "s.json"
    p.write_text(json.dumps({"format": "grammarkit-sketch-session",
                             "stages": [{"type": "Roof", "canvas": list(size), "strokes": strokes}]}))
    return p


def test_session_reports_each_stage_then_the_end(one_stage_file):
    from grammarkit_sketch.session import Session

    calls = []
    s = Session.from_file(one_stage_file, library=LIBRARY, progress=lambda *a: calls.append(a))
    assert calls == [("Roof", 0, 1), ("", 1, 1)]
    assert s.stages["Roof"].recognition.snippet == "roof_hip"


def test_session_json_stays_parseable_and_the_summary_is_short(one_stage_file, tmp_path):
    out = tmp_path / "b.grammar"
    res = CliRunner().invoke(main, ["sketch-session", str(one_stage_file), "-o", str(out),
                                    "--library", str(LIBRARY), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)  # nothing but the JSON on stdout (progress goes to stderr)
    assert data["stages"]["Roof"]["snippet"] == "roof_hip"
    res = CliRunner().invoke(main, ["sketch-session", str(one_stage_file), "-o", str(out),
                                    "--library", str(LIBRARY)])
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert lines[-1] == f"wrote {out}" and len(lines) <= 8
    assert any(ln.startswith("Roof") and "roof_hip" in ln for ln in lines)


def test_recognize_json_is_clean_on_stdout(tmp_path):
    import numpy as np
    from grammarkit_sketch.session import Session
    from PIL import Image

    s = Session(library=LIBRARY)
    strokes, size = draw_stage(s, "Roof", "roof_gable", {"roof_deg": 30})
    from grammarkit_sketch.drawing import strokes_to_ink

    ink = strokes_to_ink(strokes, size, 2.0)
    p = tmp_path / "roof.png"
    Image.fromarray((255 - ink * 255).astype(np.uint8)).save(p)
    res = CliRunner().invoke(main, ["recognize", str(p), "--type", "Roof", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["snippet"] == "roof_gable"
