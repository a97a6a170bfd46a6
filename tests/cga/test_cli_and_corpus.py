"""`grammarkit import-cga` end to end, no half files, and the corpus."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cli import main
from grammarkit.cga import translate_cga

CORPUS = Path(__file__).resolve().parents[2] / "grammars" / "cga"


def run(*args):
    return CliRunner().invoke(main, list(map(str, args)))


def test_import_writes_a_checked_grammar_and_a_report(tmp_path):
    src = tmp_path / "b.cga"
    src.write_text('attr H = 9\nLot --> extrude(H) copyUV(1, 0) comp(f) { top: R. | side: F. }\n')
    out, rep = tmp_path / "b.grammar", tmp_path / "r.json"
    res = run("import-cga", src, "-o", out, "--report", rep)
    assert res.exit_code == 0, res.stderr
    assert f"{src}:2:20: warning: not translated: copyUV()" in res.stderr
    assert "wrote" in res.stderr
    assert grammarkit.check(out) == []
    data = json.loads(rep.read_text())
    assert data["constructs"]["dropped"] == 1 and data["missing_features"] == {"op:copyUV": 1}
    assert data["checks"] is True


def test_malformed_cga_writes_nothing(tmp_path):
    src = tmp_path / "bad.cga"
    src.write_text("Lot --> split(x) { 1: A\n")
    out = tmp_path / "bad.grammar"
    res = run("import-cga", src, "-o", out)
    assert res.exit_code == 1 and not out.exists()
    assert f"{src}:2:1: error: CGA syntax error" in res.stderr
    assert "Traceback" not in res.stderr


def test_translation_that_does_not_check_is_not_written_unless_forced(tmp_path):
    src = tmp_path / "p.cga"
    src.write_text("Lot --> 70%: A. 60%: B. else: C.\n")   # percentages above 100
    out = tmp_path / "p.grammar"
    res = run("import-cga", src, "-o", out)
    assert res.exit_code == 1 and not out.exists()
    assert "does not pass `grammarkit check`" in res.stderr
    res = run("import-cga", src, "-o", out, "--force")
    assert res.exit_code == 0 and out.exists()


def test_missing_file_is_a_located_error(tmp_path):
    res = run("import-cga", tmp_path / "nope.cga", "-o", tmp_path / "x.grammar")
    assert res.exit_code == 1 and "cannot read" in res.stderr


def test_corpus_is_large_enough_and_licensed():
    files = sorted(CORPUS.glob("*.cga"))
    assert len(files) >= 20
    readme = (CORPUS / "README.md").read_text()
    assert (CORPUS / "LICENSE-Apache-2.0.txt").exists()
    for f in files:
        assert f"`{f.name}`" in readme


@pytest.mark.parametrize("path", sorted(CORPUS.glob("*.cga")), ids=lambda p: p.name)
def test_every_corpus_file_translates_to_a_checked_grammar(path):
    result = translate_cga(path, missing_assets="drop")
    assert result.ok, [d.message for d in result.diagnostics if d.severity == "error"]
    rep = result.report
    assert rep.total == rep.translated + rep.warned and rep.total > 0
    # every warned construct has a located warning in the CGA file
    warned = [c for c in rep.constructs if c.status != "translated"]
    warnings = [d for d in result.diagnostics if d.severity == "warning" and d.code and
                d.code.startswith("cga-")]
    own = [d for d in warnings if d.span.file == str(path)]
    assert len(own) == len(warned)
    # what the imported files leave out is said too, located in those files, once each
    imported = [d for d in warnings if d.span.file != str(path)]
    assert len(imported) == len(rep.imported)
    assert len({(d.span.file, d.span.line, d.span.column, d.message) for d in imported}) == len(imported)
    assert all(d.span.line >= 1 and Path(d.span.file).is_file() for d in warnings)
    assert grammarkit.parse(result.text).rules[0].name == result.grammar.rules[0].name
