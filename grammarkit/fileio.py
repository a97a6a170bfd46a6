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
from typing import Iterator, Mapping

from .errors import GrammarError, ShapeError
from .ir.base import Span

# The largest grammar file read without --max-size. The worst file of ordinary constructs this
# size (long operation chains, tests/qa/test_big_files.py) checks in about 5 s of CPU and
# 0.6 GB; 5 MB took minutes and gigabytes. Real grammars are far smaller (the largest shipped
# one is 9 KB); a generated one can raise the limit.
DEFAULT_MAX_BYTES = 512 * 1024


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


def write_files(files: Mapping[Path, bytes | str]) -> None:
    """Write every file or none: temporary names first, renames only when all were written."""
    for path in files:
        make_parent(Path(path))
    with contextlib.ExitStack() as stack:
        for path, data in files.items():
            tmp = stack.enter_context(atomic_output(Path(path)))
            if isinstance(data, str):
                tmp.write_text(data, encoding="utf-8")
            else:
                tmp.write_bytes(data)


def make_parent(path: Path) -> None:
    folder = path.parent
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{path}: cannot write: {folder} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path}: cannot create folder {folder}: {exc.strerror or exc}") from None


def read_source(path: Path, *, max_bytes: int = DEFAULT_MAX_BYTES) -> str:
    """Read a grammar file as text, with located errors for size and encoding problems.

    Only regular files are read (a FIFO would block forever, a device such as /dev/zero has no
    end, and `stat` reports 0 bytes for both), and never more than `max_bytes` + 1 bytes, so
    the limit holds even for a file that grows while it is read."""
    import stat as stat_mod

    fname = str(path)

    def refuse(message: str, code: str, hint: str | None = None) -> GrammarError:
        return GrammarError(message, Span(file=fname, line=1, column=1, end_line=1, end_column=1)
                            if code == "too-large" else Span(file=fname), code=code, hint=hint)

    def too_large(size: str) -> GrammarError:
        return refuse(f"file is too large ({size}; the limit is {max_bytes:,} bytes)", "too-large",
                      "split the grammar into several files joined with `import`, or raise the limit")

    try:
        # O_NONBLOCK: opening a FIFO without a writer must not block; the mode is checked on
        # the open descriptor, so the file cannot be swapped between the check and the read
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError) as exc:
        if isinstance(exc, OSError) and exc.errno == 21 or Path(fname).is_dir():
            raise refuse(f"cannot read {fname}: it is a folder, not a grammar file", "io-error") from None
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise refuse(f"cannot read {fname}: {reason}", "io-error") from None
    try:
        st = os.fstat(fd)
        if stat_mod.S_ISDIR(st.st_mode):
            raise refuse(f"cannot read {fname}: it is a folder, not a grammar file", "io-error")
        if not stat_mod.S_ISREG(st.st_mode):
            kind = ("a named pipe (FIFO)" if stat_mod.S_ISFIFO(st.st_mode) else
                    "a device" if stat_mod.S_ISCHR(st.st_mode) or stat_mod.S_ISBLK(st.st_mode) else
                    "a socket" if stat_mod.S_ISSOCK(st.st_mode) else "not a regular file")
            raise refuse(f"cannot read {fname}: it is {kind}, not a regular file", "not-a-file",
                         "give the path of a grammar file")
        if st.st_size > max_bytes:
            raise too_large(f"{st.st_size:,} bytes")
        os.set_blocking(fd, True)
        chunks, total = [], 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > max_bytes:
            raise too_large(f"more than {max_bytes:,} bytes")
        data = b"".join(chunks)
    except OSError as exc:
        raise refuse(f"cannot read {fname}: {exc.strerror or exc}", "io-error") from None
    finally:
        os.close(fd)
    return decode_source(data, fname)


def read_limited(stream, max_bytes: int, name: str) -> bytes:  # noqa: ANN001 - a binary stream
    """At most `max_bytes` of a stream (standard input), or a located too-large error: never
    more than `max_bytes` + 1 bytes are read."""
    data = stream.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise GrammarError(f"input is too large (more than {max_bytes:,} bytes; the limit is "
                           f"{max_bytes:,} bytes)", Span(file=name, line=1, column=1, end_line=1,
                                                        end_column=1), code="too-large")
    return data


def decode_source(data: bytes, filename: str | None) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        before = data[:exc.start]
        line = before.count(b"\n") + 1
        col = exc.start - (before.rfind(b"\n") + 1) + 1
        raise GrammarError(
            f"file is not valid UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            Span(file=filename, line=line, column=col, end_line=line, end_column=col + 1),
            code="encoding", hint="save the file as UTF-8") from None
