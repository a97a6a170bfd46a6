"""Bad input never escapes as anything but a located GrammarError (or a list of diagnostics)."""
from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grammarkit.dsl import check, parse
from grammarkit.dsl.parser import MAX_NESTING, split_statements
from grammarkit.errors import GrammarError
from grammarkit.printer import print_grammar

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parent / "data"
FILES = [p.read_text(encoding="utf-8") for p in
         sorted((ROOT / "grammars").glob("**/*.grammar")) + sorted(DATA.glob("*.grammar"))]


def _windows(text: str, size: int = 5) -> list[str]:
    """Runs of a few consecutive statements: small seeds keep thousands of examples fast."""
    chunks = [c for _, c in split_statements(text)]
    return ["\n".join(chunks[i:i + size]) for i in range(0, max(1, len(chunks)), 2)]


SEEDS = [w for text in FILES for w in _windows(text)] + [t for t in FILES if len(t) < 3000]
TOKEN_RE = re.compile(r'"[^"\n]*"|[A-Za-z_][A-Za-z0-9_]*\.?|\d+(?:\.\d+)?%?|-->|--|\.\.|\S')
VOCAB = ["-->", "{", "}", "(", ")", "[", "]", "|", ":", "*", "'", "~", "%", ",", ";", "=", ".",
         "..", "--", "@range", "@enum", "case", "else", "NIL", "attr", "const", "snippet", "use",
         "as", "default", "for", "variants", "import", "part", "site", "dock", "at", "rot",
         "neighbors", "in", "constraint", "example", "grammar", "true", "-", "+", "^", "!", "&&",
         "\n", "#", '"', "1", "0.5", "30%", "x", "Wall.", "scope.sx", "split(", "\u00e9", "\t"]


def assert_only_located_errors(source) -> None:
    """parse/check/print of `source` either work or fail with located diagnostics."""
    try:
        g = parse(source, filename="fuzz.grammar")
    except GrammarError as exc:
        assert exc.diagnostics
        for d in exc.diagnostics:
            if d.severity == "error":
                assert d.span is not None and d.span.file == "fuzz.grammar" and d.span.line >= 1, d
                assert d.span.column >= 1, d
                d.format(source if isinstance(source, str) else None)  # printable
    else:
        # anything that parses prints and reads back as the same IR
        text = print_grammar(g)
        assert parse(text, filename="fuzz.grammar") == g, text
    for d in check(source, filename="fuzz.grammar"):
        assert d.span is not None and d.span.line >= 1, d
        d.format(source if isinstance(source, str) else None)


@st.composite
def mutated(draw):
    src = draw(st.sampled_from(SEEDS))
    kind = draw(st.sampled_from(["char", "token", "bytes", "slice"]))
    n = draw(st.integers(1, 4))
    if kind == "bytes":
        data = bytearray(src.encode("utf-8"))
        for _ in range(n):
            i = draw(st.integers(0, max(0, len(data) - 1)))
            data[i:i + 1] = bytes([draw(st.integers(0, 255))])
        return bytes(data)
    if kind == "slice":
        i = draw(st.integers(0, len(src)))
        j = draw(st.integers(i, min(len(src), i + 200)))
        return src[:i] + src[j:] if draw(st.booleans()) else src[i:j]
    if kind == "char":
        chars = list(src)
        for _ in range(n):
            i = draw(st.integers(0, len(chars)))
            op = draw(st.sampled_from(["insert", "delete", "replace"]))
            c = draw(st.one_of(st.sampled_from(list("{}()[]|:*'~%,;=.-+^!&\"#\n\\ @")),
                               st.characters(blacklist_categories=("Cs",))))
            if op == "insert":
                chars.insert(i, c)
            elif chars and i < len(chars):
                if op == "delete":
                    del chars[i]
                else:
                    chars[i] = c
        return "".join(chars)
    tokens = TOKEN_RE.findall(src)
    for _ in range(n):
        i = draw(st.integers(0, max(0, len(tokens) - 1)))
        op = draw(st.sampled_from(["delete", "duplicate", "swap", "insert"]))
        if not tokens:
            tokens = [draw(st.sampled_from(VOCAB))]
        elif op == "delete":
            del tokens[i]
        elif op == "duplicate":
            tokens.insert(i, tokens[i])
        elif op == "swap" and i + 1 < len(tokens):
            tokens[i], tokens[i + 1] = tokens[i + 1], tokens[i]
        else:
            tokens.insert(i, draw(st.sampled_from(VOCAB)))
    return " ".join(tokens).replace(" \n ", "\n")


