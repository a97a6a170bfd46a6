"""Built-in expression functions, registered through the plugin hook like any plugin's.

Functions are pure, except `rand` and `fileRandom`, which draw from the random generator that
the evaluator passes as `rng` (the shape's own seeded generator, so results are reproducible),
and CGA's file functions `fileSearch`, `fileRandom`, `fileExists`, which look at the files
beside the grammar file that says them (the evaluator passes that folder; see `FILE_FUNCTIONS`).
Footprint constructors (`rect`, `polygon`, `lshape`, `ushape`) return plain tuples of 2D
points: the DSL and the evaluator stay free of geometry; the split engine builds solids.
"""
from __future__ import annotations

import fnmatch
import math
import os
import re
from pathlib import Path
from typing import Any, Iterable

from . import confine
from .hookspecs import hookimpl
from .registry import BUILTIN_ASSET_NAMES, FunctionSpec

Point = tuple[float, float]


def _rand(rng: Any, lo: float = 0.0, hi: float = 1.0) -> float:
    return float(lo + (hi - lo) * rng.random())


def _clamp(x: float, lo: float, hi: float) -> float:
    return max(lo, min(hi, x))


def rect(width: float, depth: float) -> tuple[Point, ...]:
    """Axis-aligned rectangle with a corner at the origin, counter-clockwise."""
    return ((0.0, 0.0), (width, 0.0), (width, depth), (0.0, depth))


def lshape(width: float, depth: float, wing_width: float, wing_depth: float) -> tuple[Point, ...]:
    """An L: a `width` x `wing_depth` bar along x plus a `wing_width` x `depth` bar along y."""
    return ((0.0, 0.0), (width, 0.0), (width, wing_depth), (wing_width, wing_depth),
            (wing_width, depth), (0.0, depth))


def ushape(width: float, depth: float, wing_width: float, base_depth: float) -> tuple[Point, ...]:
    """A U open towards +y: a base bar and two wings of `wing_width`."""
    return ((0.0, 0.0), (width, 0.0), (width, depth), (width - wing_width, depth),
            (width - wing_width, base_depth), (wing_width, base_depth), (wing_width, depth),
            (0.0, depth))


def polygon(*coords: float) -> tuple[Point, ...]:
    """`polygon(x1, y1, x2, y2, ...)`: a simple polygon from flat coordinates."""
    if len(coords) % 2 or len(coords) < 6:
        raise ValueError("polygon() needs an even number of coordinates, at least 3 points")
    return tuple((float(coords[i]), float(coords[i + 1])) for i in range(0, len(coords), 2))


# -- CGA's text helpers (the CGA utility library) --------------------------------------------
def get_range(s: str, left: str, right: str) -> str:
    """CGA's getRange: the text from the end of the first `left` to the beginning of the last
    `right` ("" when either is missing or they overlap, as the CGA reference's examples)."""
    s, left, right = str(s), str(left), str(right)
    i, j = s.find(left), s.rfind(right)
    if i < 0 or j < 0 or j < i + len(left):
        return ""
    return s[i + len(left):j]


def get_prefix(s: str, match: str) -> str:
    """CGA's getPrefix: `s` up to the first `match` ("" when there is none)."""
    s, match = str(s), str(match)
    i = s.find(match) if match else -1
    return s[:i] if i >= 0 else ""


def get_suffix(s: str, match: str) -> str:
    """CGA's getSuffix: the rest of `s` after the last `match` ("" when there is none)."""
    s, match = str(s), str(match)
    i = s.rfind(match) if match else -1
    return s[i + len(match):] if i >= 0 else ""


def count_matches(s: str, match: str) -> int:
    """CGA's count: how many times `match` occurs in `s` (not overlapping; 0 for an empty match)."""
    s, match = str(s), str(match)
    return s.count(match) if match else 0


def find_first(s: str, match: str) -> int:
    return str(s).find(str(match))


def find_last(s: str, match: str) -> int:
    return str(s).rfind(str(match))


# -- CGA's file functions ----------------------------------------------------------------------
# fileName/fileBasename/fileDirectory/fileExtension are pure text functions of a path;
# fileSearch/fileRandom/fileExists look at the files beside the grammar: the evaluator binds
# them to the folder of the grammar file that says the expression (as constant i() paths are
# resolved) and to the shape's random generator (fileRandom).

MAX_FILE_SEARCH = 10_000  # files a fileSearch may walk through (a grammar beside a home folder)


class TooManyFiles(ValueError):
    """A file search would walk through more than MAX_FILE_SEARCH files."""


def _slashes(path: Any) -> str:
    return str(path).replace("\\", "/")


def file_name(path: str) -> str:
    """CGA's fileName: "assets/obj/a.01.obj" -> "a.01.obj"."""
    return _slashes(path).rsplit("/", 1)[-1]


