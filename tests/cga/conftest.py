"""The importer tests' shared helpers (`_cga_helpers`) are imported by name: with
`--import-mode=importlib` the test folder is not on sys.path by itself."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
