"""The library a models file was trained on, carried inside the file.

A models file stores the library's source text and the part meshes its snippets insert (a few
KB), so that `recognize(image, "Roof")` needs no library path and no download: the first use
writes them (atomically) to a folder named after the library's hash in the sketch cache, and
loads the library from there, where its relative `i("parts/...")` paths resolve. The hash is
checked again after loading.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

from grammarkit.errors import GrammarkitError

from .dataset import DEFAULT_CACHE
from .library import SnippetLibrary, _asset_paths, load_library
from .models import ModelFileError, SketchModels


def library_files(library: SnippetLibrary) -> dict[str, bytes]:
    """{relative path: bytes} of the library file and the part files it inserts, or {} when the
    library cannot be carried (no file, imports, parts outside its folder)."""
    if not library.path or library.grammar.imports:
        return {}
    src = Path(library.path).resolve()
    base = src.parent
    files = {src.name: src.read_bytes()}
    try:
        text = src.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return {}
    if "import " in text and any(line.lstrip().startswith("import ") for line in text.splitlines()):
        return {}  # imported files would be needed too: use the library path instead
    for p in _asset_paths(library.grammar):
        try:
            rel = p.resolve().relative_to(base)
        except ValueError:
            return {}
        if not p.is_file():
            return {}
        files[rel.as_posix()] = p.read_bytes()
    return files


def embedded_library(models: SketchModels, cache: Path | None = None) -> SnippetLibrary:
    """The library stored in a models file, written out once under the cache and loaded."""
    from grammarkit.fileio import atomic_output

    files = models.library_files
    main = models.meta.get("library_file")
    if not files or main not in files:
        raise ModelFileError(f"{models.path or 'the models'}: the models file does not carry its "
                             "library; pass the library it was trained on (--library / library=)",
                             None, code="sketch-need-library")
    # the folder is named after the files' real content, not the hash the models file claims:
    # a tampered file then gets a folder of its own and cannot overwrite the shared copy
    root = Path(cache or DEFAULT_CACHE) / "libraries" / content_hash(files)[:20]
    for rel, data in files.items():
        target = (root / rel).resolve()
        if root.resolve() not in target.parents:
            raise ModelFileError(f"{models.path}: bad library file name {rel!r} in the models file",
                                 None, code="sketch-bad-models")
        if target.is_file() and target.read_bytes() == data:
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(target) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(data)
    try:
        library = load_library(root / main)
    except GrammarkitError as exc:
        raise ModelFileError(f"{models.path or 'the models'}: the library carried in the models "
                             f"file is damaged and cannot be read ({str(exc).splitlines()[0]}); "
                             "retrain, or pass the library it was trained on (--library / "
                             "library=)", None, code="sketch-bad-models") from None
    if library.hash != models.library_hash:
        raise ModelFileError(f"{models.path or 'the models'}: the library carried in the models "
                             "file does not match the hash the file records (the file was edited "
                             "or damaged); retrain, or pass the library it was trained on "
                             "(--library / library=)", None, code="sketch-bad-models")
    return library


def content_hash(files: dict[str, bytes]) -> str:
    """SHA-256 of the carried files (names and bytes, in name order)."""
    h = hashlib.sha256()
    for rel in sorted(files):
        data = files[rel]
        h.update(rel.encode("utf-8") + b"\0" + str(len(data)).encode() + b"\0")
        h.update(data)
    return h.hexdigest()

