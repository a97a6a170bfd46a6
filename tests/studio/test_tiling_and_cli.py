"""The studio on a tiling grammar (its example in the view, a gallery of graph-sampler variants
streamed with their validation reports), the `grammarkit studio` command, and the editor
grammar shipped in editors/ (the page highlights with the same file)."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
import urllib.request

import pytest
from click.testing import CliRunner

from _studio import ROOT, open_page, screenshot


def test_tiling_gallery_streams_validated_variants(browser, tmp_path):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from grammarkit_studio import running

    folder = tmp_path / "castle"
    shutil.copytree(ROOT / "grammars" / "tiling" / "castle", folder)
    with running(folder / "castle.grammar") as studio:
        page = open_page(browser, studio.url)
        facts = page.evaluate("window.studio.lastFacts")
        assert facts["kind"] == "tiling" and facts["examples"] == 2
        page.wait_for_function("document.querySelectorAll('#backend option').length > 0")
        assert "graph-sampler" in page.locator("#backend option").all_inner_texts()
        page.select_option("#backend", "graph-sampler")
        page.fill("#gallery-n", "2")
        page.click("#sample")
        page.wait_for_function("document.querySelectorAll('#gallery .card').length === 2", timeout=90_000)
        page.locator("#gallery-status", has_text="2 of 2").wait_for(timeout=30_000)
        cards = page.locator("#gallery .card")
        for i in range(2):
            assert cards.nth(i).locator(".ok").inner_text() == "valid"
            assert "OK: variant_" in cards.nth(i).locator("details").text_content()
        models = page.evaluate("window.studio.models")
        cards.nth(1).click()  # shows that variant in the view
        page.wait_for_function(f"window.studio.models > {models}")
        with page.expect_download() as info:  # and exports it
            page.click("#export-glb")
        variant = tmp_path / "variant.glb"
        info.value.save_as(variant)
        from grammarkit.tiling import read_assembly, validate
        from grammarkit.dsl import load

        assembly = read_assembly(variant)
        assert len(assembly.parts) == page.evaluate("window.studio.galleryParts[1]")
        assert validate(load(folder / "castle.grammar"), assembly).ok
        screenshot(page, "tiling_gallery", tmp_path)
        assert not page.errors
        page.context.close()


def test_cli_command_serves_and_prints_the_url(tmp_path):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from _studio import copy_grammars

    path = copy_grammars(tmp_path / "g")
    proc = subprocess.Popen([sys.executable, "-m", "grammarkit", "studio", str(path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        url = None
        deadline = time.monotonic() + 60
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if line.strip().startswith("open http://127.0.0.1:"):
                url = line.split()[-1]
        assert url and "/s/" in url
        page = urllib.request.urlopen(url, timeout=20).read()
        assert b"grammarkit studio" in page
        port = int(url.split(":")[2].split("/")[0])
        with pytest.raises(urllib.error.HTTPError) as info:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=20)
        assert info.value.code == 403
    finally:
        proc.terminate()
        proc.wait(20)


def test_cli_errors_are_clear(tmp_path, monkeypatch):
    from grammarkit.cli import main

    runner = CliRunner()
    result = runner.invoke(main, ["studio", str(tmp_path / "missing.grammar")])
    assert result.exit_code != 0 and "missing.grammar: no such file" in result.output
    assert "Traceback" not in result.output
    (tmp_path / "model.glb").write_bytes(b"glTF")
    result = runner.invoke(main, ["studio", str(tmp_path / "model.glb")])
    assert result.exit_code != 0 and "edits .grammar files" in result.output
    import grammarkit_studio

    monkeypatch.setattr(grammarkit_studio, "missing_extra", lambda: "uvicorn")
    result = runner.invoke(main, ["studio", str(ROOT / "grammars" / "paris.grammar")])
    assert result.exit_code != 0
    assert 'pip install "grammarkit[studio]"' in result.output and "uvicorn" in result.output


def test_plugin_module_stays_light():
    code = ("import sys, grammarkit_studio.plugin; "
            "heavy = [m for m in ('starlette', 'uvicorn', 'trimesh', 'scipy', 'torch') if m in sys.modules]; "
            "print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_editor_grammar_is_the_shipped_textmate_grammar():
    shipped = ROOT / "editors" / "vscode" / "syntaxes" / "grammarkit.tmLanguage.json"
    served = ROOT / "plugins" / "studio" / "grammarkit_studio" / "static" / "grammarkit.tmLanguage.json"
    assert shipped.read_bytes() == served.read_bytes()
    tm = json.loads(shipped.read_text())
    assert tm["scopeName"] == "source.grammarkit"
    pkg = json.loads((ROOT / "editors" / "vscode" / "package.json").read_text())
    (lang,) = pkg["contributes"]["languages"]
    assert lang["extensions"] == [".grammar"]
    (gram,) = pkg["contributes"]["grammars"]
    assert gram["scopeName"] == tm["scopeName"] and (shipped.parent.parent / gram["path"]).resolve() == shipped
    json.loads((ROOT / "editors" / "vscode" / "language-configuration.json").read_text())


def _scopes(line: str) -> dict[str, str]:
    """Tokenise one line like the page does (the first pattern that matches at a position
    wins): {token text: scope name without the language suffix}."""
    import re

    tm = json.loads((ROOT / "editors" / "vscode" / "syntaxes" / "grammarkit.tmLanguage.json").read_text())
    rules = [(re.compile(p["match"]), p["name"].removesuffix(".grammarkit")) for p in tm["patterns"]]
    out, pos = {}, 0
    while pos < len(line):
        for rx, name in rules:
            m = rx.match(line, pos)
            if m and m.end() > pos:
                out.setdefault(m.group(), name)
                pos = m.end()
                break
        else:
            pos += 1
    return out


def test_textmate_scopes_of_grammar_text():
    t = _scopes("Window --> offset(-0.15) { inside: Glass. | border: Frame. } # pane")
    assert t["Window"] == "entity.name.function.rule" and t["-->"] == "keyword.operator.arrow"
    assert t["offset"] == "support.function.operation" and t["0.15"] == "constant.numeric"
    assert t["Glass."] == "entity.name.tag.terminal" and t["inside"] == "variable.other"
    assert t["# pane"] == "comment.line.number-sign"
    t = _scopes("attr h = 24 @range(9, 60)  # tall")
    assert t["attr"] == "keyword.other.declaration" and t["@range"] == "storage.modifier.annotation"
    t = _scopes("Lot --> footprint(rect(16, 12)) extrude(height) Mass")
    assert t["Lot"] == "entity.name.function.rule" and t["Mass"] == "entity.name.type.successor"
    assert t["rect"] == "support.function.operation"
    t = _scopes('Roof --> 30%: roofHip(30) color("#7a3b2e") | else: NIL')
    assert t["30%"] == "constant.numeric.percentage" and t["NIL"] == "constant.language"
    assert t['"#7a3b2e"'] == "string.quoted.double" and t["else"] == "keyword.control"
    t = _scopes("dock Gate -- Tower { at (-2.8, 2.2, -0.9) rot (-6.97, -3.7, -164.28) }")
    assert t["dock"] == "keyword.other.declaration" and t["--"] == "keyword.operator"
    assert t["at"] == "keyword.control" and t["Gate"] == "entity.name.type.successor"


def test_shipped_assets_are_complete_and_licensed():
    """Every file the page loads (index.html's scripts and styles, the ES module imports) is in
    the package, with the vendored libraries' licences; nothing is fetched from elsewhere."""
    import re

    static = ROOT / "plugins" / "studio" / "grammarkit_studio" / "static"
    html = (static / "index.html").read_text()
    refs = re.findall(r'(?:src|href)="([^"]+)"', html)
    assert refs and not [r for r in refs if r.startswith(("http:", "https:", "//"))]
    for ref in refs:
        if ref.startswith("static/"):  # the others are the server's routes (export/glb) or data:
            assert (static.parent / ref).is_file(), ref
    assert sum(r.startswith("static/") for r in refs) >= 5
    modules = [static / "studio.js", *(static / "vendor" / "three").rglob("*.js")]
    for module in modules:
        for target in re.findall(r"^\s*(?:import|export)\b[^;]*?from\s+['\"]([^'\"]+)['\"]", module.read_text(), re.M):
            assert target.startswith("."), f"{module.name} imports {target!r} (a bare name needs an import map)"
            assert (module.parent / target).resolve().is_file(), f"{module.name} -> {target}"
    for lib in ("three", "codemirror"):
        assert "MIT" in (static / "vendor" / lib / "LICENSE").read_text() or \
               "Permission is hereby granted" in (static / "vendor" / lib / "LICENSE").read_text()
    lock = json.loads((ROOT / "plugins" / "studio" / "frontend" / "package-lock.json").read_text())
    versions = json.loads((static / "vendor" / "VERSIONS.json").read_text())
    for lib, version in versions.items():
        assert lock["packages"][f"node_modules/{lib}"]["version"] == version
