"""A NUL character in a grammar path (Python API) is a located error naming the file, not a bare
`ValueError: embedded null byte` (issue 31)."""
from __future__ import annotations

import pytest

import grammarkit
from grammarkit.errors import GrammarError


@pytest.mark.parametrize("call", [grammarkit.derive, grammarkit.parse, grammarkit.check])
def test_a_nul_in_the_path_is_a_clear_error(call):
    try:
        result = call("/tmp/a\0b.grammar")
    except GrammarError as exc:
        text = str(exc)
    else:  # check() returns diagnostics instead of raising
        text = "\n".join(d.format() for d in result)
    assert "the path contains a NUL character" in text and "a\\0b.grammar" in text
