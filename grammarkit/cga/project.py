"""CityEngine projects and rule packages as import input, and CityEngine's asset lookup.

A CityEngine project is a folder with `rules/` (the .cga files) and `assets/` (meshes,
textures), in a workspace beside other projects (`ESRI.lib`, ...). A rule package (`.rpk`)
is an archive of the same thing: `rules/`, `bin/` (compiled .cgb), `assets/`, and the
projects it imports under `.ws/<project>/`. Most .rpk files are 7z archives (read with the
optional `py7zr`, `pip install grammarkit[cga]`); some are zip archives (read with the
standard library).

CityEngine resolves an asset or import name (literal or computed) against the rule file's
project: a relative name relative to the rule file's folder, the project folder and its
`assets/`, then the imported projects (and their `assets/`); a name like
`/ESRI.lib/assets/x.obj` is a workspace path (project `ESRI.lib`, then `assets/x.obj`).
`Project.resolve` does the same; `Project.search_dirs` lists those folders in that order
(the importer writes them as the grammar's `asset_dir` lines).
"""
from __future__ import annotations

import re
import shutil
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Project", "ProjectError", "open_input", "find_project_root"]

# Bound the work of unpacking an archive (a rule package is a few MB; candler's is 1.1 MB).
MAX_ARCHIVE_FILES = 20_000
MAX_ARCHIVE_BYTES = 512 * 1024 * 1024


class ProjectError(ValueError):
    """A project, package or rule file that cannot be used (the message says which and why)."""


@dataclass
class Project:
    rule_file: Path                                 # the .cga to translate
    root: Path | None = None                        # the project folder (has rules/), if any
    imported: tuple[Path, ...] = ()                 # roots of the projects it imports
    names: tuple[str, ...] = ()                     # the project's own names in workspace paths
    extracted_to: Path | None = None                # where an .rpk was unpacked
    rules: tuple[Path, ...] = field(default=())     # every .cga of the project (for messages)

    def search_dirs(self) -> list[Path]:
        """The folders a relative name is looked up in, in CityEngine's order (no repeats)."""
        out: list[Path] = [self.rule_file.parent]
        for root in ((self.root,) if self.root else ()) + self.imported:
            out += [root, root / "assets"]
        seen: set[Path] = set()
        return [d for d in out if d.is_dir() and not (d.resolve() in seen or seen.add(d.resolve()))]

    def workspace_projects(self) -> dict[str, Path]:
        """Project name -> folder, for workspace paths (`/ESRI.lib/assets/x.obj`)."""
        out: dict[str, Path] = {}
        if self.root is not None:
            for name in (self.root.name, *self.names):
                out[name] = self.root
        for root in self.imported:
            out.setdefault(root.name, root)
        return out

    def workspace_project(self, name: str) -> Path | None:
        """The folder of the project `name` (the project itself, an imported or a sibling one)."""
        if self.root is not None and (name == self.root.name or name in self.names):
            return self.root
        for root in self.imported:
            if root.name == name:
                return root
        if self.root is not None:
            for cand in (self.root / ".ws" / name, self.root.parent / name):
                if cand.is_dir():
                    return cand
        return None

    def resolve(self, name: str, relative_to: Path | None = None) -> Path | None:
        """The file an asset or import name refers to, as CityEngine resolves it, or None."""
        if not name or name.startswith("builtin:"):
            return None
        candidates: list[Path] = []
        if name.startswith("/"):
            first, _, rest = name.lstrip("/").partition("/")
            proj = self.workspace_project(first)
            if proj is not None and rest:
                candidates.append(proj / rest)
            name = name.lstrip("/")  # else: try it as a relative name
        if relative_to is not None:
            candidates.append(relative_to / name)
        candidates += [d / name for d in self.search_dirs()]
        for c in candidates:
            if c.is_file():
                return c
        return None


def find_project_root(path: Path) -> Path | None:
    """The CityEngine project folder above a rule file: the folder whose `rules/` holds it."""
    p = path.resolve()
    for parent in p.parents:
        if parent.name == "rules" and parent.parent != parent:
            return parent.parent
    return None


def _imported_projects(root: Path) -> tuple[Path, ...]:
    ws = root / ".ws"
    return tuple(sorted(p for p in ws.iterdir() if p.is_dir())) if ws.is_dir() else ()


def _resolvemap_names(root: Path) -> tuple[str, ...]:
    """The project's own names in the workspace paths of a package's .resolvemap.xml
    (`/rpk/assets/...`, `/green_optimization_3/rules/...` for entries inside the package)."""
    f = root / ".resolvemap.xml"
    if not f.is_file():
        return ()
    text = f.read_text(encoding="utf-8", errors="replace")[:2_000_000]
    names = set()
    for key, value in re.findall(r'key="/([^/"]+)/[^"]*"\s+value="([^"]*)"', text):
        # a value may carry a reader's scheme (`gltf:.ws/ESRI.lib/x.glb!/...` for a texture
        # inside a glTF): the entry is still the imported project's
        value = re.sub(r"^[A-Za-z][A-Za-z0-9+]*:(?!/)", "", value)
        if not value.startswith(".ws/"):
            names.add(key)
    # a project the package carries under .ws/ is an imported one, never the package itself
    return tuple(sorted(n for n in names if not (root / ".ws" / n).is_dir()))


