"""Writing output files atomically: a temporary file next to the target, then a rename.

Every command that writes (derive, fmt --in-place, learn, render, exporters, back ends) goes
through `atomic_output`, so a failure never leaves a half-written file and never touches an
existing one, and every file-system problem is reported as an error naming the path.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import ShapeError


class OutputError(ShapeError, OSError):
    """A file could not be written (missing or unwritable folder, full disk, a folder in the
    way). A ShapeError naming the path, so the CLI prints it, and an OSError, so callers that
    handle file-system failures keep working."""


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _umask()  # read once: os.umask can only be read by setting it, which is not thread-safe


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to `path`; on success rename it over `path`, on failure
    delete it, so readers never see a half-written file and an existing `path` is untouched.

    Every file-system failure (a missing or unwritable folder, `path` being a folder, a full
    disk) becomes a ShapeError naming `path`, so the CLI reports it instead of a traceback.
    """
    path = Path(path)
    if path.is_symlink():
        # write through the link to the file it names: the link stays a link (fmt --in-place
        # on a symlinked grammar formats the real file), and the error names the user's path
        shown = path
        path = Path(os.path.realpath(path))
        if path.is_dir():
            raise OutputError(f"{shown}: cannot write: it links to a folder, {path}")
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise OutputError(f"{path}: cannot write: it is a folder, not a file")
    if not folder.is_dir():
        raise OutputError(f"{path}: cannot write: folder {folder} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {exc.strerror or exc}") from None
    # The temporary file stays locked while it is being written: a later writer of the same
    # path removes the ones whose lock is free, i.e. those of a writer that was killed (issue
    # 19: SIGKILL left hidden .tmp files behind), never those of one still writing.
    _lock(fd)
    _remove_stale(folder, path.name, keep=tmp)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates the file 0600: keep the permissions of the file being replaced, or
        # give a new file the ones a plain open() would
        try:
            mode = path.stat().st_mode & 0o7777
        except OSError:
            mode = 0o666 & ~_UMASK
        os.chmod(tmp_path, mode)
        os.replace(tmp_path, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        if isinstance(exc, OSError) and not isinstance(exc, ShapeError):
            raise OutputError(f"{path}: cannot write: {exc.strerror or exc}") from exc
        raise
    finally:
        os.close(fd)


def _lock(fd: int) -> bool:
    """An exclusive lock on fd without waiting; False if another process holds it."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no stale-file cleanup
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except OSError:
        return False


def _remove_stale(folder: Path, name: str, keep: str) -> None:
    """Delete `.name.*.tmp` files next to the target that no live writer holds locked."""
    try:
        candidates = [p for p in folder.glob(f".{glob_escape(name)}.*.tmp") if str(p) != keep]
    except OSError:
        return
    for p in candidates[:64]:
        try:
            fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0))
        except OSError:
            continue
        try:
            import stat

            if stat.S_ISREG(os.fstat(fd).st_mode) and _lock(fd):
                p.unlink()
        except OSError:
            pass
        finally:
            os.close(fd)


def glob_escape(text: str) -> str:
    import glob

    return glob.escape(text)
