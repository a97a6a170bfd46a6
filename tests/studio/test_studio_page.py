"""The studio's page in a real browser (headless chromium): the Paris building appears with its
materials, a slider drag re-derives it, a syntax error shows inline with `check`'s message and
the last good model stays, clicking a window selects its Window terminal in the tree (and a tree
row highlights its parts), variations fill the gallery, and the GLB download reads back
watertight. The tests share one page, in file order."""
from __future__ import annotations

import io

import numpy as np
import pytest

import grammarkit

from _studio import gable_roof, open_page, screenshot

BACKGROUND = np.array([0x2B, 0x30, 0x36])


@pytest.fixture(scope="module")
def page(studio, browser):
    p = open_page(browser, studio.url)
    yield p
    assert not p.errors, p.errors  # no uncaught JavaScript error during the whole session
    p.context.close()


def view_pixels(page) -> np.ndarray:
    from PIL import Image

    png = page.locator("#view canvas").screenshot()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.int16)


def wait_shown(page, timeout: float = 30_000) -> dict:
    """Wait until the newest edit's model is on screen; its facts."""
    page.wait_for_function("window.studio.shownRev === window.studio.rev && window.studio.sent.size === 0",
                           timeout=timeout)
    return page.evaluate("window.studio.lastFacts")


def test_model_appears_upright_with_materials(page, tmp_path):
    facts = wait_shown(page)
    assert facts["kind"] == "split" and facts["triangles"] > 1000
    px = view_pixels(page)
    bright = px.sum(axis=2) > 3 * 110  # background and grid lines are darker than any wall
    assert bright.mean() > 0.05, f"only {bright.mean():.1%} of the view shows the model"
    # the grammar's limestone walls (#d6c6a5, warm) are lit as a material: warm bright pixels
    warm = bright & (px[..., 0] - px[..., 2] > 20)
    assert warm.mean() > 0.02
    # upright: the building (bright pixels) is taller on screen than wide
    ys, xs = np.nonzero(bright)
    assert (ys.max() - ys.min()) > 1.2 * (xs.max() - xs.min())
    # the editor highlights the text with the TextMate grammar's scopes
    assert page.locator(".CodeMirror .cm-keyword", has_text="attr").count() >= 4
    assert page.locator(".CodeMirror .cm-def", has_text="Lot").count() == 1
    assert page.locator("#problems").inner_text().strip() == "no problems"
    screenshot(page, "overview", tmp_path)


def test_slider_drag_rederives(page):
    before = view_pixels(page)
    slider = page.locator('input[data-attr="mass_h"]')
    box = slider.bounding_box()
    lo, hi = 36, 48
    value = float(slider.input_value())
    y = box["y"] + box["height"] / 2
    x0 = box["x"] + 8 + (box["width"] - 16) * (value - lo) / (hi - lo)  # the thumb
    page.mouse.move(x0, y)
    page.mouse.down()
    for k in range(1, 11):  # a real drag: input events while the mouse moves
        page.mouse.move(x0 + (box["x"] + box["width"] - x0) * k / 10, y)
        page.wait_for_timeout(30)
    page.mouse.up()
    facts = wait_shown(page)
    assert facts["attrs"]["mass_h"] == hi
    after = view_pixels(page)
    changed = (np.abs(after - before).sum(axis=2) > 30).mean()
    assert changed > 0.01, f"the view barely changed ({changed:.2%} of pixels)"
    shown = page.locator(".slider", has=page.locator('input[data-attr="mass_h"]')).locator(".value")
    assert shown.inner_text() == str(hi)


