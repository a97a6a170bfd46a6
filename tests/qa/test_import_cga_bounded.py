"""import-cga reads like `check` (issue 31): regular files only, bounded, with check's size limit,
so a device, a FIFO or a huge rule file is a clear error instead of a MemoryError or minutes."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

CLI = [sys.executable, "-m", "grammarkit"]


def _import(src, tmp_path, *extra):
    out = tmp_path / "out.grammar"
    p = subprocess.run([*CLI, "import-cga", str(src), "-o", str(out), *extra], capture_output=True,
                       text=True, timeout=600, cwd=tmp_path)
    return p, out


def test_a_device_is_refused_without_reading_it(tmp_path):
    p, out = _import("/dev/zero", tmp_path)
    assert p.returncode == 1 and "it is a device, not a regular file" in p.stderr
    assert "Traceback" not in p.stderr and not out.exists()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "rules.cga"
    os.mkfifo(fifo)
    p, out = _import(fifo, tmp_path)
    assert p.returncode == 1 and "named pipe" in p.stderr and not out.exists()


def test_a_rule_file_over_checks_limit_is_refused_at_its_first_line(tmp_path):
    from grammarkit.fileio import DEFAULT_MAX_BYTES

    big = tmp_path / "big.cga"
    rule = "R{0} --> extrude(1) R{1}\n"
    with big.open("w") as fh:
        i = 0
        while fh.tell() <= DEFAULT_MAX_BYTES:
            fh.write(rule.format(i, i + 1))
            i += 1
    p, out = _import(big, tmp_path)
    assert p.returncode == 1 and "too large" in p.stderr and f"{big}:1:1" in p.stderr
    assert not out.exists()
