"""Every shell and Python code block in README.md and docs/*.md runs, or is marked
`<!-- illustrative -->` on the line before its fence.

Blocks run in a fresh temporary folder in which `grammars/` (and `docs/`) point to the repo's,
so paths in the docs are written from the repo root and outputs land in the temporary folder.
Shell blocks run with `bash -e -o pipefail` and this interpreter's environment first on PATH
(`grammarkit`, `python`); Python blocks with this interpreter. The README's two marked commands
are special: the main command runs without its leading `python -m pip install .` (the package
under test is installed already), and the test command is what .ci/run executes verbatim.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from _blocks import ILLUSTRATIVE, ROOT, all_blocks  # noqa: E402

RUNNABLE = [b for b in all_blocks() if b.kind in ("shell", "python")]
# A hang guard only, never a speed check: documented blocks are small (seconds on a quiet
# machine), but a loaded 2-core machine runs them 5-10x slower, and a fixed 120 s failed four of
# them there (issue 32). Speed is measured in benchmarks/, not here.
TIMEOUT = 1800
PIP_PREFIX = "python -m pip install . && "


def _workdir(tmp_path: Path) -> Path:
    for name in ("grammars", "docs"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    return tmp_path


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    env.pop("PYTHONPATH", None)
    return env


def _run(args: list[str], cwd: Path, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, input=stdin, capture_output=True, text=True, timeout=TIMEOUT,
                          env=_env())


def test_found_the_blocks():
    wheres = {b.where.split(":")[0] for b in RUNNABLE}
    assert {"README.md", "docs/derive.md", "docs/tiling.md"} <= wheres
    assert len(RUNNABLE) >= 10


@pytest.mark.parametrize("block", RUNNABLE, ids=lambda b: b.where)
def test_block_runs_or_is_marked_illustrative(block, tmp_path):
    if block.marker == ILLUSTRATIVE:
        return  # shown as an example only (e.g. a command synopsis with placeholders)
    code = block.code
    if block.marker == "<!-- test-command -->":
        run = (ROOT / ".ci" / "run").read_text()
        assert "<!-- test-command -->" in run and 'bash -c "$cmd"' in run  # CI runs it verbatim
        return
    if block.marker == "<!-- main-command -->":
        assert code.startswith(PIP_PREFIX), code
        code = code[len(PIP_PREFIX):]
    cwd = _workdir(tmp_path)
    if block.kind == "shell":
        proc = _run(["bash", "-e", "-o", "pipefail", "-c", code], cwd)
    else:
        proc = _run([sys.executable, "-"], cwd, stdin=code)
    assert proc.returncode == 0, (f"{block.where}: the {block.kind} block failed (exit {proc.returncode}); "
                                  f"mark it {ILLUSTRATIVE} if it is not meant to run\n--- block\n{code}"
                                  f"--- stdout\n{proc.stdout[-3000:]}\n--- stderr\n{proc.stderr[-3000:]}")


def test_no_machine_specific_paths():
    for f in {b.file for b in all_blocks()}:
        text = f.read_text(encoding="utf-8")
        for bad in ("/work/", "/home/", "/root/", "/Users/", "C:\\\\"):
            assert bad not in text, f"{f.relative_to(ROOT)} mentions the machine-specific path {bad!r}"


def test_readme_tower_shows_its_windows(tmp_path):
    """The README's "taste" grammar derives a tower whose windows are geometry with colour,
    not a plain box: glass and frames are distinct labelled, coloured surfaces."""
    import grammarkit

    (block,) = [b for b in all_blocks() if b.file.name == "README.md" and "grammar tower" in b.code]
    assert not [d for d in grammarkit.check(block.code) if d.severity == "error"]
    model = grammarkit.derive(block.code)
    labels = set(model.face_labels())
    assert {"Glass", "Frame"} <= labels, labels
    colours = {t.name: t.color for t in model.tags}
    assert colours["Glass"] and colours["Frame"] and colours["Glass"] != colours["Frame"]
    box = 4 * 2 + 4  # a plain box with a hip roof has a handful of triangles; windows add many
    assert model.triangle_count > 50 * box
