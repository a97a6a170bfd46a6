"""Geometry-free descriptions of what plugins provide, shared by the checker and the engines.

The DSL checker validates operation calls against `OperationSpec`s (names, arity,
argument types, block kind) without knowing what an operation does; the split engine
calls the spec's `apply`. Likewise for global constraints and expression functions.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Literal

ArgType = Literal["number", "string", "axis", "selector", "any", "expr"]
BlockKind = Literal["none", "sizes", "selectors", "optional-selectors", "optional-sizes"]


@dataclass(frozen=True)
class Param:
    name: str
    type: ArgType = "number"
    required: bool = True
    default: Any = None
    choices: tuple[str, ...] = ()  # for axis/selector-like parameters
    doc: str = ""


@dataclass(frozen=True)
class OperationSpec:
    """A split operation as the language sees it.

    `block` says what may follow in `{ }`: nothing, split sizes, or selectors (whose
    names are in `selectors`). `apply(context, shape, args, block)` is engine-defined;
    the DSL never calls it.
    """

    name: str
    params: tuple[Param, ...] = ()
    block: BlockKind = "none"
    selectors: tuple[str, ...] = ()
    doc: str = ""
    apply: Callable[..., Any] | None = field(default=None, compare=False, repr=False)
    variadic: bool = False  # accepts any number of extra positional arguments
    plugin: str = ""  # filled in by the plugin manager


@dataclass(frozen=True)
class FunctionSpec:
    """A built-in expression function (`rand`, `min`, `rect`, ...)."""

    name: str
    min_args: int
    max_args: int | None
    doc: str = ""
    impl: Callable[..., Any] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class ConstraintSpec:
    """A global constraint of tiling grammars (`connected`, `grounded`, `path`, `count`).

    `check(graph, args, context) -> list[str]` returns violation messages (empty: satisfied).
    """

    name: str
    params: tuple[Param, ...] = ()
    doc: str = ""
    check: Callable[..., list[str]] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class ExporterSpec:
    """A mesh/model writer for a file format (`glb`, `obj`, `stl`, `ply`, ...).

    `write(model, path)` writes atomically (temporary file, then rename).
    """

    format: str
    suffixes: tuple[str, ...]
    doc: str = ""
    write: Callable[..., None] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass
class DeriveRequest:
    """What `grammarkit derive` asks of a back end.

    `progress(description, total)` returns a callable `advance(n=1, **fields)`; back ends
    call it to drive the CLI's progress bar (a no-op in the Python API).
    """

    out: Any  # pathlib.Path: a file or a folder, as the back end documents
    n: int = 1
    iterations: int = 1
    seed: int = 0
    workers: int | None = None
    options: dict[str, str] = field(default_factory=dict)
    progress: Callable[..., Callable[..., None]] | None = None


@dataclass(frozen=True)
class BackendSpec:
    """A back end: turns a grammar (and its examples) into models.

    `derive(grammar, request) -> dict` writes its outputs under `request.out` and returns a
    JSON-able summary (counts, timings) that the CLI prints. `families` says which grammar
    families it accepts ("split", "tiling"); `default_for` marks it as the back end
    `grammarkit derive` picks when `--backend` is not given.
    """

    name: str
    summary: str
    families: frozenset[str]
    derive: Callable[..., dict] | None = field(default=None, compare=False, repr=False)
    default_for: frozenset[str] = frozenset()
    plugin: str = ""
