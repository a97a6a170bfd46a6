"""The shared atomic writer: all-or-nothing, located errors, sensible permissions."""
from __future__ import annotations

import os
import stat

import pytest

from grammarkit.errors import ShapeError
from grammarkit.fileio import atomic_output


def test_replacing_a_file_keeps_its_permissions(tmp_path):
    path = tmp_path / "a.grammar"
    path.write_text("old")
    os.chmod(path, 0o640)
    with atomic_output(path) as tmp:
        tmp.write_text("new")
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o640


def test_a_failure_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "a.grammar"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_output(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.grammar"]


def test_a_missing_folder_is_an_error_naming_the_path(tmp_path):
    with pytest.raises(ShapeError, match="does not exist"):
        with atomic_output(tmp_path / "nope" / "a.glb"):
            pass


def test_fmt_in_place_keeps_permissions(tmp_path):
    from click.testing import CliRunner

    from grammarkit.cli import main

    path = tmp_path / "g.grammar"
    path.write_text("Lot-->extrude(3)   Mass.\n")
    os.chmod(path, 0o600)
    result = CliRunner().invoke(main, ["fmt", "--in-place", str(path)])
    assert result.exit_code == 0, result.output
    assert path.read_text() == "Lot --> extrude(3) Mass.\n" and stat.S_IMODE(path.stat().st_mode) == 0o600


def test_writing_through_a_symlink_keeps_the_link(tmp_path):
    from grammarkit.fileio import atomic_output

    real = tmp_path / "real.grammar"
    real.write_text("old")
    link = tmp_path / "link.grammar"
    link.symlink_to(real)
    with atomic_output(link) as tmp:
        tmp.write_text("new")
    assert link.is_symlink() and real.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.grammar", "real.grammar"]


def test_render_refuses_to_replace_its_model(tmp_path):
    from click.testing import CliRunner

    from grammarkit.cli import main

    model = tmp_path / "m.png"
    model.write_bytes(b"not really a model")
    r = CliRunner().invoke(main, ["render", str(model), "-o", str(model)])
    assert r.exit_code != 0 and "overwrite the input" in r.output
    assert model.read_bytes() == b"not really a model"
