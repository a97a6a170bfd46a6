"""Same grammar, attrs and seed -> byte-identical files, also across processes with different
string-hash seeds (PYTHONHASHSEED), for every output format and the tree JSON."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SCRIPT = """
import sys
from pathlib import Path
from grammarkit.split import derive
from grammarkit.geometry.exporters import export
out = Path(sys.argv[1]); out.mkdir(parents=True, exist_ok=True)
m = derive(sys.argv[2], seed=5, attrs={"h": 11, "style": "hip"})
for fmt in ("glb", "obj", "stl", "ply"):
    export(m.to_scene(), out / f"m.{fmt}", fmt)
(out / "tree.json").write_text(m.tree_json(indent=1))
"""


def test_outputs_are_byte_identical_across_processes(tmp_path, small_grammar):
    runs = []
    for hashseed in ("1", "2"):
        out = tmp_path / f"run{hashseed}"
        env = dict(os.environ, PYTHONHASHSEED=hashseed)
        subprocess.run([sys.executable, "-c", SCRIPT, str(out), str(small_grammar)], check=True, env=env,
                       timeout=120)
        runs.append(out)
    names = sorted(p.name for p in runs[0].iterdir())
    assert names == ["m.glb", "m.obj", "m.ply", "m.stl", "tree.json"]
    for name in names:
        assert (runs[0] / name).read_bytes() == (runs[1] / name).read_bytes(), name
