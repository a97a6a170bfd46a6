"""Plugin loading stays light, and lazy packages still expose functions, not submodules."""
from __future__ import annotations

import subprocess
import sys


def _run(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_loading_every_plugin_does_not_import_trimesh_or_scipy():
    # Every `grammarkit` command loads all plugins; these two cost about a second to import.
    code = ("import sys; from grammarkit.plugins import get_plugin_manager; "
            "get_plugin_manager().plugins(); print('trimesh' in sys.modules, 'scipy' in sys.modules)")
    assert _run(code) == "False False"


def test_tiling_functions_survive_their_submodules_being_imported():
    code = ("import grammarkit.tiling as t, grammarkit.tiling.dock, grammarkit.tiling.learn, "
            "grammarkit.tiling.validate; print(all(callable(f) and not hasattr(f, '__path__') "
            "and type(f).__name__ == 'function' for f in (t.dock, t.learn, t.validate)))")
    assert _run(code) == "True"
