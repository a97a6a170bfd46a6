"""CGA's `readStringTable` / `readFloatTable` files, read while importing.

The file is looked up as CityEngine looks up an asset (beside the rule file, the project's
`assets/`, imported projects: project.Project.resolve) and read as CSV: cells separated by
`,` or, when a line has none, `;` (CityEngine accepts both; the first line decides), rows
of different lengths padded with empty cells by the caller.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

__all__ = ["MAX_TABLE_BYTES", "find_table", "read_table"]

MAX_TABLE_BYTES = 8 << 20  # a table is written into the grammar: keep it a table, not a data set


def find_table(name: str, rule_file: str | None, project: Any, asset_dirs: tuple[Path, ...] = ()) -> Path | None:
    base = Path(rule_file).parent if rule_file else Path(".")
    if project is not None and getattr(project, "root", None) is not None:
        found = project.resolve(name, relative_to=base)
        if found is not None:
            return found
    for folder in (base, *asset_dirs):
        cand = folder / name.lstrip("/")
        if cand.is_file():
            return cand
    return None


def read_table(path: Path) -> list[list[str]]:
    """The rows of cells of a CSV table; ValueError if it is too large or not text."""
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        raise ValueError(f"{path}: {size} bytes, more than the {MAX_TABLE_BYTES} a table may have")
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    lines = [ln for ln in text.splitlines() if ln.strip()]
    delimiter = "," if not lines or "," in lines[0] or ";" not in lines[0] else ";"
    return [row for row in csv.reader(io.StringIO("\n".join(lines)), delimiter=delimiter)]