def test_syntax_error_inline_keeps_last_model(page, paris_copy, tmp_path):
    models = page.evaluate("window.studio.models")
    line = next(i for i, t in enumerate(paris_copy.read_text().splitlines()) if t.startswith("attr lot_w"))
    page.locator(".CodeMirror-code > div").nth(line).click()
    page.keyboard.press("End")
    page.keyboard.type(" = =")
    diag = page.locator(".gk-diag.error").first
    diag.wait_for(timeout=15_000)
    text = page.evaluate("window.studio.text")
    expected = [d for d in grammarkit.check(text, filename=str(paris_copy)) if d.severity == "error"]
    assert expected and expected[0].span.line == line + 1
    assert diag.inner_text().startswith(f"error: {expected[0].message}")
    # located: the underline sits on the reported line, the gutter has a marker there
    assert page.locator(".gk-underline-error").count() >= 1
    assert page.locator(".gk-gutter.error").count() == 1
    assert f"{paris_copy.name}:{line + 1}:{expected[0].span.column}" in page.locator("#problems").inner_text()
    page.wait_for_timeout(300)
    assert page.evaluate("window.studio.models") == models  # the last good model stays
    screenshot(page, "diagnostic", tmp_path)
    for _ in range(4):
        page.keyboard.press("Control+z")
    page.locator("#problems .ok").wait_for(timeout=15_000)
    assert page.evaluate("window.studio.text") == paris_copy.read_text()
    wait_shown(page)


def test_derive_error_shows_and_keeps_last_model(page, paris_copy):
    models = page.evaluate("window.studio.models")
    good = page.evaluate("window.studio.text")
    # checks cleanly, but derives nothing solid: the engine's located error is shown
    page.evaluate("""(t) => { const cm = document.querySelector('.CodeMirror').CodeMirror; cm.setValue(t); }""",
                  good.replace("Lot --> footprint(rect(lot_w, lot_d)) Mass", "Lot --> footprint(rect(lot_w, lot_d)) NIL"))
    error = page.locator("#derive-error")
    error.wait_for(state="visible", timeout=15_000)
    assert "no volume" in error.inner_text() and "last good model" in error.inner_text()
    assert page.evaluate("window.studio.models") == models
    page.evaluate("""(t) => document.querySelector('.CodeMirror').CodeMirror.setValue(t)""", good)
    page.wait_for_function("window.studio.models > %d" % models, timeout=15_000)
    assert not error.is_visible()


def _visible_window_point(page, model) -> tuple[float, float, object]:
    """A screen point where the view shows a Glass pane of a Window (checked by ray casting in
    the page, so the click lands on it), with its part."""
    glass = [p for p in model.parts if p.name == "Glass"]
    for part in sorted(glass, key=lambda p: -p.origin[2])[::3] + glass:
        o, ax, sz = (np.asarray(v, dtype=float) for v in (part.origin, part.axes, part.size))
        centre = o + 0.5 * sz[0] * ax[0] + 0.5 * sz[1] * ax[1]
        s = page.evaluate("(p) => window.studio.project(p)", centre.tolist())
        hit = page.evaluate("([x, y]) => window.studio.hitAt(x, y)", [s["x"], s["y"]])
        if hit is None:
            continue
        local = ax @ (np.asarray(hit["point"]) - o)
        if np.all(local >= -0.02) and np.all(local <= sz + 0.02):
            return s["x"], s["y"], part
    raise AssertionError("no Glass pane is visible")


def test_click_window_selects_window_terminal_and_back(page, tmp_path):
    attrs = page.evaluate("window.studio.attrs")
    seed = page.evaluate("window.studio.seed")
    model = grammarkit.derive(page.evaluate("window.studio.filePath"), seed=seed, attrs=attrs)
    x, y, part = _visible_window_point(page, model)
    page.mouse.click(x, y)
    row = page.locator("#tree .node.selected")
    row.wait_for(timeout=15_000)
    assert row.get_attribute("data-rule") == "Window"  # the Window snippet's terminal shape
    assert int(row.get_attribute("data-id")) == part.node
    info = page.locator("#selection").inner_text()
    assert info.startswith("Glass.") and "(Window)" in info and "library.grammar:" in info
    assert page.evaluate("window.studio.highlighted") == 1
    screenshot(page, "pick", tmp_path)
    # the reverse: a tree row highlights the parts below it in the view
    parent = page.locator(f'#tree .node[data-id="{part.node}"]').locator("xpath=preceding-sibling::div[1]")
    parent.click()
    page.wait_for_function("window.studio.highlighted > 1", timeout=15_000)
    # and from the text: the cursor on the axiom's line outlines every part it made
    lot = next(i for i, t in enumerate(page.evaluate("window.studio.text").splitlines()) if t.startswith("Lot -->"))
    page.locator(".CodeMirror-code > div").nth(lot).click()
    page.wait_for_function(f"window.studio.highlighted === {len(model.parts)}", timeout=15_000)


