"""Crash safety of folder runs: a run killed at any moment (SIGKILL, SIGTERM, Ctrl-C) leaves a
manifest that lists exactly the model files on disk, and the same command run again finishes
the run with the same files as an uninterrupted run."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PARIS = ROOT / "grammars" / "paris.grammar"
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
CLI = [sys.executable, "-m", "grammarkit"]


def derive(out: Path, *args: str) -> subprocess.Popen:
    return subprocess.Popen([*CLI, "derive", *map(str, args), "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def listed(out: Path) -> list[dict]:
    path = out / "manifest.jsonl"
    return [json.loads(x) for x in path.read_text().splitlines()] if path.exists() else []


def models_on_disk(out: Path) -> set[str]:
    return {p.name for p in out.glob("*.glb")}


def consistent(out: Path) -> None:
    names = {e["file"] for e in listed(out)}
    on_disk = models_on_disk(out)
    pending = (out / ".pending.json").exists()
    # a SIGKILL between a rename and its manifest line may leave one unlisted file, recorded
    # in .pending.json; the next run removes it (checked after the re-run below)
    extra = on_disk - names
    assert not extra or pending, (extra, names)
    assert names <= on_disk


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole") / "out"
    p = derive(out, PARIS, "--variations", "12", "--seed", "4", "--workers", "2")
    assert p.wait(timeout=600) == 0, p.stderr.read()
    return out


@pytest.mark.parametrize("sig,delay", [(signal.SIGKILL, 2.5), (signal.SIGKILL, 4.0),
                                       (signal.SIGTERM, 3.0), (signal.SIGINT, 3.0)])
def test_killed_run_is_consistent_and_resumes_to_the_same_files(uninterrupted, tmp_path, sig, delay):
    out = tmp_path / "out"
    p = derive(out, PARIS, "--variations", "12", "--seed", "4", "--workers", "2")
    deadline = time.time() + delay
    while time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    if sig != signal.SIGKILL:
        # Ctrl-C and SIGTERM are handled once the run has begun (before that, during start-up
        # imports, they end the process the usual way, with nothing written): wait for it
        while p.poll() is None and not listed(out):
            time.sleep(0.05)
    if p.poll() is None:
        p.send_signal(sig)
    code = p.wait(timeout=60)
    err = p.stderr.read()
    assert "Traceback" not in err, err
    if sig in (signal.SIGTERM, signal.SIGINT) and code == -sig:
        # the signal came after the run had finished and restored the default handler (a
        # loaded machine can get there between our check and the kill): everything is written
        assert len(listed(out)) == len(listed(uninterrupted))
    elif sig in (signal.SIGTERM, signal.SIGINT) and code != 0:
        assert code == 130 and "run the same command again" in err
    if out.exists():
        consistent(out)
    again = derive(out, PARIS, "--variations", "12", "--seed", "4", "--workers", "2")
    assert again.wait(timeout=600) == 0, again.stderr.read()
    assert not (out / ".pending.json").exists()
    assert not [q for q in out.iterdir() if q.name.endswith(".tmp")]
    def strip(es):
        return [{k: v for k, v in e.items() if k != "metrics"} for e in es]
    assert strip(listed(out)) == strip(listed(uninterrupted))
    assert models_on_disk(out) == models_on_disk(uninterrupted)
    for name in models_on_disk(uninterrupted):
        assert (out / name).read_bytes() == (uninterrupted / name).read_bytes()


# The child runs the real CLI with one change: it kills itself (SIGKILL, nothing unwinds) at a
# known item, right after that result's files are renamed into place and before its manifest
# line: the worst moment a kill can land, reached without timing (a loaded machine cannot move
# it, and a small run suffices).
KILL_AT_ITEM = """
import os, signal, sys
import grammarkit.run.writer as writer
real, calls, at = writer.write_files, [0], int(sys.argv.pop(1))
def write_files(files):
    real(files)
    calls[0] += any(str(path).endswith(".glb") for path in files)  # results, not run.json
    if calls[0] == at:
        os.kill(os.getpid(), signal.SIGKILL)
writer.write_files = write_files
from grammarkit.cli import main
sys.argv[0] = "grammarkit"
main()
"""
# small on purpose (issue 32: this test took 89 s quiet, 418 s loaded): a few results of one
# iteration with few attempts still go through every step of a folder run
# (counts=grammar: the examples' count range admits too few castles for so small a run)
SAMPLER_ARGS = ("-n", "6", "--iterations", "1", "--option", "counts=grammar", "--option", "min-attempts=64",
                "--option", "max-attempts=128", "--seed", "7", "--workers", "1")


def test_killed_sampler_run_resumes_cleanly(tmp_path, cli):
    # only the killed run is a process of its own (SIGKILL); the whole run, the resume and the
    # refused other run are the same command in this process (three interpreter start-ups and
    # sampler imports fewer: they were most of this test's time)
    whole = tmp_path / "whole"
    code, text = cli("derive", CASTLE, *SAMPLER_ARGS, "-o", whole)
    assert code == 0, text
    assert len(listed(whole)) == 6
    out = tmp_path / "out"
    killed = subprocess.run([sys.executable, "-c", KILL_AT_ITEM, "3", "derive", str(CASTLE),
                             *SAMPLER_ARGS, "-o", str(out)], check=False, capture_output=True,
                            text=True, timeout=600)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    assert len(listed(out)) == 2 and len(models_on_disk(out)) == 3  # the third is unlisted
    assert (out / ".pending.json").exists()
    consistent(out)
    code, text = cli("derive", CASTLE, *SAMPLER_ARGS, "-o", out)
    assert code == 0, text
    assert not (out / ".pending.json").exists()
    assert [e["id"] for e in listed(out)] == [e["id"] for e in listed(whole)]
    assert models_on_disk(out) == models_on_disk(whole)
    for name in models_on_disk(whole):
        assert (out / name).read_bytes() == (whole / name).read_bytes()
    code, text = cli("derive", CASTLE, *SAMPLER_ARGS[:-3], "8", "--workers", "1", "-o", out)
    assert code == 1
    assert "another run" in text
