"""The one writer: results become files, atomically, listed in one manifest format.

Two shapes of output:

- `write_files({path: bytes | str})`: one transaction of several files (a model, its preview
  and its tree). Every file is written to a temporary name first; the renames happen only
  when all were written, so a failure leaves every existing file untouched.
- `OutputFolder`: a folder of results, as every back end produces. Each result's model and
  attachments are written as one transaction, then its line is appended to `manifest.jsonl`
  (and flushed to disk). The folder also holds `run.json`: what was asked (back end, grammar
  and its hash, seed, options, attrs, format). Re-running the same request into the folder
  continues after the last complete entry; a different request is refused, so runs never mix.

Manifest lines have the same core fields for every back end:

    {"id": "paris_0003", "index": 3, "seed": 1234, "parents": [], "metrics": {...},
     "file": "paris_0003.glb", "attachments": {"png": "paris_0003.png"}, ...back-end fields}

Crash safety: before a result's files are renamed into place, their names are recorded in
`.pending.json`; the record is removed once the manifest line is on disk. A run killed in
between (SIGKILL, power loss) leaves the record, and the next run into the folder deletes
those unlisted files first, so the folder never holds model files the manifest does not list.
Stale temporary files (`.name.xxxx.tmp`) are removed the same way.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from ..errors import GrammarkitError
from ..fileio import (  # noqa: F401 - re-exported
    FolderBusy, FolderLock, OutputError, atomic_output, check_outputs, make_parent, refuse_special,
    same_file, write_files,
)
from ..jsonable import to_jsonable

__all__ = ["ModelFile", "OutputFolder", "RunMismatch", "WriteStopped", "check_outputs", "grammar_hash",
           "write_files"]

MANIFEST = "manifest.jsonl"
RUN_FILE = "run.json"
PENDING = ".pending.json"
MODEL_SUFFIXES = frozenset({".glb", ".gltf", ".obj", ".stl", ".ply"})


class RunMismatch(GrammarkitError):
    """The output folder holds a different run."""


class WriteStopped(OutputError):
    """A result could not be written (a full disk, a folder gone read-only): the run stopped
    with the manifest listing exactly the `done` complete results; the same run continues."""

    def __init__(self, what: str, done: int, noun: str = "run", items: str = "results"):
        self.what, self.done = what, done
        listed = "nothing was written" if done == 0 else \
            f"manifest.jsonl lists the {done} complete {items}"
        super().__init__(f"{what}; the {noun} stopped ({listed}); fix the cause and run the "
                         "same command again to continue")


def grammar_hash(grammar: Any) -> str:
    """A stable hash of a grammar's meaning (its canonical text), for run.json and models."""
    from ..printer import format_grammar

    text = format_grammar(grammar)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _files_of(entries: Iterable[dict]) -> list[str]:
    """The plain file names (model and attachments) that manifest entries list."""
    names = []
    for e in entries:
        for name in [e.get("file"), *(e.get("attachments") or {}).values()]:
            if isinstance(name, str) and name and "/" not in name and not name.startswith("."):
                names.append(name)
    return names


