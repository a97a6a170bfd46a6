"""CGA identifiers -> grammarkit identifiers.

CGA allows dotted names (`Plant.Generate`, qualified by an import) and names that are
grammarkit keywords (`part`, `site`, `default`, `in`, ...). Dots become underscores and a
keyword gets a trailing underscore, so every printed name reads back as the same name.
"""
from __future__ import annotations

import re

# grammarkit's reserved words (docs/language.md); kept here so that importing the CGA
# translator does not load the .grammar parser.
GK_KEYWORDS = frozenset({
    "grammar", "import", "attr", "const", "func", "snippet", "use", "as", "default", "for", "variants",
    "case", "else", "NIL", "true", "false", "part", "site", "at", "facing", "mirror", "dock",
    "rot", "neighbors", "in", "constraint", "example",
})

_BAD = re.compile(r"[^A-Za-z0-9_]")


def gk_name(name: str) -> str:
    out = _BAD.sub("_", name.replace(".", "_")) or "_"
    if out[0].isdigit():
        out = "_" + out
    return out + "_" if out in GK_KEYWORDS else out