def test_variations_fill_the_gallery(page, tmp_path):
    page.fill("#gallery-n", "3")
    page.click("#variations")
    page.wait_for_function("document.querySelectorAll('#gallery .card').length === 3", timeout=60_000)
    page.locator("#gallery-status").filter(has_text="3 of 3").wait_for(timeout=30_000)
    page.locator("#gallery .card").nth(1).click()
    page.wait_for_function("window.studio.lastFacts.variation && window.studio.lastFacts.variation.index === 1",
                           timeout=30_000)
    screenshot(page, "variations", tmp_path)
    page.click("#reset-attrs")
    wait_shown(page)


def test_new_seed_and_format(page, paris_copy):
    page.click("#reseed")
    seed = int(page.input_value("#seed"))
    facts = wait_shown(page)
    assert facts["seed"] == seed and page.evaluate("window.studio.seed") == seed
    page.fill("#seed", "0")
    page.dispatch_event("#seed", "change")
    assert wait_shown(page)["seed"] == 0
    # Format: the text as grammarkit's printer writes it (`grammarkit fmt`)
    text = page.evaluate("window.studio.text")
    untidy = text.replace("attr lot_w = 16 @range(12, 24)", "attr   lot_w=16   @range( 12,24 )")
    assert untidy != text
    set_text = "(t) => document.querySelector('.CodeMirror').CodeMirror.setValue(t)"
    page.evaluate(set_text, untidy)
    page.click("#format")
    expected = grammarkit.format(grammarkit.parse(untidy, filename=str(paris_copy)))
    assert "attr lot_w = 16 @range(12, 24)" in expected
    page.wait_for_function("(t) => window.studio.text === t", arg=expected, timeout=15_000)
    page.evaluate(set_text, text)
    wait_shown(page)


def test_download_glb_reads_back_watertight(page, tmp_path):
    import trimesh

    facts = wait_shown(page)
    with page.expect_download() as info:
        page.click("#export-glb")
    path = tmp_path / info.value.suggested_filename
    info.value.save_as(path)
    assert path.suffix == ".glb" and path.stat().st_size > 10_000
    loaded = trimesh.load(path)
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.to_mesh()
    mesh = trimesh.Trimesh(loaded.vertices, loaded.faces)  # trimesh's default processing
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert len(mesh.faces) == facts["triangles"]
    for fmt in ("obj", "stl"):
        with page.expect_download() as info:
            page.click(f"#export-{fmt}")
        assert info.value.suggested_filename.endswith(f".{fmt}")


def draw_strokes(page, box, strokes) -> None:
    """Draw strokes (fractions of the box) with the mouse."""
    for stroke in strokes:
        page.mouse.move(box["x"] + stroke[0][0] * box["width"], box["y"] + stroke[0][1] * box["height"])
        page.mouse.down()
        for (x0, y0), (x1, y1) in zip(stroke, stroke[1:]):
            for k in range(1, 7):
                t = k / 6
                page.mouse.move(box["x"] + (x0 + t * (x1 - x0)) * box["width"],
                                box["y"] + (y0 + t * (y1 - y0)) * box["height"])
        page.mouse.up()


