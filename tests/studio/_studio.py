"""Helpers and fixtures of the studio tests: a copy of the Paris grammar (saving must not touch the repo),
the studio serving it from a background thread, and Debian's chromium driven by Playwright
(no browser download). Without chromium or playwright the browser tests skip locally and FAIL
under CI (environment variable CI set), so CI never passes by skipping them."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GRAMMARS = ROOT / "grammars"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--no-first-run"]
# `GRAMMARKIT_STUDIO_SCREENSHOTS=docs/images pytest tests/studio` refreshes docs/studio.md's pictures
SCREENSHOTS = os.environ.get("GRAMMARKIT_STUDIO_SCREENSHOTS")


def missing(what: str) -> None:
    msg = f"{what} is not installed (pip install -e '.[test]'; apt-get install chromium)"
    if os.environ.get("CI"):
        pytest.fail(f"CI must run the studio tests: {msg}")
    pytest.skip(msg)


def chromium_path() -> str:
    for name in ("/usr/bin/chromium", shutil.which("chromium") or "", shutil.which("chromium-browser") or ""):
        if name and Path(name).is_file():
            return name
    missing("chromium")
    raise AssertionError("unreachable")


def copy_grammars(dest: Path) -> Path:
    """paris.grammar with the library it imports and the part meshes, in a fresh folder."""
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("paris.grammar", "library.grammar"):
        shutil.copy(GRAMMARS / name, dest / name)
    shutil.copytree(GRAMMARS / "parts", dest / "parts")
    return dest / "paris.grammar"


@pytest.fixture(scope="module")
def paris_copy(tmp_path_factory) -> Path:
    return copy_grammars(tmp_path_factory.mktemp("studio") / "grammars")


@pytest.fixture(scope="module")
def studio(paris_copy):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from grammarkit_studio import running

    with running(paris_copy, poll=0.2) as s:
        yield s


@pytest.fixture(scope="session")
def browser():
    """One headless Chromium for all the studio tests of this test process (each test opens
    its own context: no cookies, storage or pages are shared); a launch per module cost
    seconds each (issue 32)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        missing("playwright")
    executable = chromium_path()
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=executable, args=CHROMIUM_FLAGS, headless=True)
        try:
            yield b
        finally:
            b.close()


def open_page(browser, url: str):
    """A page on the studio, waited for until its first model is shown. `bypass_csp` lets
    Playwright evaluate its own scripts; the page's CSP itself is tested in test_security."""
    context = browser.new_context(viewport={"width": 1280, "height": 800}, bypass_csp=True,
                                  accept_downloads=True)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_function("window.studio && window.studio.models > 0", timeout=90_000)
    page.errors = errors
    return page


def screenshot(page, name: str, tmp: Path, **kwargs) -> Path:
    """A screenshot of the page as docs/studio.md shows it: a 128-colour PNG (small enough to
    commit), into GRAMMARKIT_STUDIO_SCREENSHOTS when set, else the test's temporary folder."""
    import io

    from PIL import Image

    folder = Path(SCREENSHOTS) if SCREENSHOTS else tmp
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"studio_{name}.png"
    # Playwright scrolls what it clicks into view, even in a page that has no scroll bars
    page.evaluate("document.scrollingElement.scrollTop = 0; document.body.scrollTop = 0")
    image = Image.open(io.BytesIO(page.screenshot(**kwargs))).convert("RGB")
    image.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    return path


def gable_roof(lift: float = 0.22) -> list[list[tuple[float, float]]]:
    """Strokes of a gable roof drawn on the Roof canvas over its anchor's outline, in fractions
    of the canvas (x right, y down): the eaves, the two gable ends and the ridge, `lift` of the
    canvas height above the anchor (a higher ridge is a steeper roof)."""
    a, b, c, d = (0.176, 0.533), (0.449, 0.408), (0.8125, 0.59), (0.539, 0.825)  # the anchor's corners
    r1 = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2 - lift)
    r2 = ((c[0] + d[0]) / 2, (c[1] + d[1]) / 2 - lift)
    return [[a, r1, b], [d, r2, c], [r1, r2], [a, d], [b, c]]
