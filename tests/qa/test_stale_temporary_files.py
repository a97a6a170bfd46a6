"""A writer killed with SIGKILL leaves its hidden temporary file behind; the next write of the
same path removes it, but never the temporary file of a writer that is still running (it
holds a lock on it)."""
from __future__ import annotations

import subprocess
import sys

from grammarkit.fileio import atomic_output


def test_next_write_removes_a_killed_writers_temporary_file(tmp_path):
    stale = tmp_path / ".out.glb.k1ll3d.tmp"
    stale.write_bytes(b"half a model")
    live = tmp_path / ".out.glb.l1ve.tmp"
    live.write_bytes(b"being written")
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, os, sys, time\n"
         f"fd = os.open({str(live)!r}, os.O_RDONLY); fcntl.flock(fd, fcntl.LOCK_EX)\n"
         "print('locked', flush=True); time.sleep(60)"], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with atomic_output(tmp_path / "out.glb") as tmp:
            tmp.write_bytes(b"model")
    finally:
        holder.kill()
        holder.wait()
    assert (tmp_path / "out.glb").read_bytes() == b"model"
    assert not stale.exists() and live.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.glb.l1ve.tmp", "out.glb"]


def test_a_failed_write_leaves_no_temporary_file(tmp_path):
    try:
        with atomic_output(tmp_path / "x.txt") as tmp:
            tmp.write_text("partial")
            raise RuntimeError("crash")
    except RuntimeError:
        pass
    assert list(tmp_path.iterdir()) == []
