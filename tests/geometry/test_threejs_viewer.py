"""A derived GLB opened as a web user would: three.js' GLTFLoader (npm, tests/js) in headless
Chromium (Debian's `chromium`, driven by Playwright without a browser download). The Paris
building stands upright (Y is its tallest extent) and arrives as one mesh (a closed solid is
one primitive, issue 32) in the grammar's most used material, non-metallic PBR, its pixels
that material's colour."""
from __future__ import annotations

import functools
import http.server
import os
import shutil
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import grammarkit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "js"))
from _node import JS_DIR, ROOT, missing, package_or_skip  # noqa: E402

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--no-first-run"]


def _chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    missing("chromium (apt-get install chromium)")
    raise AssertionError("unreachable")


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # keep the test output clean
        pass


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """An HTTP server on 127.0.0.1 serving tests/js (three.js, the page) and the model."""
    package_or_skip("three")
    model = grammarkit.derive(ROOT / "grammars" / "paris.grammar", seed=0)
    model.save(JS_DIR / ".paris_test.glb")
    handler = functools.partial(_Quiet, directory=str(JS_DIR))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", model
    finally:
        server.shutdown()
        server.server_close()
        (JS_DIR / ".paris_test.glb").unlink(missing_ok=True)


@pytest.fixture(scope="module")
def inspected(served):
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        missing("playwright (pip install -e '.[test]')")
    base, model = served
    executable = _chromium()
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=executable, args=CHROMIUM_FLAGS, headless=True)
        try:
            page = browser.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(f"{base}/viewer.html")
            page.wait_for_function("window.viewerReady === true", timeout=60_000)
            result = page.evaluate("url => window.inspectModel(url)", f"{base}/.paris_test.glb")
        finally:
            browser.close()
    assert not errors, errors
    return result, model


def test_model_is_upright(inspected):
    result, model = inspected
    sx, sy, sz = result["size"]
    assert sy > sx and sy > sz, result["size"]  # Y up: the 46 m tall block stands
    zx, zy, zz = model.mesh.extents
    assert np.allclose([sx, sy, sz], [zx, zz, zy], atol=1e-3)  # (x, y, z) -> (x, z, -y)
    assert result["min"][1] == pytest.approx(model.mesh.bounds[0][2], abs=1e-3)  # on the ground


def _main_material(model) -> dict:
    """The glTF material of the building's one primitive (the most used of the grammar's)."""
    import json

    data = (JS_DIR / ".paris_test.glb").read_bytes() if (JS_DIR / ".paris_test.glb").exists() else None
    if data is None:  # the fixture removed it: write it again
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            data = model.save(Path(tmp) / "p.glb").read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    (mesh,) = doc["meshes"]
    (prim,) = mesh["primitives"]
    return doc["materials"][prim["material"]]


def test_material_names_arrive_as_plastic_pbr(inspected):
    """A closed building is one primitive (issue 32: watertight in every reader), so a plain
    GLTFLoader shows it in one material: the grammar's most used one, non-metallic PBR. The
    per-terminal materials ride in the primitive's extras (geometry.userData in three.js)."""
    result, model = inspected
    names = set(result["materials"])
    wanted = {t.material for t in model.tags if t.material}
    (name,) = names
    assert any(name == w or name.startswith(w + " #") for w in wanted), (wanted, names)
    assert name == _main_material(model)["name"]
    for name, mat in result["materials"].items():
        assert mat["type"] == "MeshStandardMaterial", name
        assert mat["metalness"] == 0, name


def test_pixels_show_the_main_material_colour(inspected):
    result, model = inspected
    (name,) = result["stats"]  # one mesh: the building
    hexc = _main_material(model)["extras"]["srgb"]
    expected = np.array([int(hexc[k:k + 2], 16) for k in (1, 3, 5)])
    s = result["stats"][name]
    assert s["pixels"] > 10_000
    # flat colour: every pixel of the building, not just the mean
    assert np.abs(np.array(s["min"]) - expected).max() <= 3 and np.abs(np.array(s["max"]) - expected).max() <= 3
