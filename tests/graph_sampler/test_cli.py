"""`grammarkit derive` with the graph sampler, then the real `grammarkit validate` / `learn` on its output."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

GRAMMAR = Path(__file__).parent / "data" / "minicastle.grammar"
CLI = [sys.executable, "-m", "grammarkit"]


def cli(*args, cwd=None):
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, timeout=1800, cwd=cwd)  # a hang guard only


@pytest.fixture(scope="module")
def derived(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "variants"
    r = cli("derive", GRAMMAR, "-o", out, "-n", 6, "--iterations", 4, "--seed", 7, "--workers", 2, "--json",
            "--option", "attempts_per_shape=64", "--option", "min_attempts=256", "--option", "counts=grammar")
    assert r.returncode == 0, r.stderr
    return out, json.loads(r.stdout)


def test_derive_picks_the_graph_sampler_and_reports_growth(derived):
    out, summary = derived
    stats = summary["stats"]
    assert summary["backend"] == "graph-sampler" and stats["workers"] == 2
    assert summary["written"] == 6 and stats["dedupe"] == "isomorphism"  # the default
    assert [row["iteration"] for row in stats["growth"]][:2] == [0, 1]
    lines = (out / "manifest.jsonl").read_text().splitlines()
    assert len(lines) == 6 and len(list(out.glob("variant_*.glb"))) == 6


def test_grammarkit_validate_accepts_every_written_variant(derived):
    out, _ = derived
    files = sorted(out.glob("variant_*.glb"))
    r = cli("validate", GRAMMAR, *files, "--json")
    assert r.returncode == 0, r.stdout + r.stderr


def test_grammarkit_learn_reads_the_variants(derived, tmp_path):
    out, _ = derived
    files = sorted(out.glob("variant_*.glb"))[:2]
    r = cli("learn", *files, "-o", tmp_path / "learned.grammar", "--neighbors", "multisets")
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "learned.grammar").read_text()
    assert "neighbors Wall: {Tower, Tower}" in text


def test_same_seed_same_files_with_one_worker(derived, tmp_path):
    out, _ = derived
    r = cli("derive", GRAMMAR, "-o", tmp_path / "one", "-n", 6, "--iterations", 4, "--seed", 7,
            "--workers", 1, "--option", "attempts_per_shape=64", "--option", "min_attempts=256",
            "--option", "counts=grammar")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "one" / "manifest.jsonl").read_text() == (out / "manifest.jsonl").read_text()
    for f in sorted(out.glob("variant_*.glb")):
        assert (tmp_path / "one" / f.name).read_bytes() == f.read_bytes()


def test_bad_option_is_a_clear_error_not_a_traceback(tmp_path):
    r = cli("derive", GRAMMAR, "-o", tmp_path / "x", "--option", "tolerence=0.2")
    assert r.returncode == 1
    assert "graph-sampler has no option 'tolerence'" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "x").exists()
