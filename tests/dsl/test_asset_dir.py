"""`asset_dir "path"`: parsed into Grammar.asset_dirs in order, printed back, checked, made
absolute when an imported file declares it."""
from __future__ import annotations

from pathlib import Path

import pytest

from grammarkit.dsl import KEYWORDS, check, load, parse
from grammarkit.errors import GrammarError
from grammarkit.ir import AssetDir, Grammar, Rule, Seq, Terminal
from grammarkit.printer import format_grammar, print_grammar

TEXT = """grammar t
# meshes
asset_dir "assets"
asset_dir "../shared meshes"
asset_dir "/abs/x"
Lot --> A.
"""


def test_parsed_in_declaration_order_as_written():
    g = parse(TEXT)
    assert g.asset_dirs == ("assets", "../shared meshes", "/abs/x")
    assert [s.kind for s in g.statements][:3] == ["asset_dir"] * 3
    assert g.family == "split"
    assert "asset_dir" in KEYWORDS


def test_fmt_round_trips():
    once = format_grammar(TEXT)
    assert 'asset_dir "assets"\nasset_dir "../shared meshes"\nasset_dir "/abs/x"' in once
    assert "# meshes" in once
    assert format_grammar(once) == once
    assert parse(once) == parse(TEXT)


def test_printer_prints_ir_built_in_code():
    g = Grammar(name="t", statements=(AssetDir.of('a "quoted" dir'),
                                      Rule(name="Lot", body=Seq(items=(Terminal(name="A"),)))))
    text = print_grammar(g)
    assert 'asset_dir "a \\"quoted\\" dir"' in text
    assert parse(text).asset_dirs == ('a "quoted" dir',)


@pytest.mark.parametrize("value, col", [("3", 11), ("name", 11), ('""', 11), ('"a" + "b"', 11), ('"  "', 11)])
def test_non_string_or_empty_is_a_located_error(value, col):
    diags = check(f"grammar t\nasset_dir {value}\nLot --> A.\n", filename="t.grammar")
    errors = [d for d in diags if d.severity == "error"]
    assert len(errors) == 1, diags
    (d,) = errors
    assert d.code == "bad-asset-dir" and "asset_dir" in d.message
    assert (d.span.file, d.span.line, d.span.column) == ("t.grammar", 2, col)
    with pytest.raises(GrammarError) as info:
        load(f"grammar t\nasset_dir {value}\nLot --> A.\n", filename="t.grammar")
    assert [(x.span.line, x.span.column) for x in info.value.diagnostics] == [(2, 11)]


def test_missing_value_is_a_syntax_error():
    diags = check("grammar t\nasset_dir\nLot --> A.\n", filename="t.grammar")
    assert any(d.severity == "error" and d.span.line == 2 for d in diags)


def test_imported_asset_dirs_become_absolute(tmp_path: Path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "lib.grammar").write_text('grammar lib\nasset_dir "meshes"\n'
                                                  'asset_dir "/already/abs"\nLib --> L.\n')
    main = tmp_path / "main.grammar"
    main.write_text('grammar main\nasset_dir "assets"\nimport "lib/lib.grammar"\n'
                    'asset_dir "more"\nLot --> Lib\n')
    g = load(main)
    assert g.asset_dirs == ("assets", str((tmp_path / "lib" / "meshes").absolute()),
                            "/already/abs", "more")
    # the file's own folders stay as written (relative to its folder, resolved by the engine)
    assert parse(main).asset_dirs == ("assets", "more")
