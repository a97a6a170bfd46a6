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
from typing import Iterable, Iterator, Mapping

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
    refuse_special(path)
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


def special_kind(path: str | Path) -> str | None:
    """What `path` is when it exists and is neither a regular file nor a folder ("a device",
    "a named pipe (FIFO)", "a socket"), following symlinks; None otherwise."""
    import stat as stat_mod

    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None  # missing (or a dangling link): a new file is written
    if stat_mod.S_ISREG(mode) or stat_mod.S_ISDIR(mode):
        return None
    if stat_mod.S_ISCHR(mode) or stat_mod.S_ISBLK(mode):
        return "a device"
    if stat_mod.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat_mod.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def refuse_special(path: str | Path, option: str | None = None) -> None:
    """Refuse an output path that exists and is not a regular file or a folder.

    The atomic writer renames its temporary file over the target, so writing to /dev/null or
    a FIFO would replace the device node (as root: for the whole machine) with a plain file."""
    kind = special_kind(path)
    if kind is None:
        return
    real = os.path.realpath(path)
    via = f" (it links to {real})" if real != os.path.abspath(path) else ""
    what = f"{option} " if option else ""
    raise OutputError(f"{path}: refusing to write {what}here: it is {kind}{via}, not a regular "
                      "file; give the path of a file to create or replace")


def same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def check_outputs(outputs: Mapping[str, Path | None], inputs: Iterable[Path] = ()) -> None:
    """Refuse, before any work, an output that is an input, that another output also uses, or
    that exists and is not a regular file (a device, a FIFO, a socket).

    `outputs` maps an option name (for the message) to its path."""
    seen: dict[str, str] = {}
    inputs = [Path(p) for p in inputs]
    for option, path in outputs.items():
        if path is None:
            continue
        path = Path(path)
        refuse_special(path, option)
        for src in inputs:
            if same_file(path, src):
                raise OutputError(f"{path}: {option} would overwrite the input {src}; "
                                  "choose another output path")
        key = os.path.realpath(path)
        if key in seen:
            raise OutputError(f"{path}: {option} and {seen[key]} name the same file; "
                              "each output needs its own path")
        seen[key] = option


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
    """Read a grammar file as text, with located errors for size and encoding problems
    (`read_bounded`, then UTF-8)."""
    return decode_source(read_bounded(path, max_bytes=max_bytes), str(path))


def read_bounded(path: Path, *, max_bytes: int = DEFAULT_MAX_BYTES) -> bytes:
    """The bytes of a source file (a grammar, a CGA rule file), with located errors.

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
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else (
            "the path contains a NUL character" if "null byte" in str(exc) else str(exc))
        if "\0" in fname:
            fname = fname.replace("\0", "\\0")  # shown, not swallowed by the terminal
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
    return data


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


LOCK_NAME = ".grammarkit.lock"


class FolderBusy(OutputError):
    """Another live process holds the lock of an output folder."""


class FolderLock:
    """An exclusive lock on an output folder for the whole of one run (issue 31: two runs into
    one folder mixed their results and doubled manifest lines).

    The lock is `fcntl.flock` on `.grammarkit.lock` inside the folder. The kernel drops it when
    the holding process ends, however it ends, so a lock whose holder died is simply taken
    over; the file's text (pid, command, start time) only serves the message of a run that is
    refused. The folder is created if missing (and removed again on release if the run left
    nothing in it), because the lock must exist before anything in the folder is read.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None
        self._created = False

    def acquire(self) -> "FolderLock":
        import json
        import shlex
        import time

        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX: no lock
            return self
        for _ in range(20):
            if not self.folder.is_dir():
                try:
                    self.folder.mkdir(parents=True)
                    self._created = True
                except FileExistsError:
                    pass
                except OSError as exc:
                    raise OutputError(f"{self.folder}: cannot create folder: "
                                      f"{exc.strerror or exc}") from None
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
                             | getattr(os, "O_NOFOLLOW", 0), 0o644)
            except FileNotFoundError:
                continue  # the folder was removed by a run releasing it: make it again
            except OSError as exc:
                raise OutputError(f"{self.folder}: cannot lock the folder ({self.path}): "
                                  f"{exc.strerror or exc}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = _read_holder(fd)
                os.close(fd)
                raise FolderBusy(f"{self.folder}: another run is writing into this folder "
                                 f"({holder}); wait until it ends, or use another folder") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(self.path, follow_symlinks=False).st_ino
            except OSError:
                same = False
            if not same:  # the holder released (and removed) the file between open and flock
                os.close(fd)
                continue
            record = {"pid": os.getpid(), "command": shlex.join(_command_line())[:500],
                      "since": time.strftime("%Y-%m-%d %H:%M:%S")}
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
                os.pwrite(fd, (json.dumps(record) + "\n").encode("utf-8"), 0)
            self._fd = fd
            return self
        raise FolderBusy(f"{self.folder}: cannot lock the folder: its lock file keeps changing")

    def release(self) -> None:
        """Remove the lock file (while still holding it) and drop the lock."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):
            self.path.unlink()
        os.close(fd)
        if self._created:
            with contextlib.suppress(OSError):
                self.folder.rmdir()  # only if the run left it empty

    @property
    def held(self) -> bool:
        return self._fd is not None

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _command_line() -> list[str]:
    """This process's command as a person would type it: `grammarkit batch ...`,
    `python -m grammarkit ...`, `python script.py ...`, `python -c ...`."""
    import sys

    argv = list(sys.argv) or [""]
    python = os.path.basename(sys.executable or "python")
    head = argv[0]
    if head.endswith("__main__.py"):
        return [python, "-m", os.path.basename(os.path.dirname(head)), *argv[1:]]
    if head in ("-c", "-m", "") or head.endswith(".py"):
        return [python, *argv]
    return [os.path.basename(head), *argv[1:]]


def _read_holder(fd: int) -> str:
    """'pid 123: grammarkit batch ...; since ...' from a lock file's record, as far as known."""
    import json

    try:
        record = json.loads(os.pread(fd, 4096, 0).decode("utf-8", "replace") or "{}")
    except (OSError, ValueError):
        record = {}
    if not isinstance(record, dict) or "pid" not in record:
        return "a process that has not said who it is yet"
    return (f"pid {record.get('pid')}: {record.get('command') or 'unknown command'}; "
            f"since {record.get('since') or 'unknown'}")
