"""`grammarkit batch` as a user runs it: killed on a real 2-process Dask LocalCluster and resumed
to the same bytes as an uninterrupted local run; a full disk or an unwritable folder stops the
batch cleanly; failures and --fail-fast; clear errors for bad options and dead schedulers."""
from __future__ import annotations

import json
import resource
import signal
import socket
import subprocess
import sys
import time

import pytest

from _batch_helpers import (BLOCK, CLI, TINY, feature, grid_lots, item_files, listed, rect, run_cli,
                            without_timing, write_lots)


def consistent(out) -> None:
    """Every listed file exists; files on disk that are not listed are only the ones a kill
    between rename and manifest line left, recorded in .pending.json (removed by the next run)."""
    entries = listed(out)
    names = {n for e in entries for n in [e.get("file"), *(e.get("attachments") or {}).values()] if n}
    on_disk = set(item_files(out))
    assert names <= on_disk, names - on_disk
    assert not (on_disk - names) or (out / ".pending.json").exists(), on_disk - names


@pytest.fixture(scope="module")
def lots24(tmp_path_factory):
    return grid_lots(tmp_path_factory.mktemp("lots") / "lots.geojson", 24)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory, lots24):
    out = tmp_path_factory.mktemp("whole") / "city"
    p = run_cli("batch", BLOCK, "--lots", lots24, "-o", out, "--seed", "3", "--render", "sketch",
                "--render-size", "48", "--executor", "local", "--workers", "1")
    assert p.returncode == 0, p.stderr
    return out


