"""The derive worker: a call that overruns its time budget ends the worker process (a runaway
grammar cannot hang the server) and the next call works in a fresh one; a crashed worker is
restarted; operations report grammarkit errors with their locations."""
from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from grammarkit_studio.work import Work
from grammarkit_studio.worker import BudgetExceeded, CallFailed, Worker, WorkerFailed

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"
# 19,600 boxes: within the engine's limits, but ~35 s of work on this machine
SLOW = """grammar slow
Lot --> footprint(rect(70, 70)) Ground
Ground --> split(x) { { ~0.5: Col }* }
Col --> split(y) { { ~0.5: Cell }* }
Cell --> extrude(0.3) Box.
"""


@pytest.fixture()
def worker(tmp_path):
    w = Worker(str(PARIS), str(PARIS.parent), "test")
    yield w
    w.close()


def test_budget_stops_a_runaway_derive_and_restarts(worker, tmp_path):
    text = PARIS.read_text()
    out = worker.call("check", 60, text=text)
    assert out["ok"] and out["family"] == "split"
    first = worker.pid
    with pytest.raises(BudgetExceeded, match="time budget of 0.3 s"):
        worker.call("derive", 0.3, text=SLOW, attrs={}, seed=0)
    assert worker.pid is None and worker.restarts == 1
    try:
        os.kill(first, 0)
        alive = True
    except ProcessLookupError:
        alive = False
    assert not alive, "the overrunning worker process must be gone"
    out = worker.call("derive", 60, text=text, attrs={"mass_h": 40}, seed=1)
    assert out["ok"] and out["facts"]["attrs"]["mass_h"] == 40 and out["glb"][:4] == b"glTF"


def test_a_crashed_worker_is_restarted(worker):
    worker.call("check", 60, text=PARIS.read_text())
    os.kill(worker.pid, signal.SIGKILL)
    with pytest.raises(WorkerFailed, match="restarted"):
        worker.call("check", 60, text=PARIS.read_text())
    assert worker.call("check", 60, text=PARIS.read_text())["ok"]


def test_errors_are_located_and_unknown_ops_refused(worker):
    bad = PARIS.read_text().replace("footprint(rect(lot_w, lot_d))", "footprint(rect(lot_w, lot_d)) extrude(nope)")
    out = worker.call("derive", 60, text=bad, attrs={}, seed=0)
    assert not out["ok"]
    (d,) = [d for d in out["check"]["diagnostics"] if d["severity"] == "error"]
    assert d["line"] == 17 and "nope" in d["message"]
    with pytest.raises(CallFailed) as info:
        worker.call("export", 60, fmt="exe")
    assert "unknown export format" in info.value.info["message"]
    with pytest.raises(Exception, match="unknown worker operation"):
        worker.call("__init__", 60)


def test_sliders_from_range_and_enum_attrs(tmp_path):
    path = tmp_path / "g.grammar"
    text = ('grammar g\nattr h = 10 @range(4, 2 * 10)\nattr n = 3 @range(1, 9)\n'
            'attr style = "flat" @enum("flat", "gable")\nattr k = 2 @range(1, h)\n'
            'Lot --> footprint(rect(8, 6)) extrude(h) NIL\n')
    path.write_text(text)
    sliders = {s["name"]: s for s in Work(str(path), str(tmp_path)).check(text)["sliders"]}
    assert sliders["h"]["min"] == 4 and sliders["h"]["max"] == 20 and sliders["h"]["line"] == 2
    assert sliders["n"]["step"] == 1
    assert sliders["style"] == {"name": "style", "kind": "enum", "choices": ["flat", "gable"],
                                "value": "flat", "line": 4}
    assert "k" not in sliders  # a bound that needs a name's value gets no guessed slider


def test_pick_finds_the_part_under_a_point():
    text = PARIS.read_text()
    work = Work(str(PARIS), str(PARIS.parent))
    assert work.derive(text, {}, 0)["ok"]
    glass = next(p for p in work.model.parts if p.name == "Glass")
    centre = [glass.origin[i] + 0.5 * glass.size[0] * glass.axes[0][i] + 0.5 * glass.size[1] * glass.axes[1][i]
              for i in range(3)]
    out = work.pick(centre, "Glass")
    assert out["part"]["id"] == glass.id and out["distance"] == 0
    assert out["path"][0] == 0 and out["path"][-1] == glass.node
    assert out["source"]["file"].endswith("library.grammar")
    rows = work.tree()["nodes"]
    assert [rows[i][2] for i in out["path"]][:2] == ["Lot", "Mass"]
    below = work.node_box([out["path"][-3]])
    assert below["count"] > 1 and any(p["id"] == glass.id for p in below["parts"])


def test_empty_and_exampleless_grammars_say_what_is_missing(tmp_path):
    path = tmp_path / "g.grammar"
    work = Work(str(path), str(tmp_path))
    out = work.derive("grammar g\n", {}, 0)
    assert not out["ok"] and "no rules, parts or examples" in out["error"]["message"]
    tiling = "grammar t\npart A = box(1, 1, 1)\nneighbors A: {A}\n"
    out = work.derive(tiling, {}, 0)
    assert not out["ok"] and "no `example`" in out["error"]["message"] and out["check"]["family"] == "tiling"
