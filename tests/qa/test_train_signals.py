"""Issue 31: SIGINT or SIGTERM during `grammarkit train` stops it cleanly: exit status 130, an
`interrupted` message and no traceback, no model file written or half-written (a model already
at `-o` keeps its bytes), no temporary file left beside it and no worker process left behind.
Real processes through the CLI; the signal is sent at a known point of the run (an epoch
reported, the rendering workers started), never after a fixed delay."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
LIBRARY = ROOT / "grammars" / "library.grammar"
CLI = [sys.executable, "-m", "grammarkit"]
OLD_MODEL = b"an earlier model that an interrupted run must not touch\n"


class Running:
    """A CLI process whose stderr is collected line by line while it runs."""

    def __init__(self, *args: str) -> None:
        self.process = subprocess.Popen([*CLI, *map(str, args)], stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stderr:
            self.lines.append(line)

    def wait_for(self, found, what: str, timeout: float = 600) -> None:
        """Wait until `found()` is true (bounded generously: load may slow the run, never stop it)."""
        end = time.monotonic() + timeout
        while not found():
            if self.process.poll() is not None:
                pytest.fail(f"the run ended before {what}: {''.join(self.lines)[-2000:]}")
            if time.monotonic() > end:
                self.process.kill()
                pytest.fail(f"no {what} within {timeout:g} s")
            time.sleep(0.05)

    def stop(self, sig: int) -> tuple[int, str]:
        self.process.send_signal(sig)
        try:
            code = self.process.wait(timeout=120)
        except subprocess.TimeoutExpired:
            self.process.kill()
            pytest.fail(f"still running 120 s after {signal.Signals(sig).name}")
        self._reader.join(timeout=30)
        return code, "".join(self.lines)


def children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(x) for x in text.split()]


def assert_stopped_cleanly(code: int, err: str, model: Path) -> None:
    assert code == 130, err
    assert "interrupted" in err, err
    assert model.read_bytes() == OLD_MODEL  # the earlier model is intact, nothing half-written
    assert sorted(p.name for p in model.parent.iterdir()) == [model.name]  # no temporary file
    # no traceback, also when the stop landed inside a worker's `Process.start()` (the
    # executor holds it until the start is complete: the child's start-up data arrives whole)
    assert "Traceback" not in err and "EOFError" not in err, err


def make_castle_dataset(folder: Path) -> Path:
    """A small string-VAE dataset of castle rings in `folder`, made in code (the sampler would
    take a minute); also used by benchmarks/bench_hardening.py."""
    from grammarkit_string_vae.dataset import make_dataset, write_dataset
    from grammarkit_string_vae.graphs import TypedGraph
    from grammarkit_string_vae.strings import Alphabet
    from grammarkit_string_vae.topology import TopologyRules

    from grammarkit.dsl import load
    from grammarkit.run import grammar_hash

    grammar = load(CASTLE)
    rules = TopologyRules.from_grammar(grammar)
    graphs = []
    for towers in range(2, 12):  # a ring of towers, two walls between neighbours
        types = ["Tower"] * towers + ["Wall"] * (2 * towers)
        edges = []
        for i in range(towers):
            w1, w2 = towers + 2 * i, towers + 2 * i + 1
            edges += [(i, w1), (w1, w2), (w2, (i + 1) % towers)]
        graphs.append(TypedGraph.make(types, edges))
    assert all(rules.is_valid(g) for g in graphs)
    ds = make_dataset(graphs, rules, Alphabet.for_types(rules.types), strings_per_graph=4, seed=0,
                      meta={"grammar": grammar.name, "grammar_hash": grammar_hash(grammar),
                            "grammar_file": str(CASTLE), "source": "test"})
    write_dataset(ds, folder)
    return folder


@pytest.fixture(scope="module")
def castle_dataset(tmp_path_factory):
    pytest.importorskip("torch")
    pytest.importorskip("grammarkit_string_vae")
    return make_castle_dataset(tmp_path_factory.mktemp("ds") / "castle_ds")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_string_vae_training_stops_cleanly_mid_run(tmp_path, castle_dataset, sig):
    model = tmp_path / "models" / "castle.vae"
    model.parent.mkdir()
    model.write_bytes(OLD_MODEL)
    run = Running("train", "string-vae", castle_dataset, "-o", model, "--epochs", "100000",
                  "--hidden", "8", "--latent", "2", "--batch-size", "8")
    run.wait_for(lambda: any(line.startswith("epoch 2/") for line in run.lines), "second epoch")
    code, err = run.stop(sig)
    assert_stopped_cleanly(code, err, model)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_sketch_training_stops_cleanly_with_its_workers(tmp_path, sig):
    pytest.importorskip("torch")
    pytest.importorskip("grammarkit_sketch")
    model = tmp_path / "models" / "windows.models"
    model.parent.mkdir()
    model.write_bytes(OLD_MODEL)
    run = Running("train", "sketch", "--library", LIBRARY, "-o", model, "--types", "Window",
                  "--samples", "400", "--classifier-epochs", "2", "--regressor-epochs", "1",
                  "--no-cache", "--workers", "2")
    pid = run.process.pid
    run.wait_for(lambda: len(children(pid)) >= 2, "rendering workers")
    workers = children(pid)
    code, err = run.stop(sig)
    for worker in workers:  # the workers end with the command (none is left rendering)
        end = time.monotonic() + 60
        while Path(f"/proc/{worker}").exists() and time.monotonic() < end:
            if Path(f"/proc/{worker}/stat").read_text().split(")")[-1].split()[0] == "Z":
                break  # a zombie: ended, waiting for its (already gone) parent's reaper
            time.sleep(0.05)
        alive = Path(f"/proc/{worker}").exists() and \
            Path(f"/proc/{worker}/stat").read_text().split(")")[-1].split()[0] != "Z"
        assert not alive, f"worker {worker} still running after the command ended"
    assert_stopped_cleanly(code, err, model)


def test_train_string_vae_refuses_a_device_as_model_before_training(tmp_path, castle_dataset):
    link = tmp_path / "null.vae"
    link.symlink_to(os.devnull)
    # in this process (torch is imported here already, by the dataset fixture): the command's
    # own error path, without a second interpreter start and torch import
    from click.testing import CliRunner

    from grammarkit.cli import main

    done = CliRunner().invoke(main, ["train", "string-vae", str(castle_dataset), "-o", str(link),
                                     "--epochs", "1"])
    assert done.exit_code == 1 and isinstance(done.exception, SystemExit), done.output
    assert str(link) in done.output, done.output  # a clear error, not an uncaught exception
    assert link.is_symlink() and os.readlink(link) == os.devnull
    assert "epoch 1/" not in done.output  # refused before training, not once the model was made


def test_train_sketch_refuses_a_device_as_model_before_training(tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("grammarkit_sketch")
    link = tmp_path / "null.models"
    link.symlink_to(os.devnull)
    run = Running("train", "sketch", "--library", LIBRARY, "--types", "Window", "--samples", "20",
                  "--no-cache", "--workers", "2", "--classifier-epochs", "1", "-o", link)
    pid = run.process.pid
    end = time.monotonic() + 600
    while run.process.poll() is None and not children(pid) and time.monotonic() < end:
        time.sleep(0.05)
    if run.process.poll() is None:  # rendering workers started: training began before the check
        run.process.kill()
        run.process.wait()
        pytest.fail("train sketch started training before refusing a device as -o")
    run._reader.join(timeout=30)
    err = "".join(run.lines)
    assert run.process.returncode == 1 and str(link) in err and "Traceback" not in err, err
    assert link.is_symlink() and os.readlink(link) == os.devnull
