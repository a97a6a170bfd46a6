"""The run layer's write-behind thread (grammarkit.run.write_behind): same folder as synchronous
writes, bounded, errors raised in the caller, a stop leaves only complete results."""
from __future__ import annotations

import json
import threading

import pytest

from grammarkit.run import run_backend
from grammarkit.run.write_behind import WriteBehind, write_behind_enabled
from grammarkit.run.writer import OutputFolder, WriteStopped


def _lines(folder):
    """Manifest lines without the timing fields (the only ones that may differ)."""
    out = []
    for line in (folder / "manifest.jsonl").read_text().splitlines():
        entry = json.loads(line)
        entry["metrics"] = {k: v for k, v in entry["metrics"].items() if not k.endswith("seconds")}
        out.append(entry)
    return out


def test_the_switch_reads_the_environment(monkeypatch):
    monkeypatch.delenv("GRAMMARKIT_WRITE_BEHIND", raising=False)
    assert write_behind_enabled()
    for off in ("0", "false", "off", "no"):
        monkeypatch.setenv("GRAMMARKIT_WRITE_BEHIND", off)
        assert not write_behind_enabled()


def test_write_behind_writes_the_same_folder_as_synchronous_writes(small, tmp_path, monkeypatch):
    seen_threads = []

    def on_result(entry):
        seen_threads.append(threading.current_thread())

    monkeypatch.setenv("GRAMMARKIT_WRITE_BEHIND", "0")
    sync = run_backend(small, out=tmp_path / "sync", n=12, seed=3, options={"variations": True})
    monkeypatch.setenv("GRAMMARKIT_WRITE_BEHIND", "1")
    behind = run_backend(small, out=tmp_path / "behind", n=12, seed=3, options={"variations": True},
                         on_result=on_result)
    assert sync.written == behind.written == 12
    assert _lines(tmp_path / "sync") == _lines(tmp_path / "behind")
    for entry in _lines(tmp_path / "sync"):
        assert (tmp_path / "sync" / entry["file"]).read_bytes() == \
            (tmp_path / "behind" / entry["file"]).read_bytes()
    # callbacks run in the caller's thread, once per result, and the thread is gone afterwards
    assert seen_threads == [threading.main_thread()] * 12
    assert not [t for t in threading.enumerate() if t.name == "grammarkit-write-behind"]


class _SlowFolder:
    """An OutputFolder stand-in whose add waits for `release` and fails at `fail_at`."""

    def __init__(self, fail_at=None):
        self.entries, self.release, self.fail_at = [], threading.Event(), fail_at
        self.started = threading.Event()

    @property
    def done(self):
        return len(self.entries)

    def add(self, entry, files):
        self.started.set()
        self.release.wait(10)
        if self.fail_at is not None and len(self.entries) == self.fail_at:
            raise OSError(28, "No space left on device")
        self.entries.append(entry)
        return entry


def test_the_queue_is_bounded_and_keeps_the_order():
    folder = _SlowFolder()
    behind = WriteBehind(folder, depth=3)
    putter = threading.Thread(target=lambda: [behind.put({"id": i}, {"x": b"1"}) for i in range(10)])
    putter.start()
    folder.started.wait(5)
    putter.join(0.3)
    # one result being written and `depth` waiting: the caller is held at the fifth
    assert putter.is_alive() and behind.handed == 4
    folder.release.set()
    putter.join(5)
    behind.close()
    assert [e["id"] for e in folder.entries] == list(range(10))
    assert [e["id"] for e in behind.written()] == list(range(10))


def test_a_failed_write_stops_the_writing_and_is_raised_in_the_caller():
    folder = _SlowFolder(fail_at=2)
    folder.release.set()
    behind = WriteBehind(folder, depth=2)
    with pytest.raises(WriteStopped, match="lists the 2 complete results"):
        for i in range(50):
            behind.put({"id": i}, {"x": b"1"})
        behind.close()
    with pytest.raises(WriteStopped):
        behind.close()  # closing again raises the same error, and nothing more was written
    assert [e["id"] for e in folder.entries] == [0, 1]


def test_abandon_finishes_the_write_in_progress_and_drops_the_queue():
    folder = _SlowFolder()
    behind = WriteBehind(folder, depth=8)
    for i in range(6):
        behind.put({"id": i}, {"x": b"1"})
    folder.started.wait(5)
    threading.Timer(0.2, folder.release.set).start()
    behind.close(abandon=True)
    assert [e["id"] for e in folder.entries] == [0]


def test_a_write_error_during_a_real_run_leaves_the_manifest_a_prefix(small, tmp_path, monkeypatch):
    calls = {"n": 0}
    real_add = OutputFolder.add

    def failing_add(self, entry, files):
        calls["n"] += 1
        if calls["n"] == 4:
            raise OSError(28, "No space left on device")
        return real_add(self, entry, files)

    monkeypatch.setenv("GRAMMARKIT_WRITE_BEHIND", "1")
    monkeypatch.setattr(OutputFolder, "add", failing_add)
    with pytest.raises(WriteStopped, match="lists the 3 complete results"):
        run_backend(small, out=tmp_path / "out", n=10, seed=1)
    entries = _lines(tmp_path / "out")
    assert [e["index"] for e in entries] == [0, 1, 2]
    models = sorted(p.name for p in (tmp_path / "out").glob("*.glb"))
    assert models == [e["file"] for e in entries]
    monkeypatch.setattr(OutputFolder, "add", real_add)
    rest = run_backend(small, out=tmp_path / "out", n=10, seed=1)
    assert (rest.resumed, rest.written) == (3, 7)