def test_a_batch_killed_on_a_dask_cluster_resumes_to_the_same_bytes(tmp_path, lots24, uninterrupted,
                                                                   dask_executor):
    """Killed with the LocalCluster of its own `--executor dask`; resumed on a running cluster
    through its address (the session's: one cluster start fewer), to the same bytes."""
    out = tmp_path / "city"
    common = ["batch", BLOCK, "--lots", lots24, "-o", out, "--seed", "3", "--render", "sketch",
              "--render-size", "48"]
    args = [*common, "--executor", "dask", "--workers", "2"]
    proc = subprocess.Popen([*CLI, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.time() + 300
    while time.time() < deadline and proc.poll() is None and len(listed(out)) < 3:
        time.sleep(0.02)
    killed_at = len(listed(out))
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert 3 <= killed_at < 24, f"the kill should land mid-run (manifest had {killed_at} lines)"
    consistent(out)
    # the cluster's worker processes end with their parent
    time.sleep(1)
    address = dask_executor.client.scheduler.address.replace("tcp://", "dask://")
    again = run_cli(*common, "--executor", address, "--json")
    assert again.returncode == 0, again.stderr
    summary = json.loads(again.stdout)
    assert summary["executor"] == "dask" and summary["resumed"] >= 3
    assert summary["resumed"] + summary["written"] == 24
    assert "continued an earlier run" in again.stderr
    assert not (out / ".pending.json").exists()
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    assert without_timing(listed(out)) == without_timing(listed(uninterrupted))
    mine, theirs = item_files(out), item_files(uninterrupted)
    assert mine.keys() == theirs.keys() and len(mine) == 48
    assert all(mine[k] == theirs[k] for k in theirs)


def test_sigterm_stops_cleanly_and_the_same_command_continues(tmp_path, lots24, uninterrupted):
    out = tmp_path / "city"
    args = ["batch", BLOCK, "--lots", lots24, "-o", out, "--seed", "3", "--render", "sketch",
            "--render-size", "48", "--workers", "1"]
    proc = subprocess.Popen([*CLI, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    while proc.poll() is None and len(listed(out)) < 2:
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    code = proc.wait(timeout=120)
    err = proc.stderr.read()
    assert "Traceback" not in err
    if code != 0:
        assert code == 130 and "run the same command again to continue" in err
    consistent(out)
    assert run_cli(*args).returncode == 0
    assert item_files(out) == item_files(uninterrupted)


def _limit_file_size(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_a_full_disk_stops_the_batch_with_the_manifest_consistent(tmp_path):
    """RLIMIT_FSIZE makes every write past a size fail (EFBIG), as a full disk does. The limit is
    above every model file and below the whole manifest, so the manifest's append fails."""
    lots = grid_lots(tmp_path / "lots.geojson", 12)
    whole = tmp_path / "whole"
    assert run_cli("batch", TINY, "--lots", lots, "-o", whole, "--workers", "1").returncode == 0
    limit = max(len(b) for b in item_files(whole).values()) + 200
    assert (whole / "manifest.jsonl").stat().st_size > limit + 1000
    out = tmp_path / "city"
    args = ["batch", TINY, "--lots", lots, "-o", out, "--workers", "1"]
    p = subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, timeout=300,
                       preexec_fn=_limit_file_size(limit))
    assert p.returncode == 1, p.stderr
    assert "Traceback" not in p.stderr
    assert "cannot write" in p.stderr and "File too large" in p.stderr and "the batch stopped" in p.stderr
    assert "run the same command again to continue" in p.stderr
    done = len(listed(out))
    assert 0 < done < 12
    assert (out / "manifest.jsonl").read_text().endswith("\n")  # no torn line
    consistent(out)
    # space again: the same command finishes the batch, with the files of an uninterrupted run
    again = run_cli(*args)
    assert again.returncode == 0, again.stderr
    assert item_files(out) == item_files(whole)
    assert without_timing(listed(out)) == without_timing(listed(whole))


def test_an_unwritable_output_folder_is_a_clear_error(tmp_path):
    lots = grid_lots(tmp_path / "lots.geojson", 2)
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    p = run_cli("batch", TINY, "--lots", lots, "-o", blocker / "city", "--workers", "1")
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert "cannot create folder" in p.stderr and "is a file" in p.stderr
    # a folder that cannot be created when the first item is written (as root, /proc refuses)
    p = run_cli("batch", TINY, "--lots", lots, "-o", "/proc/grammarkit-batch-test", "--workers", "1")
    assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr
    assert "/proc/grammarkit-batch-test" in p.stderr and "cannot" in p.stderr


def test_failures_are_listed_and_fail_fast_stops(tmp_path):
    lots = write_lots(tmp_path / "lots.geojson", [
        feature(rect(0, 0, 10, 10), "ok-1"), feature([(20, 0), (30, 10), (30, 0), (20, 10)], "bowtie"),
        feature(rect(40, 0, 10, 10), "ok-2")])
    out = tmp_path / "city"
    p = run_cli("batch", TINY, "--lots", lots, "-o", out, "--workers", "1", "--fail-fast")
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert "lot 'bowtie' (feature 1): is self-intersecting" in p.stderr and "--fail-fast" in p.stderr
    assert [e["id"] for e in listed(out)] == ["ok-1"]
    p = run_cli("batch", TINY, "--lots", lots, "-o", out, "--workers", "1", "--json")
    assert p.returncode == 1
    summary = json.loads(p.stdout)
    assert (summary["ok"], summary["failed"], summary["resumed"]) == (2, 1, 1)
    assert "1 of 3 items failed" in p.stderr and "bowtie: lot 'bowtie'" in p.stderr
    assert [e["status"] for e in listed(out)] == ["ok", "failed", "ok"]


@pytest.mark.parametrize("args,words", [
    ([], "give either --lots FILE"),
    (["--variations", "2", "--lots", "LOTS"], "give either --lots FILE"),
    (["--lots", "LOTS", "--attrs", "sample"], "--attrs sample applies to --variations"),
    (["--variations", "2", "--executor", "ray"], "unknown executor 'ray'"),
    (["--variations", "2", "--render", "oil"], "unknown render style 'oil'"),
    (["--variations", "2", "--set", "h=99"], "tiny.grammar:4:1: error: attr 'h' = 99 is outside"),
])
def test_bad_options_are_clear_errors(tmp_path, args, words):
    lots = grid_lots(tmp_path / "lots.geojson", 1)
    args = [str(lots) if a == "LOTS" else a for a in args]
    p = run_cli("batch", TINY, *args, "-o", tmp_path / "out")
    assert p.returncode != 0 and "Traceback" not in p.stderr
    assert words in p.stderr, p.stderr


def test_a_scheduler_that_does_not_answer_is_an_error_within_the_timeout(tmp_path):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    t0 = time.monotonic()
    p = run_cli("batch", TINY, "--variations", "2", "-o", tmp_path / "out", "--executor",
                f"dask://127.0.0.1:{port}", "--connect-timeout", "2")
    # a hang guard, not a speed check: the connect timeout is 2 s, the rest is a Python start-up
    # that takes tens of seconds on a loaded 2-core machine (35 s seen at load 20)
    assert time.monotonic() - t0 < 120
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert f"tcp://127.0.0.1:{port}: cannot reach a Dask scheduler: no answer within 2 s" in p.stderr
    assert not (tmp_path / "out").exists()


def test_the_command_line_stays_light():
    code = ("import sys; from grammarkit.cli import main; "
            "print(sorted(m for m in ('distributed', 'dask', 'trimesh', 'pyarrow', 'shapefile') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
    help_text = run_cli("batch", "--help").stdout
    assert "--executor" in help_text and "--lots" in help_text and "--merge" in help_text