def file_basename(path: str) -> str:
    """CGA's fileBasename: "assets/obj/a.01.obj" -> "a.01"."""
    name = file_name(path)
    return name.rsplit(".", 1)[0] if "." in name.lstrip(".") else name


def file_directory(path: str) -> str:
    """CGA's fileDirectory: "assets/obj/a.01.obj" -> "assets/obj/" (with the slash; "" if none)."""
    p = _slashes(path)
    return p[:p.rfind("/") + 1]


def file_extension(path: str) -> str:
    """CGA's fileExtension: "assets/obj/a.01.obj" -> "obj" (without the dot; "" if none)."""
    name = file_name(path)
    return name.rsplit(".", 1)[1] if "." in name.lstrip(".") else ""


def project_folder(base: Path) -> Path:
    """The folder file searches start from: the grammar's folder, or its parent when the
    grammar sits in a CityEngine project's `rules/` folder (an `assets/` folder beside it and
    none inside it)."""
    if not (base / "assets").is_dir() and confine.allows(base.parent) and (base.parent / "assets").is_dir():
        return base.parent
    return base


def _walk(root: Path) -> list[str]:
    """Paths (relative, with /) of the files under `root`, hidden folders and files skipped;
    a ValueError beyond MAX_FILE_SEARCH files."""
    out: list[str] = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        rel = Path(folder).relative_to(root).as_posix()
        prefix = "" if rel == "." else rel + "/"
        for f in files:
            if f.startswith("."):
                continue
            out.append(prefix + f)
            if len(out) > MAX_FILE_SEARCH:
                raise TooManyFiles(f"more than {MAX_FILE_SEARCH:,} files under {root} (the search "
                                 "is limited; keep the grammar's assets in a smaller folder)")
    return out


def _term_matcher(term: str, project: str) -> Any:
    """A predicate (candidate paths, name, extension) -> bool for one query term."""
    for key in ("Name=", "Ext=", "Path=", "Project="):
        if term.startswith(key):
            pattern = term[len(key):]
            if key == "Name=":
                return lambda paths, name, ext: fnmatch.fnmatchcase(name, pattern)
            if key == "Ext=":
                return lambda paths, name, ext: fnmatch.fnmatchcase(ext, pattern.lstrip("."))
            if key == "Project=":
                return lambda paths, name, ext: fnmatch.fnmatchcase(project, pattern)
            term = pattern
    if term.startswith("$"):
        try:
            rx = re.compile(term[1:])
        except re.error as exc:
            raise ValueError(f"bad regular expression {term[1:]!r}: {exc}") from None
        return lambda paths, name, ext: any(rx.fullmatch(p) for p in paths)
    pattern = term.lstrip("/")
    return lambda paths, name, ext: any(fnmatch.fnmatchcase(p, pattern) for p in paths)


def search_files(query: str, base: "str | Path") -> list[str]:
    """The files of CGA's `fileSearch(query)`, sorted, as absolute paths with /.

    A file matches when every whitespace-separated term of the query does (CGA: whitespace is
    AND). A term is a wildcard pattern (`*` any characters, `/` included; `?` one character)
    or, after `$`, a regular expression, matched against the file's path relative to the
    project folder and, for files in its `assets/` folder, relative to that folder (CGA's
    search order); a leading `/` is dropped. `Name=`, `Ext=`, `Path=`, `Project=` match the
    file name, the extension, the path, the project folder's name."""
    project = project_folder(Path(base).resolve())
    confine.check(project, what="fileSearch folder")  # the folder it walks (fileRandom searches too)
    terms = str(query).split()
    if not terms:
        return []
    matchers = [_term_matcher(t, project.name) for t in terms]
    found = []
    for rel in _walk(project):
        paths = [rel, f"{project.name}/{rel}"]
        if rel.startswith("assets/"):
            paths.append(rel[len("assets/"):])
        name = rel.rsplit("/", 1)[-1]
        ext = file_extension(name)
        if all(m(paths, name, ext) for m in matchers):
            found.append((project / rel).as_posix())
    return sorted(found)


def file_random(rng: Any, files: list[str]) -> str:
    """CGA's fileRandom: one of `files` (sorted), drawn with the shape's generator; "" when
    there is none. One number is drawn either way, so that the random values drawn after it
    do not depend on how many files there are."""
    u = rng.random()
    return files[int(u * len(files))] if files else ""


def file_exists(path: str, base: "str | Path") -> bool:
    """CGA's fileExists: whether `path` (relative to `base`, or absolute) is a file, or one of
    the built-in assets (`builtin:cube`, ...)."""
    p = _slashes(path)
    if p.startswith("builtin:"):
        return p[len("builtin:"):] in BUILTIN_ASSET_NAMES
    if not p:
        return False
    q = Path(p)
    confine.check(p, base=base, what="file")  # refused whether or not the file exists
    return (q if q.is_absolute() else Path(base) / q).is_file()


