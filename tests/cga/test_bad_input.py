"""Malformed CGA: located errors, never a traceback (including fuzzed input)."""
from __future__ import annotations

import random
from pathlib import Path

import pytest

from grammarkit.cga import translate_cga

CORPUS = Path(__file__).resolve().parents[2] / "grammars" / "cga"
TOKENS = ["Lot", "-->", "extrude", "(", ")", "{", "}", "|", ":", "~", "'", "*", "split", "x",
          "comp", "f", "case", "else", "%", "30", "0.5", "attr", "const", "=", "@Range", "[",
          "]", '"s"', ",", "NIL", ".", "+", "-", "/", "&&", "==", "scope.sx", "\n", "#c\n",
          "/*", "*/", "import", "version", "A", "B", "t", "s", "r", "i", "color", ";"]


def errors_are_located(result, text):
    for d in result.diagnostics:
        assert d.severity in ("error", "warning", "note")
        if d.severity == "error":
            assert d.span is not None and d.span.file == "f.cga", d
            if d.code not in ("cga-check-failed",):
                assert d.span.line >= 1 and d.span.column >= 1, d
        d.format(text)  # never raises


@pytest.mark.parametrize("text, line, col, words", [
    ("Lot --> extrude(3\nA --> X.\n", 2, 1, "unexpected rule head"),
    ("attr h = \nLot --> X.\n", 2, 7, "unexpected '>'"),
    ('Lot --> color("#fff)\n', 1, 15, "unterminated string"),
    ("Lot --> split(x) { 1: A | }\n", 1, 27, "unexpected '}'"),
    ("Lot --> case a > 1: A\n", 2, 1, "end of file"),
])
def test_syntax_errors_are_located(text, line, col, words):
    result = translate_cga(text, filename="f.cga")
    assert not result.ok and result.text is None
    err = [d for d in result.diagnostics if d.severity == "error"][0]
    assert (err.span.line, err.span.column) == (line, col)
    assert words in err.message
    assert err.format(text).startswith(f"f.cga:{line}:{col}: error: CGA syntax error")


def test_deep_nesting_and_binary_input():
    deep = "Lot --> extrude(" + "(" * 200 + "1" + ")" * 200 + ") X.\n"
    r = translate_cga(deep, filename="f.cga")
    assert not r.ok and "nested too deeply" in r.diagnostics[0].message
    r = translate_cga(b"Lot --> X.\x00\x01", filename="f.cga")
    assert not r.ok and r.diagnostics[0].code == "encoding"
    long_chain = "Lot --> extrude(" + "+".join(["1"] * 3000) + ") X.\n"
    r = translate_cga(long_chain, filename="f.cga")
    errors_are_located(r, long_chain)


def test_no_rules_is_an_error():
    r = translate_cga("attr a = 1\n", filename="f.cga")
    assert not r.ok and r.diagnostics[-1].code == "cga-no-rules"


def _fuzz_cases(n: int, seed: int):
    rng = random.Random(seed)
    files = sorted(CORPUS.glob("*.cga"))
    texts = [p.read_text(encoding="utf-8") for p in files]
    for k in range(n):
        kind = k % 3
        if kind == 0:  # a real file, mutated
            t = list(rng.choice(texts)[:4000])
            for _ in range(rng.randint(1, 8)):
                pos = rng.randrange(len(t))
                op = rng.random()
                if op < 0.4:
                    del t[pos:pos + rng.randint(1, 5)]
                elif op < 0.8:
                    t.insert(pos, rng.choice("{}()[]|:~'*%=\".#\n-"))
                else:
                    t[pos] = chr(rng.randrange(32, 127))
            yield "".join(t)
        elif kind == 1:  # a token soup
            yield " ".join(rng.choice(TOKENS) for _ in range(rng.randint(1, 60)))
        else:  # random bytes
            yield bytes(rng.randrange(256) for _ in range(rng.randint(0, 200)))


@pytest.mark.parametrize("seed", [0, 1])
def test_fuzz_only_located_diagnostics(seed):
    for case in _fuzz_cases(60, seed):
        result = translate_cga(case, filename="f.cga")
        text = result.source
        errors_are_located(result, text)
        if result.ok:
            assert result.text and result.report.checks