def sketch_answer(page) -> str:
    """Wait until the recognizer (or the server) has answered; the result panel's text."""
    page.wait_for_function("!window.studio.sketchBusy && document.getElementById('sketch-result')"
                           ".textContent.length > 0 && !/…$/.test(document.getElementById('sketch-result')"
                           ".textContent)", timeout=90_000)
    return page.locator("#sketch-result").inner_text()


def test_sketch_canvas_draws_strokes_and_asks_the_recognizer(page, tmp_path):
    try:
        import grammarkit_sketch  # noqa: F401
        import torch  # noqa: F401
        installed = True
    except ImportError:
        installed = False
    page.click("#sketch-toggle")
    canvas = page.locator("#sketch")
    assert "Roof" in page.locator("#sketch-type option").all_inner_texts()  # the grammar's object types
    page.select_option("#sketch-type", "Roof")
    result = page.locator("#sketch-result")
    if not installed:  # no plugin: "the sketch recognizer is not installed"; no torch: "... needs torch, which is not installed"
        assert "not installed" in sketch_answer(page)
        assert not canvas.is_visible() and page.locator("#sketch-recognize").is_disabled()
        page.click("#sketch-toggle")
        return
    from grammarkit_sketch import get_recognizer

    # the Roof's canvas: the recognizer's aspect ratio, white paper with the anchor's outline
    page.wait_for_function("window.studio.sketchCanvas && window.studio.sketchCanvas.object_type === 'Roof'",
                           timeout=90_000)
    assert canvas.is_visible() and not page.locator("#sketch-recognize").is_disabled()
    w, h = get_recognizer().models.type_model("Roof").stage.canvas_size()
    box = canvas.bounding_box()
    assert abs(box["width"] / box["height"] - w / h) < 0.02
    from PIL import Image

    paper = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("L")).astype(int)
    assert (paper > 245).mean() > 0.9 and ((paper < 235) & (paper > 120)).mean() > 0.001
    # an error is shown, not waited for: recognising an empty drawing
    page.click("#sketch-recognize")
    assert "nothing to recognise" in sketch_answer(page)
    assert "error" in (result.get_attribute("class") or "")
    draw_strokes(page, box, gable_roof())
    assert page.evaluate("window.studio.strokes.length") == 5
    assert not result.inner_text()  # drawing again clears the error
    # strokes are kept in the canvas's own pixels, whatever size it is shown at
    xs = page.evaluate("window.studio.strokes.flat().map((p) => p[0])")
    cw = page.evaluate("window.studio.sketchCanvas.width")
    assert 0.15 * cw < min(xs) < max(xs) < 0.85 * cw
    page.click("#sketch-recognize")
    sketch_answer(page)
    buttons = page.locator("#sketch-result button")
    assert buttons.count() == 3
    first = buttons.first.inner_text()
    snippet = first.split(" ")[1]
    assert snippet == "roof_gable" and "roof_deg=" in first, first  # what the recognizer sees in the drawing
    screenshot(page, "sketch", tmp_path)
    before = page.evaluate("window.studio.rev")
    buttons.first.click()  # the grammar text takes the snippet and its parameters
    assert f"use {snippet} as Roof" in page.evaluate("window.studio.text")
    page.wait_for_function(f"window.studio.rev > {before}")
    facts = wait_shown(page, 60_000)
    assert facts["kind"] == "split"
    # another type, another shape: a floor's canvas is wide and low
    page.select_option("#sketch-type", "Floor")
    page.wait_for_function("window.studio.sketchCanvas && window.studio.sketchCanvas.object_type === 'Floor'",
                           timeout=60_000)
    box = canvas.bounding_box()
    fw, fh = get_recognizer().models.type_model("Floor").stage.canvas_size()
    assert abs(box["width"] / box["height"] - fw / fh) < 0.05 and page.evaluate("window.studio.strokes.length") == 0
    page.click("#sketch-toggle")
    assert not canvas.is_visible() and not page.locator("#sketch-tools").is_visible()
