"""Front-end hardening of issue 19: bounded reads, line counting identical to the parser's,
linear diagnostics, ASCII-only numbers, bad import paths, check's cap and standard input."""
from __future__ import annotations

import os
import time

import pytest
from click.testing import CliRunner

import grammarkit
from grammarkit.cli import main
from grammarkit.dsl import check
from grammarkit.dsl.parser import read_source
from grammarkit.errors import GrammarError


def run(*args, input=None):  # noqa: A002
    return CliRunner().invoke(main, [str(a) for a in args], input=input)


@pytest.mark.parametrize("brk", ["\u2028", "\u0085", "\f", "\x1c", "\r", "\u2029", "\x0b"])
def test_source_line_under_a_diagnostic_is_the_parsers_line(brk, tmp_path):
    text = f"# one{brk}two\nLot --> extrude(x) X.\n"
    p = tmp_path / "g.grammar"
    p.write_text(text, encoding="utf-8", newline="")
    (d,) = [d for d in check(p) if d.severity == "error"]
    assert d.span.line == 2
    for shown in (d.format(), d.format(text)):  # read from the file, and from the text given
        assert shown.splitlines()[1].strip() == "Lot --> extrude(x) X.", shown


def test_many_diagnostics_format_in_linear_time(tmp_path):
    p = tmp_path / "many.grammar"
    p.write_text("".join(f"R{i} --> extrude(u{i}) R{i + 1}\n" for i in range(8000)) + "R8000 --> X.\n",
                 encoding="utf-8")
    diags = check(p)
    assert len(diags) == 8000
    t0 = time.process_time()
    text = "\n".join(d.format() for d in diags)
    assert time.process_time() - t0 < 3.0  # was ~0.3 ms per diagnostic per 1,000 lines
    assert "R7999 --> extrude(u7999) R8000" in text


def test_check_prints_at_most_200_diagnostics_then_a_count(tmp_path):
    p = tmp_path / "many.grammar"
    p.write_text("".join(f"R{i} --> extrude(u{i}) R{i + 1}\n" for i in range(450)) + "R450 --> X.\n",
                 encoding="utf-8")
    r = run("check", p)
    assert r.exit_code == 1
    assert r.output.count(": error: undefined name") == 200
    assert "... and 250 more diagnostics" in r.output and "450 errors" in r.output
    r = run("check", "--max-diagnostics", "1000", p)
    assert r.output.count(": error: undefined name") == 450
    r = run("check", "--json", p)
    assert r.output.count('"undefined-name"') == 450  # JSON lists them all


@pytest.mark.parametrize("number", ["１０", "١٢", "1_0", "٣.٥", "1e٣"])
def test_numbers_are_ascii_digits_only(number):
    (d, *_) = [d for d in check(f"Lot --> extrude({number}) X.\n") if d.severity == "error"]
    assert d.span.line == 1 and d.span.column >= 17, d.format()


def test_devices_fifos_and_folders_are_refused_without_reading(tmp_path):
    t0 = time.perf_counter()
    with pytest.raises(GrammarError, match="device"):
        read_source(type(tmp_path)("/dev/zero"))
    fifo = tmp_path / "pipe.grammar"
    os.mkfifo(fifo)
    with pytest.raises(GrammarError, match="named pipe"):
        read_source(fifo)
    with pytest.raises(GrammarError, match="folder"):
        read_source(tmp_path)
    assert time.perf_counter() - t0 < 2
    # the API never raises for them
    (d,) = check(fifo)
    assert d.code == "not-a-file" and d.span.file == str(fifo)


def test_a_file_over_the_limit_is_not_read_whole(tmp_path):
    p = tmp_path / "big.grammar"
    p.write_text("#" * 5000)
    with pytest.raises(GrammarError, match="too large"):
        read_source(p, max_bytes=1000)


def test_standard_input_is_read_up_to_the_limit():
    r = run("check", "-", input="Lot --> extrude(x) X.\n")
    assert r.exit_code == 1 and "<stdin>:1:17: error: undefined name 'x'" in r.output
    r = run("fmt", "-", input="Lot-->extrude( 3 )  X.\n")
    assert r.exit_code == 0 and "Lot --> extrude(3) X." in r.output
    r = run("fmt", "--max-size", "100", "-", input="\0" * 100_000)
    assert r.exit_code == 1 and "too large" in r.output
    r = run("fmt", "-i", "-", input="Lot --> X.\n")
    assert r.exit_code == 2 and "standard input" in r.output


@pytest.mark.parametrize("path,words", [("a\0b.grammar", "NUL"), ("a" * 5000 + ".grammar", "5,008 characters"),
                                        ("a" * 300 + ".grammar", "bad import path")])
def test_bad_import_paths_are_located_errors(tmp_path, path, words):
    p = tmp_path / "g.grammar"
    p.write_text(f'import "{path}"\nLot --> X.\n', encoding="utf-8")
    diags = grammarkit.check(p)
    (d,) = [d for d in diags if d.severity == "error"]
    assert words in d.message and d.span.line == 1, d.format()


def test_long_lines_show_a_window_around_the_column():
    text = "Lot --> " + " ".join(f"t(0, 0, {i})" for i in range(3000)) + " extrude(zz) X.\n"
    (d,) = check(text)
    shown = d.format(text).splitlines()
    assert len(shown[1]) < 260 and shown[1].startswith("    ...")
    assert shown[1].index("zz") == shown[2].index("^")
