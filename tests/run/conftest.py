"""Fixtures shared by the run-layer tests."""
from __future__ import annotations

import pytest

SMALL = """grammar small
attr h = 6 @range(3, 12)
Lot --> footprint(rect(8, 6)) extrude(h) Mass.
"""


@pytest.fixture
def small(tmp_path):
    """A one-box split grammar file (fast to derive)."""
    p = tmp_path / "small.grammar"
    p.write_text(SMALL)
    return p
