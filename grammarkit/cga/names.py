"""CGA identifiers -> grammarkit identifiers.

CGA allows dotted names (`Plant.Generate`, qualified by an import) and names that are
grammarkit keywords (`part`, `site`, `default`, `in`, ...). Dots become underscores and a
keyword gets a trailing underscore, so every printed name reads back as the same name.
"""
from __future__ import annotations

import re

from ..dsl.parser import KEYWORDS

# grammarkit's reserved words, the parser's own list (importing dsl.parser builds no tables:
# get_parser() does that lazily), so a new keyword such as asset_dir is escaped here too.
GK_KEYWORDS = KEYWORDS

_BAD = re.compile(r"[^A-Za-z0-9_]")


def gk_name(name: str) -> str:
    out = _BAD.sub("_", name.replace(".", "_")) or "_"
    if out[0].isdigit():
        out = "_" + out
    return out + "_" if out in GK_KEYWORDS else out
