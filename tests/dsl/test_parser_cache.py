"""The Lark parser tables are cached on disk (issue 8): written once, reused, a stale or broken
file is not trusted, and a missing or read-only cache folder just works. Each case runs in a
fresh process (the parser is built once per process)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

PARSE = ("import sys; from grammarkit.dsl import parse; from grammarkit.dsl.parser import parser_cache_path;"
         "g = parse('Lot --> extrude(1) X.'); print(g.rules[0].name);"
         "from importlib import resources;"
         "print(parser_cache_path(resources.files('grammarkit.dsl').joinpath('grammar.lark').read_text()))")


def run(cache: Path, code: str = PARSE) -> tuple[str, Path]:
    env = dict(os.environ, GRAMMARKIT_CACHE_DIR=str(cache))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr  # nothing is logged about the cache
    name, path = r.stdout.split()
    return name, Path(path)


def test_written_once_then_reused(tmp_path):
    name, path = run(tmp_path / "cache")
    assert name == "Lot" and path.is_file() and path.parent == tmp_path / "cache"
    stamp = path.stat().st_mtime_ns
    assert run(tmp_path / "cache")[0] == "Lot"
    assert path.stat().st_mtime_ns == stamp  # read, not rebuilt


def test_a_broken_cache_file_is_rebuilt(tmp_path):
    _, path = run(tmp_path)
    path.write_bytes(b"not a pickle at all")
    assert run(tmp_path)[0] == "Lot"
    assert path.read_bytes() != b"not a pickle at all"  # rewritten with good tables


def test_a_stale_cache_is_never_read(tmp_path):
    # a file with another grammar's hash inside, at this grammar's name (e.g. copied over):
    # Lark checks the hash it stores and builds the tables anew
    _, path = run(tmp_path)
    good = path.read_bytes()
    first_line, rest = good.split(b"\n", 1)
    path.write_bytes(b"0" * len(first_line) + b"\n" + rest)
    assert run(tmp_path)[0] == "Lot"
    assert path.read_bytes().split(b"\n", 1)[0] == first_line


def test_the_cache_name_depends_on_the_grammar_text_and_versions():
    from grammarkit.dsl.parser import parser_cache_path

    assert parser_cache_path("a") != parser_cache_path("b")
    assert parser_cache_path("a") == parser_cache_path("a")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root may write anywhere")
def test_read_only_cache_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert run(ro)[0] == "Lot"
    finally:
        ro.chmod(0o700)


def test_unusable_cache_folder(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder would be")
    assert run(blocker / "cache")[0] == "Lot"  # cannot create it: parse without a cache
