"""Inserted assets are cached on disk as solids (grammarkit.split.assets): the same model from a
cold and a warm cache, no trimesh/scipy import with a warm one, broken or unusable caches
ignored. Each run is a fresh process (the solids are also cached per process)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CODE = """
import hashlib, json, sys
from grammarkit.split import derive
m = derive("grammars/paris.grammar", seed=3)
print(json.dumps({"vertices": hashlib.sha256(m.vertices.tobytes()).hexdigest(),
                  "faces": hashlib.sha256(m.faces.tobytes()).hexdigest(),
                  "trimesh": "trimesh" in sys.modules, "scipy": "scipy" in sys.modules}))
"""


def run(cache: Path) -> dict:
    env = dict(os.environ, GRAMMARKIT_CACHE_DIR=str(cache))
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, env=env,
                       cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_cold_and_warm_caches_give_the_same_model_and_warm_needs_no_trimesh(tmp_path):
    cold = run(tmp_path)
    files = sorted((tmp_path / "assets").glob("*.npz"))
    assert len(files) == 2  # paris inserts a chimney and a dormer
    warm = run(tmp_path)
    assert {k: cold[k] for k in ("vertices", "faces")} == {k: warm[k] for k in ("vertices", "faces")}
    assert cold["trimesh"] and not warm["trimesh"] and not warm["scipy"]
    for f in files:  # broken cache files are not trusted, and are rewritten
        f.write_bytes(b"garbage")
    again = run(tmp_path)
    assert again["vertices"] == cold["vertices"] and again["trimesh"]
    assert all(f.read_bytes() != b"garbage" for f in files)


def test_an_unusable_cache_folder_only_costs_time(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    ok = run(blocker / "cache")
    assert ok["vertices"] == run(tmp_path / "good")["vertices"]


def test_the_cache_key_follows_the_file_bytes(tmp_path):
    from grammarkit.split.assets import asset_cache_path

    assert asset_cache_path(b"a") != asset_cache_path(b"b")
    assert asset_cache_path(b"a") == asset_cache_path(b"a")
