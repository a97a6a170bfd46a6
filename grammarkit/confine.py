"""Folder confinement: which files a run may open, checked where every file is opened.

A caller that runs grammars it does not trust (the studio, a service) confines the run to a
folder; every place that opens a file a grammar names (imports, inserted meshes and their
external glTF buffers, textures, `fileSearch`/`fileRandom`/`fileExists`, lots) asks `check()`
with the path it is about to open. The check looks at the *resolved* path: after the language's
escapes and the evaluation of the expression (the caller passes the final string), after
joining it to its base folder, after `..` and after every symbolic link (`os.path.realpath`).
So `"\\u{2e}\\u{2e}/x"`, `"../" + "x"`, a const or attr holding a path, an absolute path and a
link that points outside all fail the same way.

    from grammarkit import confine

    with confine.confined("grammars/", who="the studio"):
        ...                                  # any derive, check or import in here
        confine.check("grammars/parts/a.glb", what="mesh file")   # passes
        confine.check("/etc/passwd", what="import")         # ConfinementError

Without a policy (the default: the command line, the Python API) `check` does nothing, so
behaviour and outputs are unchanged. The policy is a `contextvars.ContextVar`: it follows the
code that entered it (threads started by `asyncio.to_thread` and `contextvars.copy_context`
inherit it), never leaks into other threads, and a process that runs work elsewhere (worker
processes) must enter it there again (`current()` is picklable).

The refusal never depends on whether the file exists, and its message shows the path as the
grammar named it plus the allowed folder, never what a link outside points at: the error
cannot be used to learn anything about files outside the folder.

This module is on the bottom floor (docs/architecture.md): it imports only `errors`.
"""
from __future__ import annotations

import contextlib
import contextvars
import functools
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Iterator, TypeVar

from .errors import Diagnostic, GrammarkitError

if TYPE_CHECKING:  # pragma: no cover
    from .ir.base import Span

__all__ = ["CODE", "ConfinementError", "Policy", "allows", "check", "confined", "current", "guarded",
           "refusal", "resolve"]

CODE = "outside-folder"  # the diagnostic code of every refusal
_SHOWN = 200  # characters of a refused path shown in the message
BUILTIN_PREFIX = "builtin:"  # CGA's built-in assets name no file

F = TypeVar("F", bound=Callable[..., Any])


class ConfinementError(GrammarkitError):
    """A file outside the folder the run is confined to was about to be opened."""


@dataclass(frozen=True)
class Policy:
    """A run may open files inside `root` only (`root` is a resolved, absolute folder)."""

    root: str
    who: str = "this run"  # who confined it, for the message ("the studio")

    def allows(self, resolved: str) -> bool:
        root = os.path.normcase(self.root)
        p = os.path.normcase(resolved)
        return p == root or p.startswith(root.rstrip(os.sep) + os.sep)


_POLICY: contextvars.ContextVar[Policy | None] = contextvars.ContextVar("grammarkit_confine", default=None)


def current() -> Policy | None:
    """The policy in force here (None: files are not confined)."""
    return _POLICY.get()


@contextlib.contextmanager
def confined(root: str | os.PathLike | Policy | None, *, who: str = "this run") -> Iterator[Policy | None]:
    """Confine the block to `root` (a folder; None or no policy: unconfined). A confinement
    inside another can only narrow it: a root outside the one in force, or None, keeps the
    outer one (a refusal would only break the caller; widening must never happen)."""
    if isinstance(root, Policy):
        policy: Policy | None = root
    elif root is None:
        policy = None
    else:
        policy = Policy(os.path.realpath(os.fspath(root)), who)
    outer = _POLICY.get()
    if outer is not None and (policy is None or not outer.allows(policy.root)):
        policy = outer
    token = _POLICY.set(policy)
    try:
        yield policy
    finally:
        _POLICY.reset(token)


def resolve(path: str | os.PathLike, base: str | os.PathLike | None = None) -> str:
    """The absolute path a file operation on `path` (relative to `base`, else to the working
    folder) would reach: `..` collapsed and every symbolic link followed. ValueError for a
    path that cannot name a file (a NUL character)."""
    p = os.fsdecode(os.fspath(path))
    if "\0" in p:
        raise ValueError("the path contains a NUL character")
    if base is not None and not os.path.isabs(p):
        p = os.path.join(os.fsdecode(os.fspath(base)), p)
    return os.path.realpath(p)


def allows(path: str | os.PathLike, base: str | os.PathLike | None = None) -> bool:
    """Whether the policy in force lets `path` be opened (always True without a policy).
    For lookups that try several folders: skip the refused candidates silently, so that
    which of them exist outside the folder is never told."""
    policy = _POLICY.get()
    if policy is None:
        return True
    try:
        return policy.allows(resolve(path, base))
    except (OSError, ValueError):
        return False


def _message(policy: Policy, path: Any, what: str) -> str:
    shown = os.fsdecode(os.fspath(path)) if isinstance(path, (str, bytes, os.PathLike)) else str(path)
    if len(shown) > _SHOWN:
        shown = shown[:_SHOWN] + "..."
    return f"{what} {shown!r} is outside {policy.root}, the only folder {policy.who} reads files from"


_HINT = ("keep the files a grammar uses (imports, meshes, textures, lots) inside its folder; a "
         "symbolic link counts where it points")


def refusal(path: str | os.PathLike, *, base: str | os.PathLike | None = None, what: str = "file",
            span: Span | None = None) -> Diagnostic | None:
    """The located error for opening `path`, or None when the policy allows it (for code that
    collects diagnostics instead of raising, such as the import resolver)."""
    policy = _POLICY.get()
    if policy is None or allows(path, base):
        return None
    return Diagnostic("error", _message(policy, path, what), span, _HINT, CODE)


def check(path: str | os.PathLike, *, base: str | os.PathLike | None = None, what: str = "file",
          span: Span | None = None) -> None:
    """Raise ConfinementError (naming `what`, a noun such as "import" or "mesh file", the path
    and the folder; located at `span`)
    unless the policy in force allows opening `path`. Call it with the path about to be
    opened, before anything looks at the file (so existence is never told)."""
    diagnostic = refusal(path, base=base, what=what, span=span)
    if diagnostic is not None:
        raise ConfinementError(diagnostic.message, span, hint=diagnostic.hint, code=CODE)


def guarded(what: str) -> Callable[[F], F]:
    """A decorator for a loader whose first argument is the path it opens: the path is checked
    on every call. Put it *above* an `lru_cache`, so that a file cached by an unconfined call
    is not handed to a confined one. `builtin:` names open no file and pass."""

    def wrap(fn: F) -> F:
        @functools.wraps(fn)
        def loader(path: Any, *args: Any, **kwargs: Any) -> Any:
            if _POLICY.get() is not None and not (isinstance(path, str) and path.startswith(BUILTIN_PREFIX)):
                check(path, what=what)
            return fn(path, *args, **kwargs)

        for name in ("cache_clear", "cache_info"):  # keep an lru_cache's controls reachable
            if hasattr(fn, name):
                setattr(loader, name, getattr(fn, name))
        return loader  # type: ignore[return-value]

    return wrap
