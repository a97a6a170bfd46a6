"""Where a relative asset name (i(), texture(), `set(material.colormap, ...)`) is found, as
docs/operations.md "Assets" says: the folder of the grammar file that names it, then each
`asset_dir` of the grammar (INTERFACES.md item 1), in declaration order. The first folder
holding a file of that name wins; when none does, the name stays relative to the first folder
(so the error names the file where the grammar says it is)."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from .. import confine


def asset_dirs_of(grammar: Any, base_dir: str | None) -> tuple[str, ...]:
    """The grammar's `asset_dir` folders as absolute paths (relative ones are relative to the
    grammar file's folder, or the working folder for grammar text without a file)."""
    base = Path(base_dir) if base_dir else Path(".")
    return tuple(str((base / d).resolve()) for d in getattr(grammar, "asset_dirs", ()) or ())


# answers per (name, folder, asset_dirs): a computed name (a texture set per shape) is looked
# up thousands of times a derivation, so each is asked of the file system once per process (as
# the texture check and the asset loader do: a file appearing later is not looked for again)
_FOUND: dict[tuple, str] = {}
MAX_FOUND = 4096


def find_asset(name: str, base: Path, asset_dirs: tuple[str, ...]) -> str:
    """The absolute path of asset `name` (absolute names and `builtin:` ones as they are)."""
    if not name or name.startswith("builtin:"):
        return name
    key = (name, base, asset_dirs, confine.current())  # a folder outside a policy is never found
    hit = _FOUND.get(key)
    if hit is not None:
        return hit
    path = _search(name, base, asset_dirs)
    if len(_FOUND) >= MAX_FOUND:
        _FOUND.clear()
    _FOUND[key] = path
    return path


def _search(name: str, base: Path, asset_dirs: tuple[str, ...]) -> str:
    if Path(name).is_absolute():
        return str(Path(name).resolve())
    first = (base / name).resolve()
    if not asset_dirs or (confine.allows(first) and first.is_file()):
        return str(first)
    for folder in asset_dirs:
        candidate = Path(folder) / name
        # a candidate outside the studio's folder is passed over before anything looks at it
        # (its existence is not told); the caller checks the path it is given
        if confine.allows(candidate) and candidate.is_file():
            return str(candidate.resolve())
    return str(first)


def resolving(fn: Callable[[Any], Any], base: Path, asset_dirs: tuple[str, ...]) -> Callable[[Any], Any]:
    """An argument function whose string values (a name computed from attrs, consts, rule
    arguments, fileRandom) are looked up as `find_asset` does, when the shape is derived."""
    def resolved(s: Any) -> Any:
        value = fn(s)
        return find_asset(value, base, asset_dirs) if isinstance(value, str) else value
    return resolved
