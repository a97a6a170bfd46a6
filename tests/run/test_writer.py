"""The one writer: whole files or none, a manifest that lists exactly the files of complete
results, runs that continue or are refused, outputs that never replace inputs."""
from __future__ import annotations

import json
import os

import pytest

from grammarkit.errors import ShapeError
from grammarkit.fileio import LOCK_NAME, FolderBusy
from grammarkit.run.writer import MANIFEST, PENDING, OutputFolder, RunMismatch, check_outputs, write_files

RUN = {"backend": "test", "seed": 1, "n": 3}


def folder(path, **kw):
    return OutputFolder(path, dict(RUN, **kw.pop("run", {})), **kw)


def add(f, i, data=b"x"):
    name = f"r{i}.bin"
    return f.add({"id": f"r{i}", "index": i, "file": name, "attachments": {}}, {name: data})


def lines(path):
    return [json.loads(x) for x in (path / MANIFEST).read_text().splitlines()]


def listing(path):
    """The folder's files, without the run's lock file (there while a run holds the folder)."""
    return sorted(p.name for p in path.iterdir() if p.name != LOCK_NAME)


def test_nothing_but_the_lock_is_created_before_the_first_result(tmp_path):
    out = tmp_path / "a" / "b"
    f = folder(out)
    assert [p.name for p in out.iterdir()] == [LOCK_NAME] and f.done == 0
    f.close()
    assert not out.exists()  # made for the lock and left empty: removed again
    f = folder(out)
    add(f, 0)
    assert listing(out) == ["manifest.jsonl", "r0.bin", "run.json"]
    f.close()
    assert sorted(p.name for p in out.iterdir()) == ["manifest.jsonl", "r0.bin", "run.json"]


def test_a_second_folder_object_on_a_held_folder_is_refused(tmp_path):
    f = folder(tmp_path / "o")
    with pytest.raises(FolderBusy, match="another run is writing into this folder"):
        folder(tmp_path / "o")
    f.close()
    folder(tmp_path / "o").close()


def test_same_run_continues_other_run_is_refused_overwrite_starts_over(tmp_path):
    f = folder(tmp_path / "o")
    for i in range(2):
        add(f, i)
    f.close()
    again = folder(tmp_path / "o", run={"n": 10})  # n may grow: the same run, continued
    assert again.done == 2 and again.resumed == 2
    again.close()
    with pytest.raises(RunMismatch, match="seed=1"):
        folder(tmp_path / "o", run={"seed": 2})
    fresh = folder(tmp_path / "o", run={"seed": 2}, overwrite=True)
    assert fresh.done == 0 and (tmp_path / "o" / "r1.bin").exists()  # nothing deleted yet
    add(fresh, 0, b"new")
    assert not (tmp_path / "o" / "r1.bin").exists()
    assert [e["id"] for e in lines(tmp_path / "o")] == ["r0"]


def test_a_torn_last_line_and_a_vanished_file_end_the_list(tmp_path):
    f = folder(tmp_path / "o")
    for i in range(3):
        add(f, i)
    f.close()
    with open(tmp_path / "o" / MANIFEST, "a") as fh:
        fh.write('{"id": "r3", "ind')  # a crash mid-line
    g = folder(tmp_path / "o")
    assert g.done == 3
    g.close()
    (tmp_path / "o" / "r1.bin").unlink()
    g = folder(tmp_path / "o")
    assert g.done == 1
    add(g, 1)
    assert [e["id"] for e in lines(tmp_path / "o")] == ["r0", "r1"]
    assert not (tmp_path / "o" / "r2.bin").exists()  # listed after the gap: made again


def test_files_renamed_in_but_never_listed_are_removed_on_the_next_open(tmp_path):
    f = folder(tmp_path / "o")
    add(f, 0)
    f.close()
    # what SIGKILL between rename and manifest line leaves behind
    (tmp_path / "o" / "r1.bin").write_bytes(b"orphan")
    (tmp_path / "o" / PENDING).write_text(json.dumps(["r1.bin"]))
    (tmp_path / "o" / ".r2.bin.abcd.tmp").write_bytes(b"half")
    g = folder(tmp_path / "o")
    assert g.done == 1
    assert listing(tmp_path / "o") == ["manifest.jsonl", "r0.bin", "run.json"]


def test_a_failing_result_leaves_no_file_and_no_line(tmp_path, monkeypatch):
    f = folder(tmp_path / "o")
    add(f, 0)
    import grammarkit.run.writer as w

    real = w.write_files

    def fail_second(files):
        items = list(files.items())
        real(dict(items[:1]))
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(w, "write_files", fail_second)
    with pytest.raises(OSError):
        f.add({"id": "r1", "index": 1, "file": "r1.bin", "attachments": {"png": "r1.png"}},
              {"r1.bin": b"m", "r1.png": b"p"})
    monkeypatch.undo()
    assert listing(tmp_path / "o") == ["manifest.jsonl", "r0.bin", "run.json"]
    assert len(lines(tmp_path / "o")) == 1


def test_folder_paths_that_cannot_work_are_refused_up_front(tmp_path):
    plain = tmp_path / "plain"
    plain.write_text("keep")
    with pytest.raises(ShapeError, match="is a file"):
        folder(plain)
    with pytest.raises(ShapeError, match="looks like one model file"):
        folder(tmp_path / "castle.glb")
    with pytest.raises(ShapeError, match="is a file"):
        folder(plain / "sub")
    assert plain.read_text() == "keep"


def test_a_result_may_not_replace_an_input(tmp_path):
    grammar = tmp_path / "o" / "r0.bin"
    grammar.parent.mkdir()
    grammar.write_bytes(b"input")
    f = folder(tmp_path / "o", protected=(grammar,))
    with pytest.raises(ShapeError, match="overwrite the input"):
        add(f, 0)
    assert grammar.read_bytes() == b"input"


def test_check_outputs_refuses_inputs_and_shared_paths(tmp_path):
    src = tmp_path / "s.grammar"
    src.write_text("x")
    with pytest.raises(ShapeError, match="would overwrite the input"):
        check_outputs({"-o": src}, inputs=[src])
    link = tmp_path / "link.grammar"
    link.symlink_to(src)
    with pytest.raises(ShapeError, match="would overwrite the input"):
        check_outputs({"-o": link}, inputs=[src])
    with pytest.raises(ShapeError, match="name the same file"):
        check_outputs({"-o": tmp_path / "x.glb", "--tree": tmp_path / "x.glb"})
    check_outputs({"-o": tmp_path / "x.glb", "--tree": tmp_path / "x.json"}, inputs=[src])


def test_write_files_is_all_or_nothing(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "sub"
    a.write_text("old")
    b.mkdir()
    with pytest.raises(ShapeError):
        write_files({a: "new", b: "cannot: a folder"})
    assert a.read_text() == "old"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    write_files({a: "new", tmp_path / "deep" / "c.bin": b"c"})
    assert a.read_text() == "new" and (tmp_path / "deep" / "c.bin").read_bytes() == b"c"
    mode = os.stat(tmp_path / "deep" / "c.bin").st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask
