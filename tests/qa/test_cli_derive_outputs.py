"""`grammarkit derive`: bad output paths and options end with a clear message and a non-zero
status, never a traceback, and never touch an existing output file."""
from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

UNWRITABLE = Path("/proc/grammarkit-qa")  # a folder nobody (not even root) can create files in


def _no_traceback(code: int, out: str) -> None:
    assert code not in (0, 99), out
    assert "Traceback" not in out and "TRACEBACK" not in out, out


def test_output_is_a_folder(cli, small_grammar, tmp_path):
    code, out = cli("derive", small_grammar, "-o", tmp_path, "--format", "glb")
    _no_traceback(code, out)
    assert "folder" in out


@pytest.mark.parametrize("option", ["--preview", "--tree"])
def test_preview_or_tree_that_is_a_folder_fails_before_writing_the_model(cli, small_grammar, tmp_path, option):
    model = tmp_path / "m.glb"
    model.write_bytes(b"old")
    folder = tmp_path / "sub"
    folder.mkdir()
    code, out = cli("derive", small_grammar, "-o", model, option, folder)
    _no_traceback(code, out)
    assert model.read_bytes() == b"old"


def test_preview_with_an_unknown_image_suffix(cli, small_grammar, tmp_path):
    model = tmp_path / "m.glb"
    model.write_bytes(b"old")
    code, out = cli("derive", small_grammar, "-o", model, "--preview", tmp_path / "p.txt")
    _no_traceback(code, out)
    assert "p.txt" in out and model.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.glb", "small.grammar"]


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc as an unwritable folder")
@pytest.mark.parametrize("which", ["-o", "--preview", "--tree"])
def test_unwritable_output_is_an_error_and_keeps_the_other_files(cli, small_grammar, tmp_path, which):
    model = tmp_path / "m.glb"
    model.write_bytes(b"old")
    args = {"-o": model, "--preview": None, "--tree": None}
    target = {"-o": UNWRITABLE / "m.glb", "--preview": Path("/proc/x.png"), "--tree": Path("/proc/t.json")}[which]
    args[which] = target
    argv = ["derive", small_grammar]
    for k, v in args.items():
        if v is not None:
            argv += [k, v]
    code, out = cli(*argv)
    _no_traceback(code, out)
    assert str(target.parent) in out
    assert model.read_bytes() == b"old"  # all files of one run are committed together


def test_written_files_have_normal_permissions(cli, small_grammar, tmp_path):
    code, out = cli("derive", small_grammar, "-o", tmp_path / "m.glb", "--tree", tmp_path / "t.json",
                    "--preview", tmp_path / "p.png")
    assert code == 0, out
    mask = os.umask(0)
    os.umask(mask)
    for name in ("m.glb", "t.json", "p.png"):
        mode = stat.S_IMODE((tmp_path / name).stat().st_mode)
        assert mode == 0o666 & ~mask, (name, oct(mode))


def test_variations_with_a_bad_set_creates_no_folder(cli, small_grammar, tmp_path):
    out_dir = tmp_path / "vars"
    code, out = cli("derive", small_grammar, "-o", out_dir, "--variations", "2", "--set", "nope=1")
    _no_traceback(code, out)
    assert "nope" in out and not out_dir.exists()


def test_variations_into_an_existing_file(cli, small_grammar, tmp_path):
    f = tmp_path / "plainfile"
    f.write_text("keep")
    code, out = cli("derive", small_grammar, "-o", f, "--variations", "2")
    _no_traceback(code, out)
    assert f.read_text() == "keep"


@pytest.mark.parametrize("argv", [["--variations", "1000000000"], ["-n", "1000000000"], ["--workers", "100000"]])
def test_huge_counts_are_refused_up_front(cli, small_grammar, tmp_path, argv):
    code, out = cli("derive", small_grammar, "-o", tmp_path / "vars", *argv)
    _no_traceback(code, out)
    assert not (tmp_path / "vars").exists()


@pytest.mark.parametrize("value,words", [("h=100", "outside its range"), ("h=abc", "is a number"),
                                         ("h=nan", "finite"), ("h=1e999", "finite"),
                                         ("style=round", "not one of"), ("win=maybe", "boolean"),
                                         ("nope=1", "has no attr 'nope'")])
def test_set_errors_point_at_the_attr(cli, small_grammar, tmp_path, value, words):
    code, out = cli("derive", small_grammar, "-o", tmp_path / "m.glb", "--set", value)
    _no_traceback(code, out)
    assert words in out
    if not value.startswith("nope"):
        assert "small.grammar:" in out  # file:line:col of the attr's declaration
    assert not (tmp_path / "m.glb").exists()


CASTLE = Path(__file__).resolve().parents[2] / "grammars" / "tiling" / "castle" / "castle.grammar"


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc as an unwritable folder")
def test_back_end_output_folder_that_cannot_be_made(cli):
    code, out = cli("derive", CASTLE, "-o", UNWRITABLE / "out", "-n", "1", "--iterations", "1")
    _no_traceback(code, out)
    assert str(UNWRITABLE) in out and "cannot create folder" in out


def test_back_end_output_that_is_a_file(cli, tmp_path):
    f = tmp_path / "plain"
    f.write_text("keep")
    code, out = cli("derive", CASTLE, "-o", f, "-n", "1", "--iterations", "1")
    _no_traceback(code, out)
    assert f.read_text() == "keep"


def test_a_crashing_back_end_is_reported_without_traceback(cli, tmp_path):
    from grammarkit import hookimpl
    from grammarkit.plugins import get_plugin_manager
    from grammarkit.run import BackendSpec

    def boom(request):
        raise RuntimeError("kaput")
        yield  # pragma: no cover - a generator that fails on its first step

    class Plugin:
        @staticmethod
        @hookimpl
        def grammarkit_backends():
            return [BackendSpec(name="qa-crash", summary="crashes", families=frozenset({"tiling", "split"}),
                                run=boom)]

    pm = get_plugin_manager()
    pm.register(Plugin, name="qa-crash-plugin")
    try:
        code, out = cli("derive", CASTLE, "-o", tmp_path / "o", "--backend", "qa-crash")
    finally:
        pm.unregister("qa-crash-plugin")
    _no_traceback(code, out)
    assert "qa-crash" in out and "kaput" in out
    assert not (tmp_path / "o").exists()