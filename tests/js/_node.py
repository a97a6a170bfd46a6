"""Finding node and the npm packages in tests/js/node_modules (installed by `npm ci` in
tests/js, which .ci/run does). Tests that need them skip with a visible reason on a developer
machine that lacks them, and FAIL under CI (environment variable CI set), so CI never passes
by skipping them."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

JS_DIR = Path(__file__).resolve().parent
ROOT = JS_DIR.parents[1]


def missing(what: str) -> None:
    """Skip (locally) or fail (CI) because `what` is not installed."""
    msg = f"{what} is not installed; run `cd tests/js && npm ci` (and apt-get install nodejs chromium)"
    if os.environ.get("CI"):
        pytest.fail(f"CI must run this test: {msg}")
    pytest.skip(msg)


def node_or_skip() -> str:
    node = shutil.which("node")
    if node is None:
        missing("node (Node.js 20)")
    return node


def package_or_skip(name: str) -> Path:
    path = JS_DIR / "node_modules" / name
    if not (path / "package.json").is_file():
        missing(f"the npm package {name!r}")
    return path


def validate_gltf(files: list[Path]) -> dict[str, dict]:
    """Khronos' glTF validator (tests/js/validate.mjs) on `files`: its report per file name."""
    node = node_or_skip()
    package_or_skip("gltf-validator")
    proc = subprocess.run([node, str(JS_DIR / "validate.mjs"), *map(str, files)], capture_output=True,
                          text=True, timeout=300, cwd=JS_DIR)
    assert proc.returncode == 0, proc.stderr
    reports = [json.loads(line) for line in proc.stdout.splitlines() if line.strip()]
    return {r["file"]: r for r in reports}
