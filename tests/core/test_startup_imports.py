"""Start-up stays light (issue 8): what each entry point imports, checked in fresh processes.
(Speed itself is measured by benchmarks/bench_startup.py, not asserted here.)"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("pydantic", "lark", "pluggy", "numpy", "manifold3d", "trimesh", "scipy", "networkx", "rich")


def loaded(code: str) -> set[str]:
    probe = f"{code}\nimport sys\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    return set(r.stdout.splitlines()[-1].split()) if r.stdout.strip() else set()


def test_the_command_line_and_version_import_nothing_heavy():
    assert loaded("import grammarkit, grammarkit.cli") == set()
    code = ("import sys\nfrom grammarkit.cli import main\ntry:\n    main(['--version'])\n"
            "except SystemExit:\n    print()")
    assert loaded(code) == set()


def test_check_needs_no_geometry():
    assert loaded("import grammarkit\ngrammarkit.check('grammars/paris.grammar')") == {"pydantic", "lark", "pluggy"}


def test_plugins_entry_points_of_the_split_engine_stay_light():
    # the language (IR, parser, plugin hooks) but no geometry: numpy, manifold3d, trimesh...
    assert loaded("import grammarkit.split.operations, grammarkit.split") <= {"pydantic", "lark", "pluggy"}
