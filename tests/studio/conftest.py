"""Fixtures of the studio tests (helpers in _studio.py)."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studio import browser, paris_copy, studio  # noqa: E402,F401 - fixtures