@settings(max_examples=1500, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated())
def test_mutated_grammars_give_only_located_diagnostics(source):
    assert_only_located_errors(source)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(st.sampled_from(VOCAB), max_size=40).map(" ".join))
def test_token_soup(source):
    assert_only_located_errors(source)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.binary(max_size=200))
def test_random_bytes(data):
    assert_only_located_errors(data)


def test_non_utf8_file(tmp_path):
    f = tmp_path / "latin1.grammar"
    f.write_bytes("A --> B\n# caf\u00e9\n".encode("latin-1"))
    with pytest.raises(GrammarError) as e:
        parse(f)
    d = e.value.diagnostics[0]
    assert "not valid UTF-8" in d.message and (d.span.line, d.span.column) == (2, 6)
    assert check(f)[0].code == "encoding"


def test_empty_and_blank_files(tmp_path):
    f = tmp_path / "empty.grammar"
    f.write_text("")
    g = parse(f)
    assert g.statements == () and g.family == "empty"
    assert check(f) == []
    assert parse("\n\n  # only a comment\n\n").statements == ()


def test_huge_file_is_refused_quickly(tmp_path):
    f = tmp_path / "huge.grammar"
    line = "A --> split(x) { 1: B | ~1: C }\n"
    f.write_text(line * (10 * 1024 * 1024 // len(line) + 1))
    t = time.perf_counter()
    with pytest.raises(GrammarError) as e:
        parse(f)
    assert time.perf_counter() - t < 2
    d = e.value.diagnostics[0]
    assert "too large" in d.message and d.span.file == str(f)
    # the limit is a parameter
    with pytest.raises(GrammarError):
        parse(line * 100, max_bytes=1000)


def test_unreadable_path(tmp_path):
    with pytest.raises(GrammarError) as e:
        parse(tmp_path / "nope.grammar")
    assert "cannot read" in e.value.diagnostics[0].message


@pytest.mark.parametrize("make", [
    lambda n: "const c = " + "(" * n + "1" + ")" * n,
    lambda n: "A --> " + "[ " * n + "B" + " ]" * n,
    lambda n: "A --> split(x) { " + "{ " * n + "1: B" + " }*" * n + " }",
    lambda n: "const c = " + "f(" * n + "1" + ")" * n,
    lambda n: "A --> " + "(case x: " * n + "B" + ")" * n,
])
def test_deep_nesting_is_a_clear_error(make):
    src = make(5000)
    with pytest.raises(GrammarError) as e:
        parse(src)
    d = e.value.diagnostics[0]
    assert "nested too deeply" in d.message and d.span.line == 1
    parse(make(10))  # moderate nesting is fine


@pytest.mark.parametrize("src", [
    "const c = " + " + ".join(["1"] * 3000),
    "const c = " + "-" * 3000 + "1",
    "const c = " + " ^ ".join(["2"] * 3000),
    "const c = " + " && ".join(["!a"] * 3000),
])
def test_long_operator_chains_do_not_recurse(src):
    with pytest.raises(GrammarError) as e:
        parse(src)
    assert "nested too deeply" in e.value.diagnostics[0].message


def test_long_flat_files_are_fine():
    src = "".join(f"R{i} --> extrude({i}) split(y) {{ 1: R{i + 1} | ~1: W. }}\n" for i in range(600))
    g = parse(src)
    assert len(g.rules) == 600
    assert parse(print_grammar(g)) == g


def test_nesting_limit_is_generous_enough():
    parse("const c = " + "(" * (MAX_NESTING - 1) + "1" + ")" * (MAX_NESTING - 1))