def _choose_rule(root: Path, rule: str | None, stem_hint: str | None) -> tuple[Path, tuple[Path, ...]]:
    rules_dir = root / "rules"
    found = tuple(sorted(rules_dir.rglob("*.cga"))) if rules_dir.is_dir() else ()
    if not found:
        raise ProjectError(f"{root}: no rules/*.cga in this project or package (a rule package "
                           "exported without its sources cannot be imported)")
    if rule is not None:
        hits = [p for p in found if p.relative_to(rules_dir).as_posix() == rule.lstrip("/")
                or p.name == rule or p.stem == rule]
        if not hits:
            raise ProjectError(f"{root}: no rule file {rule!r}; the rule files are: "
                               + ", ".join(p.relative_to(rules_dir).as_posix() for p in found))
        return hits[0], found
    if len(found) == 1:
        return found[0], found
    # the package's compiled start file names its rule file (bin/<name>.cgb)
    compiled = {p.stem for p in (root / "bin").rglob("*.cgb")} if (root / "bin").is_dir() else set()
    for hint in ([stem_hint] if stem_hint else []) + sorted(compiled):
        hits = [p for p in found if p.stem == hint]
        if len(hits) == 1:
            return hits[0], found
    # a package with sources only (no bin/): the one rule file no other rule file imports is
    # the set's entry (envelope2002.cga imports facade, volume0110, ... and none imports it)
    tops = _not_imported(found)
    if len(tops) == 1:
        return tops[0], found
    raise ProjectError(f"{root}: several rule files, choose one with --rule: "
                       + ", ".join(p.relative_to(rules_dir).as_posix() for p in found))


_IMPORT = re.compile(r'^[ \t]*import\s+(?:[A-Za-z_][A-Za-z0-9_]*\s*:\s*)?"([^"\n]+)"', re.M)


def _not_imported(found: tuple[Path, ...]) -> list[Path]:
    """The rule files that no other one of `found` imports (matched by file name, as the
    workspace paths of imports name files of other projects too)."""
    imported: set[str] = set()
    for f in found:
        try:
            text = f.read_text(encoding="utf-8", errors="replace")[:1_000_000]
        except OSError:
            continue
        imported.update(Path(m).name for m in _IMPORT.findall(text) if Path(m).name != f.name)
    return [f for f in found if f.name not in imported]


def _extract(archive: Path, dest: Path) -> None:
    """Unpack a 7z or zip rule package into `dest` (replacing an earlier unpacking of it)."""
    with archive.open("rb") as fh:
        magic = fh.read(6)
    tmp = dest.with_name(dest.name + ".part")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    try:
        if magic[:4] == b"PK\x03\x04":
            with zipfile.ZipFile(archive) as z:
                infos = z.infolist()
                _check_members([(i.filename, i.file_size) for i in infos], archive)
                z.extractall(tmp)
        elif magic == b"7z\xbc\xaf\x27\x1c":
            try:
                import py7zr
            except ImportError:
                raise ProjectError(f"{archive}: a 7z rule package needs the optional py7zr reader "
                                   "(`pip install grammarkit[cga]` or `pip install py7zr`), or unpack "
                                   "it and import the folder") from None
            with py7zr.SevenZipFile(archive, mode="r") as z:
                members = [(i.filename, i.uncompressed or 0) for i in z.list()]
                _check_members(members, archive)
                z.extractall(path=tmp)
        else:
            raise ProjectError(f"{archive}: not a rule package (neither a 7z nor a zip archive)")
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise ProjectError(f"{archive}: cannot unpack the rule package ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - py7zr raises its own types for corrupt archives
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, ProjectError):
            raise
        raise ProjectError(f"{archive}: cannot unpack the rule package ({type(exc).__name__}: {exc})") from None
    if dest.exists():
        shutil.rmtree(dest)
    tmp.rename(dest)


def _check_members(members: list[tuple[str, int]], archive: Path) -> None:
    if len(members) > MAX_ARCHIVE_FILES:
        raise ProjectError(f"{archive}: more than {MAX_ARCHIVE_FILES} files in the package")
    if sum(size for _, size in members) > MAX_ARCHIVE_BYTES:
        raise ProjectError(f"{archive}: the package unpacks to more than {MAX_ARCHIVE_BYTES >> 20} MB")
    for name, _ in members:
        parts = Path(name).parts
        if name.startswith(("/", "\\")) or ".." in parts or (parts and ":" in parts[0]):
            raise ProjectError(f"{archive}: the member {name!r} would be written outside the folder")


def open_input(path: Path, *, rule: str | None = None, extract_to: Path | None = None) -> Project:
    """A .cga file (inside a project folder or not), a project folder or an .rpk -> Project.

    An .rpk is unpacked to `extract_to` (default: a folder `<name>.rpk.d` beside the archive).
    """
    path = Path(path)
    if not path.exists():
        if path.suffix.lower() == ".cga":
            return Project(path)  # the reader reports it, located, as for any unreadable file
        raise ProjectError(f"{path}: no such file or folder")
    if path.is_dir():
        root = path.resolve()
        rule_file, rules = _choose_rule(root, rule, root.name)
        return Project(rule_file, root, _imported_projects(root), _resolvemap_names(root), None, rules)
    if path.suffix.lower() == ".rpk":
        dest = Path(extract_to) if extract_to is not None else path.with_name(path.name + ".d")
        _extract(path, dest)
        root = dest.resolve()
        rule_file, rules = _choose_rule(root, rule, path.stem)
        return Project(rule_file, root, _imported_projects(root), _resolvemap_names(root), root, rules)
    root = find_project_root(path)
    if root is None:
        return Project(path)
    return Project(path, root, _imported_projects(root), _resolvemap_names(root), None,
                   tuple(sorted((root / "rules").rglob("*.cga"))))