BUILTIN_FUNCTIONS: tuple[FunctionSpec, ...] = (
    FunctionSpec("rand", 0, 2, "rand() in [0,1), rand(hi) in [0,hi), rand(lo, hi) in [lo,hi)", None),
    FunctionSpec("min", 1, None, "smallest argument", min),
    FunctionSpec("max", 1, None, "largest argument", max),
    FunctionSpec("floor", 1, 1, "round down", math.floor),
    FunctionSpec("ceil", 1, 1, "round up", math.ceil),
    FunctionSpec("round", 1, 1, "round half away from zero",
                 lambda x: math.floor(x + 0.5) if x >= 0 else -math.floor(-x + 0.5)),
    FunctionSpec("abs", 1, 1, "absolute value", abs),
    FunctionSpec("sqrt", 1, 1, "square root", math.sqrt),
    FunctionSpec("sin", 1, 1, "sine of degrees", lambda d: math.sin(math.radians(d))),
    FunctionSpec("cos", 1, 1, "cosine of degrees", lambda d: math.cos(math.radians(d))),
    FunctionSpec("tan", 1, 1, "tangent of degrees", lambda d: math.tan(math.radians(d))),
    FunctionSpec("clamp", 3, 3, "clamp(x, lo, hi)", _clamp),
    # conditional values (CGA's case and stochastic expressions); the evaluator evaluates only
    # the chosen argument (see expr_eval: LAZY_FUNCTIONS), so `select(x == 0, 0, 1 / x)` is safe
    FunctionSpec("select", 3, 3, "select(cond, a, b): a if cond holds, else b", None),
    FunctionSpec("pick", 2, None, "pick(u, p1, v1, p2, v2, ..., other): v_k for the first k with "
                 "u < p1 + ... + pk (percentages), else other; pick(rand(0, 100), 30, a, b)", None),
    FunctionSpec("rect", 2, 2, "rect(width, depth): rectangular footprint", rect),
    FunctionSpec("lshape", 4, 4, "lshape(width, depth, wing_width, wing_depth): L footprint", lshape),
    FunctionSpec("ushape", 4, 4, "ushape(width, depth, wing_width, base_depth): U footprint", ushape),
    FunctionSpec("polygon", 6, None, "polygon(x1, y1, x2, y2, ...): simple polygon footprint", polygon),
    # CGA's text helpers
    FunctionSpec("getRange", 3, 3, "getRange(s, left, right): the text between left and the next right",
                 get_range),
    FunctionSpec("getPrefix", 2, 2, "getPrefix(s, match): s up to the first match", get_prefix),
    FunctionSpec("getSuffix", 2, 2, "getSuffix(s, match): s after the last match", get_suffix),
    FunctionSpec("findFirst", 2, 2, "findFirst(s, match): index of the first match, or -1", find_first),
    FunctionSpec("findLast", 2, 2, "findLast(s, match): index of the last match, or -1", find_last),
    FunctionSpec("count", 2, 2, "count(s, match): how many times match occurs in s", count_matches),
    # CGA's file functions (fileSearch, fileRandom, fileExists: bound by the evaluator)
    FunctionSpec("fileName", 1, 1, "fileName(path): the file name without its folder", file_name),
    FunctionSpec("fileBasename", 1, 1, "fileBasename(path): the file name without folder and extension",
                 file_basename),
    FunctionSpec("fileDirectory", 1, 1, "fileDirectory(path): the folder part, ending in /", file_directory),
    FunctionSpec("fileExtension", 1, 1, "fileExtension(path): the extension without the dot", file_extension),
    FunctionSpec("fileSearch", 1, 1, "fileSearch(query): the matching files beside the grammar, sorted, "
                 "as a CGA list \"a;b;\" (wildcards * ?, $regex, Name= Ext= Path=)", None),
    FunctionSpec("fileRandom", 1, 1, "fileRandom(query): one of fileSearch(query)'s files, drawn with "
                 "the shape's random generator, or \"\"", None),
    FunctionSpec("fileExists", 1, 1, "fileExists(path): whether the file exists (relative to the grammar)",
                 None),
)

# fileSearch/fileRandom/fileExists need the grammar's folder (and fileRandom the shape's
# generator); the evaluator binds them (see expr_eval).
FILE_FUNCTIONS = frozenset({"fileSearch", "fileRandom", "fileExists"})

# `rand` needs the shape's generator; the evaluator binds it (see expr_eval).
RANDOM_FUNCTIONS = {"rand": _rand}


@hookimpl
def grammarkit_functions() -> Iterable[FunctionSpec]:
    return BUILTIN_FUNCTIONS