@dataclass
class OutputFolder:
    """A folder of results with `run.json` and `manifest.jsonl` (see the module docstring).

    path:      the folder (created if missing; refused if it is a file or named like a model).
    run:       what is being asked; must equal the folder's `run.json` to continue a run.
    protected: input files that no output may replace.
    overwrite: start over: delete the files an earlier run listed, then write afresh.

    The folder is locked for the life of the object (grammarkit.fileio.FolderLock): a second
    run into it fails at once, naming the process that holds it; `close()` releases it. Nothing
    in the folder is changed until the first `add` but the lock file, which `close()` removes
    (a run that fails before its first result leaves the folder as it was).
    """

    path: Path
    run: dict[str, Any]
    protected: tuple[Path, ...] = ()
    overwrite: bool = False
    entries: list[dict] = field(default_factory=list)
    resumed: int = 0
    sync_seconds: float = 1.0
    _synced: float = 0.0

    def __post_init__(self) -> None:
        self.path = Path(self.path)
        self.run = to_jsonable(self.run)
        p = self.path
        refuse_special(p, "-o")
        if p.exists() and not p.is_dir():
            raise OutputError(f"{p}: is a file; this command writes a folder of results "
                              "(model files and manifest.jsonl)")
        if not p.exists() and p.suffix.lower() in MODEL_SUFFIXES:
            raise OutputError(f"{p}: this command writes a folder of results, and the name looks "
                              f"like one model file; give a folder name, e.g. -o {p.with_suffix('')}/")
        self._check_creatable()
        self._opened = False
        # locked before anything in the folder is read: recovery deletes unlisted files, which
        # must never be those of a run still writing
        self._lock = FolderLock(p).acquire()
        try:
            self._recover()
            self._read_state()
        except BaseException:
            self._lock.release()
            raise

    def _check_creatable(self) -> None:
        """Fail now, not after the work, if the folder cannot exist: the nearest existing
        ancestor must be a folder we may write in. (The folder itself is made with the first
        result, so a run that fails early leaves no empty folder behind.)"""
        p = self.path
        ancestor = p
        while not ancestor.exists():
            if ancestor.parent == ancestor:
                break
            ancestor = ancestor.parent
        if not ancestor.is_dir():
            raise OutputError(f"{p}: cannot create folder: {ancestor} is a file")
        if not os.access(ancestor, os.W_OK | os.X_OK):
            raise OutputError(f"{p}: cannot create folder: {ancestor} is not writable")

    # -- opening ----------------------------------------------------------------------------
    def _recover(self) -> None:
        """Undo what a killed run left: files renamed in but never listed, temporary files."""
        pending = self.path / PENDING
        if pending.exists():
            try:
                names = json.loads(pending.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                names = []
            listed = {e.get("file") for e in self._read_manifest()}
            for e in self._read_manifest():
                listed.update((e.get("attachments") or {}).values())
            for name in names if isinstance(names, list) else []:
                if isinstance(name, str) and name not in listed and "/" not in name:
                    with contextlib.suppress(OSError):
                        (self.path / name).unlink()
            with contextlib.suppress(OSError):
                pending.unlink()
        for tmp in self.path.glob(".*.tmp"):
            with contextlib.suppress(OSError):
                tmp.unlink()

    def _read_manifest(self) -> list[dict]:
        path = self.path / MANIFEST
        if not path.is_file():
            return []
        entries = []
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise OutputError(f"{path}: cannot read the manifest: {exc}") from None
        for line in text.splitlines():
            try:
                entry = json.loads(line)
            except ValueError:
                break  # a line cut short by a crash: everything after it is incomplete
            if not isinstance(entry, dict) or "id" not in entry:
                break
            entries.append(entry)
        return entries

    def _read_state(self) -> None:
        """Read an earlier run's run.json and manifest, if any, and decide where to go on."""
        run_path = self.path / RUN_FILE
        old_run = None
        if run_path.exists():
            try:
                old_run = json.loads(run_path.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                old_run = None
        entries = self._read_manifest()
        self._discard: list[str] = []  # listed files that the new run replaces (deleted on open)
        if self.overwrite:
            self._discard = _files_of(entries)
            entries, old_run = [], None
        elif (entries or (self.path / MANIFEST).exists()) and old_run is None:
            raise RunMismatch(f"{self.path}: holds a manifest.jsonl without run.json (written by an "
                              "older grammarkit or by hand); use another folder or --overwrite")
        if old_run is not None and not self.overwrite:
            differ = sorted(k for k in set(old_run) | set(self.run)
                            if k != "n" and old_run.get(k) != self.run.get(k))
            if differ:
                what = ", ".join(f"{k}={old_run.get(k)!r}" for k in differ[:4])
                raise RunMismatch(f"{self.path}: holds results of another run ({what}); "
                                  "re-run that command to continue it, or use another folder or "
                                  "--overwrite to start over")
        # an entry whose file vanished ends the list: later results are made again
        for i, e in enumerate(entries):
            names = [e.get("file"), *(e.get("attachments") or {}).values()]
            if any(isinstance(nm, str) and not (self.path / nm).exists() for nm in names if nm):
                self._discard = _files_of(entries[i:])
                entries = entries[:i]
                break
        self.entries = entries
        self.resumed = len(entries)

    def _open(self) -> None:
        """Make the folder; rewrite run.json and the manifest (dropping a torn last line)."""
        if self._opened:
            return
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{self.path}: cannot create folder: {exc.strerror or exc}") from None
        for name in self._discard:
            with contextlib.suppress(OSError):
                (self.path / name).unlink()
        write_files({self.path / RUN_FILE: json.dumps(self.run, indent=1, sort_keys=True) + "\n",
                     self.path / MANIFEST: "".join(json.dumps(e, sort_keys=True) + "\n"
                                                   for e in self.entries)})
        self._opened = True

    # -- writing ----------------------------------------------------------------------------
    @property
    def done(self) -> int:
        return len(self.entries)

    def add(self, entry: dict, files: Mapping[str, bytes | str]) -> dict:
        """Write one result's `files` ({file name: data}) and append its manifest `entry`."""
        for name in files:
            target = self.path / name
            if "/" in name or name.startswith(".") or name in (MANIFEST, RUN_FILE):
                raise OutputError(f"{target}: refusing to write a result file with this name")
            for src in self.protected:
                if same_file(target, src):
                    raise OutputError(f"{target}: writing this result would overwrite the input "
                                      f"{src}; choose another output folder")
        self._open()
        pending = self.path / PENDING
        manifest = self.path / MANIFEST
        before = manifest.stat().st_size if manifest.exists() else 0
        listed = False
        try:
            pending.write_text(json.dumps(sorted(files)), encoding="utf-8")
            write_files({self.path / name: data for name, data in files.items()})
            line = json.dumps(to_jsonable(entry), sort_keys=True) + "\n"
            with open(manifest, "a", encoding="utf-8") as fh:
                fh.write(line)
                fh.flush()
            listed = True
        except BaseException as exc:
            # the files must not outlive a missing manifest line (full disk, Ctrl-C), and a
            # line cut short must not stay for other readers (truncating needs no free space)
            if not listed:
                with contextlib.suppress(OSError):
                    os.truncate(manifest, before)
                for name in files:
                    with contextlib.suppress(OSError):
                        (self.path / name).unlink()
            if isinstance(exc, OSError) and not isinstance(exc, OutputError):
                raise OutputError(f"{self.path}: cannot write {entry.get('id')!r}: "
                                  f"{exc.strerror or exc}") from exc
            raise
        finally:
            with contextlib.suppress(OSError):
                pending.unlink()
        self.entries.append(entry)
        self._maybe_sync()
        return entry

    def _maybe_sync(self, force: bool = False) -> None:
        """Make the manifest and the folder durable at most every `sync_seconds` (and on
        close). A killed process loses nothing either way (written data is in the page cache);
        this bounds what a power cut can lose without paying two fsyncs per result."""
        import time

        now = time.monotonic()
        if not force and now - self._synced < self.sync_seconds:
            return
        self._synced = now
        with contextlib.suppress(OSError):
            fd = os.open(self.path / MANIFEST, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        _fsync_dir(self.path)

    def sync(self) -> None:
        """Flush everything written so far to disk."""
        if self._opened:
            self._maybe_sync(force=True)

    def close(self) -> None:
        """Flush everything to disk and release the folder's lock (call when the run ends,
        however it ends; closing twice is harmless)."""
        try:
            self.sync()
        finally:
            self._lock.release()

    def __enter__(self) -> "OutputFolder":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def manifest(self) -> Path:
        return self.path / MANIFEST


@dataclass
class ModelFile:
    """One result written as named files (`grammarkit derive -o paris.glb --preview p.png`):
    the model and its attachments in one transaction (all replaced, or none), no manifest.

    The same calls as OutputFolder (`add`, `done`, `entries`, `close`), so `run_backend`
    writes both the same way: the one writer, with two shapes of output.

    path:        the model file.
    attachments: where each attachment goes, by suffix: {"png": Path("p.png"),
                 "tree.json": Path("tree.json")}; a PNG is converted to the format its
                 suffix names (.jpg, .webp, ...).
    protected:   input files that no output may replace.
    """

    path: Path
    attachments: Mapping[str, Path] = field(default_factory=dict)
    protected: tuple[Path, ...] = ()
    entries: list[dict] = field(default_factory=list)
    resumed: int = 0
    manifest: Path | None = None

    def __post_init__(self) -> None:
        self.path = Path(self.path)
        self.attachments = {k: Path(v) for k, v in self.attachments.items()}
        if self.path.is_dir():
            raise OutputError(f"{self.path}: is a folder; give a file name (or -n N for a folder "
                              "of results)")
        check_outputs({"-o": self.path, **{f"--{'preview' if k == 'png' else k.split('.')[0]}": p
                                           for k, p in self.attachments.items()}},
                      inputs=self.protected)

    @property
    def done(self) -> int:
        return len(self.entries)

    def add(self, entry: dict, files: Mapping[str, bytes | str]) -> dict:
        """Write the result's model and the attachments asked for, as one transaction."""
        if self.entries:
            raise OutputError(f"{self.path}: holds one result; the run made a second one")
        model = entry.get("file")
        out: dict[Path, bytes | str] = {}
        for name, data in files.items():
            if name == model:
                out[self.path] = data
                continue
            suffix = name[len(str(entry["id"])) + 1:]
            target = self.attachments.get(suffix)
            if target is None:
                continue  # an attachment nobody asked a file for
            if suffix == "png" and isinstance(data, bytes):
                data = image_as(data, target)
            out[target] = data
        write_files(out)
        self.entries.append(entry)
        return entry

    def close(self) -> None:
        return None

    def __enter__(self) -> "ModelFile":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def image_as(png: bytes, path: Path) -> bytes:
    """PNG bytes converted to the image format `path`'s suffix names."""
    if path.suffix.lower() == ".png":
        return png
    import io

    from PIL import Image

    fmt = Image.registered_extensions()[path.suffix.lower()]
    image: Image.Image = Image.open(io.BytesIO(png))
    if fmt in ("JPEG", "BMP") and image.mode == "RGBA":
        image = image.convert("RGB")
    buf = io.BytesIO()
    image.save(buf, format=fmt)
    return buf.getvalue()
