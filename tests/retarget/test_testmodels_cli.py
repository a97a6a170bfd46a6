"""`python -m grammarkit_retarget.testmodels` (issue 32 item 5): progress on stderr, one line per
file on stdout, --json for machines, a usage line for bad arguments."""
from __future__ import annotations

import json

import trimesh
from grammarkit_retarget import testmodels


def test_writes_every_model_and_says_what(tmp_path, capsys):
    assert testmodels.main([str(tmp_path), "--json"]) == 0
    out, err = capsys.readouterr()
    rows = json.loads(out)  # stdout is the JSON only; the progress display is on stderr
    assert [r["path"] for r in rows] == [str(tmp_path / f"{n}.glb") for n in testmodels.MODELS]
    for r in rows:
        assert r["triangles"] == len(trimesh.load(r["path"], force="mesh").faces) > 0
    assert "Traceback" not in err


def test_human_summary_and_usage(tmp_path, capsys):
    assert testmodels.main([str(tmp_path)]) == 0
    out, _ = capsys.readouterr()
    lines = out.splitlines()
    assert len(lines) == len(testmodels.MODELS)
    assert all(ln.startswith("wrote ") and ln.endswith(" triangles)") for ln in lines)
    assert testmodels.main([]) == 2 and "usage:" in capsys.readouterr().err


def test_progress_callback_sees_every_model(tmp_path):
    calls = []
    testmodels.write_models(tmp_path, ["picket_fence", "bookshelf"], progress=lambda *a: calls.append(a))
    assert calls == [("picket_fence", 0, 2), ("bookshelf", 1, 2), ("", 2, 2)]
