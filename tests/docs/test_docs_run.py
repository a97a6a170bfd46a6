"""Every shell and Python code block in README.md and docs/*.md runs, or is marked
`<!-- illustrative -->` on the line before its fence.

Blocks run in a fresh temporary folder in which `grammars/` (and `docs/`) point to the repo's,
so paths in the docs are written from the repo root and outputs land in the temporary folder.
Shell blocks run with `bash -e -o pipefail` and this interpreter's environment first on PATH
(`grammarkit`, `python`); Python blocks with this interpreter, saved as a script first (as a
reader saves them: worker processes then re-import it, so an unguarded parallel example fails
here as it would for them). A block marked `<!-- output -->` shows what the runnable block
above it prints: its lines must appear in that output, in order (durations may differ). The README's two marked commands
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
from _blocks import ILLUSTRATIVE, OUTPUT, ROOT, all_blocks, missing_lines, outputs_of  # noqa: E402

EVERY = all_blocks()
RUNNABLE = [b for b in EVERY if b.kind in ("shell", "python")]
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
        script = cwd / "docs_block.py"
        script.write_text(code, encoding="utf-8")
        proc = _run([sys.executable, str(script)], cwd)
    assert proc.returncode == 0, (f"{block.where}: the {block.kind} block failed (exit {proc.returncode}); "
                                  f"mark it {ILLUSTRATIVE} if it is not meant to run\n--- block\n{code}"
                                  f"--- stdout\n{proc.stdout[-3000:]}\n--- stderr\n{proc.stderr[-3000:]}")
    for shown in outputs_of(block, EVERY):
        missing = missing_lines(shown.code, proc.stdout + "\n" + proc.stderr)
        assert not missing, (f"{shown.where}: the output shown is not what {block.where} prints "
                             f"(now); lines not printed:\n" + "\n".join(missing)
                             + f"\n--- printed\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")


def test_every_shown_output_has_a_block_that_prints_it():
    runs = [b for b in RUNNABLE if b.marker != ILLUSTRATIVE]
    for shown in (b for b in EVERY if b.marker == OUTPUT):
        assert any(shown in outputs_of(b, EVERY) for b in runs), \
            f"{shown.where}: marked {OUTPUT} but no runnable block above it in its file"


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


def test_the_output_check_sees_a_stale_number_and_ignores_durations():
    shown = "wrote out/a.glb (1102 triangles): solved in 0.182 s\n"
    assert missing_lines(shown, "reading\nwrote out/a.glb (1102 triangles): solved in 0.5 s\n") == []
    assert missing_lines(shown, "wrote out/a.glb (1101 triangles): solved in 0.182 s\n") == [shown.strip()]
    assert missing_lines("b\na\n", "a\nb\n") == ["a"]  # in order
    assert missing_lines("a ... c\n", "a b c\n") == []
