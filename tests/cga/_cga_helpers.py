"""Helpers shared by the importer tests: translate CGA text (which must succeed) and pick one
rule's line of the translation."""
from __future__ import annotations

from grammarkit.cga import translate_cga

LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def imported(text: str, **kw):
    result = translate_cga(text, filename="t.cga", **kw)
    assert result.ok, [d.format(text) for d in result.diagnostics]
    return result


def line(result, rule: str) -> str:
    return next(ln for ln in result.text.splitlines() if ln.startswith(rule + " -->"))
