"""Geometry-free descriptions of what plugins provide, shared by the checker and the engines.

The DSL checker validates operation calls against `OperationSpec`s (names, arity,
argument types, block kind) without knowing what an operation does; the split engine
calls the spec's `apply`. Likewise for global constraints and expression functions.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Iterator, Literal, Mapping, Sequence

if TYPE_CHECKING:  # pragma: no cover - types only
    from pydantic import BaseModel

    from .ir.grammar import Grammar

# The names of the built-in meshes `i("builtin:NAME")` inserts (grammarkit.split.assets makes
# them). They are data every floor may ask about (fileExists("builtin:cube") in any evaluator),
# so they live down here; tests/core/test_layers.py checks that split's table agrees.
BUILTIN_ASSET_NAMES = ("cube", "cube:notex", "cylinder", "cylinder:y", "cone", "sphere", "quad", "disk")

# number, string: a value of that type; color: a string '#rrggbb' or '#rgb' (checked when
# constant); axis, selector: a bare name among `choices`; name: a bare name of the registry kind
# `names` (e.g. a fit); any, expr: whatever the operation makes of it.
ArgType = Literal["number", "string", "color", "axis", "selector", "name", "any", "expr"]
BlockKind = Literal["none", "sizes", "selectors", "optional-selectors", "optional-sizes"]


@dataclass(frozen=True)
class Param:
    name: str
    type: ArgType = "number"
    required: bool = True
    default: Any = None
    choices: tuple[str, ...] = ()  # for axis/selector-like parameters
    doc: str = ""
    names: str = ""  # for type "name": the Registries kind the name must be in ("fits")


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
    """A model writer for a file format (`glb`, `obj`, `stl`, `ply`, ...).

    `encode(model) -> bytes` turns a split `Model`, a tiling `Assembly`, a trimesh Scene or
    Trimesh into the file's bytes; it never touches the file system (the run layer's writer
    writes atomically and checks the bytes first). `check(data) -> str | None` optionally
    says what is wrong with bytes that cannot be a valid file of this format.
    """

    format: str
    suffixes: tuple[str, ...]
    doc: str = ""
    encode: Callable[[Any], bytes] | None = field(default=None, compare=False, repr=False)
    check: Callable[[bytes], "str | None"] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class FitSpec:
    """A way to fit an inserted asset into a scope: `i("fence.glb", fit=NAME)` in split grammars.

    `fit(mesh, size) -> mesh` receives the asset as a trimesh.Trimesh normalised to its bounding
    box's minimum corner at the origin, and the scope size (sx, sy, sz); it returns the mesh to
    insert (same frame, bounding box of `size`). The built-in behaviour (`fit=scale`, the
    default) scales the asset; e.g. the retargeter plugin provides `fit=retarget`.
    """

    name: str
    doc: str = ""
    fit: Callable[[Any, tuple[float, float, float]], Any] | None = field(default=None, compare=False,
                                                                          repr=False)
    plugin: str = ""


# ---------------------------------------------------------------------------------------------
# The back-end contract (beside the other specs: the registry and the hooks name it, and no
# lower module may import the run layer). grammarkit.run.backend re-exports it.
#
# The back-end contract: a typed request in, results yielded out; no files touched.
#
# Every back end (the built-in `split` engine, the graph sampler, and third-party ones) is a
# `BackendSpec` returned by the `grammarkit_backends` hook. Its `run(request)` is a generator:
#
#     def run(request: Request) -> Iterator[Result]:
#         for index in range(request.start, request.n):
#             model = ...                                   # a Model, an Assembly, a Scene
#             yield Result(id=f"variant_{index:05d}", index=index, seed=..., model=model)
#
# The run layer (`grammarkit.run.run_backend`) validates options, opens the output folder, hands
# the results to the one writer (files + manifest.jsonl) and reports shortfalls. A back end
# never writes files, never starts processes of its own (it asks `request.executor`), and
# never reads the global plugin manager (`request.registries` has what it needs).
#
# Determinism: a result must depend only on (request.seed, its index) and the grammar, never
# on the number of workers or on how the run was split up.
def _no_progress(description: str, total: int | None = None) -> Callable[..., None]:
    def advance(n: int = 1, **fields: Any) -> None:
        return None
    return advance


@dataclass(frozen=True)
class Request:
    """What a back end is asked to do.

    grammar:    the grammar IR (imports inlined); its examples/parts are resolved against
                `grammar.source_path`.
    n:          how many results to yield at most (the run layer reports a shortfall).
    seed:       run seed; results depend only on (seed, index).
    start:      the first index to yield (resumed runs). A back end that cannot start in the
                middle may recompute earlier results: the writer skips indices below `start`.
    iterations: back-end iterations (sampler steps), where meaningful.
    attrs:      attr overrides (split grammars), already checked by the run layer.
    options:    an instance of the back end's `options` model, validated.
    executor:   the one executor for parallel work (`grammarkit.run.executor`).
    registries: the operations/functions/constraints/exporters in effect for this run.
    progress:   `progress(description, total) -> advance(n=1, **fields)` for progress bars.
    deadline:   `time.monotonic()` value after which the back end must stop (None: no limit);
                `check_deadline()` raises a LimitError for it (`--timeout`: a hard stop).
    soft_deadline: `time.monotonic()` value of the graceful budget (`--time-limit`): past it a
                back end stops making new results, keeps what it made and returns; the run layer
                reports the shortfall. `time_is_up()` tells whether it has passed.
    format:     the export format the writer will use, or None when results stay in memory
                (Python API). Back ends that make models in worker processes may encode them
                there (`grammarkit.run.encode_model`) and yield the bytes as `Result.model`.
    preview:    the caller wants a PNG preview per result (`attachments["png"]`); the writer
                renders one for results that come without.
    items:      the inputs results are made from, where the run has some: result `i` is made
                from `items[i]` (the split back end: one `grammarkit.run.lots.Lot` per
                building). None: results come from (seed, index) alone.
    """

    grammar: "Grammar"
    n: int = 1
    seed: int = 0
    start: int = 0
    iterations: int = 1
    attrs: Mapping[str, Any] = field(default_factory=dict)
    options: Any = None
    executor: Any = None  # a grammarkit.run.executor.Executor (the run layer makes it)
    registries: Any = None
    progress: Callable[..., Callable[..., None]] = _no_progress
    deadline: float | None = None
    soft_deadline: float | None = None
    format: str | None = None
    preview: bool = False
    items: Sequence[Any] | None = None

    def check_deadline(self) -> None:
        """Raise `grammarkit.errors.LimitError` once the run's time budget is spent."""
        if self.deadline is None:
            return
        import time

        if time.monotonic() > self.deadline:
            from .errors import LimitError

            raise LimitError("the run's time budget (--timeout) is spent", None, code="timeout")

    def time_is_up(self) -> bool:
        """True once the graceful budget (`--time-limit`) has passed: stop making new results."""
        if self.soft_deadline is None:
            return False
        import time

        return time.monotonic() > self.soft_deadline


@dataclass
class Result:
    """One output of a back end.

    id:       a stable name, unique within the run (becomes the file stem), e.g. "paris_0003".
    index:    position in the run (0-based); results are yielded in index order.
    seed:     the seed this result was made from (None if not seed-driven).
    model:    what the writer exports: a split `Model`, a tiling `Assembly`, a trimesh Scene or
              Trimesh, or None for results that are data only (e.g. strings).
    parents:  ids of the results or examples it was made from.
    metrics:  numbers worth a column in the manifest (triangles, parts, residual, ...).
    extra:    further back-end-specific manifest fields (JSON-able).
    attachments: extra files written beside the model, by suffix: {"png": bytes,
              "tree.json": str}. Written atomically with the model, listed in the manifest.
    """

    id: str
    index: int
    model: Any = None
    seed: int | None = None
    parents: tuple[str, ...] = ()
    metrics: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    attachments: dict[str, bytes | str] = field(default_factory=dict)


RunFunction = Callable[[Request], Iterator[Result]]


@dataclass(frozen=True)
class BackendSpec:
    """A back end, as the `grammarkit_backends` hook returns it.

    name:        `--backend NAME`; unique across plugins (a clash is an error naming both).
    summary:     one line for `grammarkit plugins`.
    families:    grammar families it accepts: {"split"}, {"tiling"} or both.
    run:         the generator function `run(request) -> Iterator[Result]`.
    options:     a pydantic model class of its options (`--option key=value`, validated against
                 it; `grammarkit plugins` lists its fields), or None for no options.
    default_for: families for which `grammarkit derive` picks it without `--backend`.
    model_format: default export format for its results ("glb").
    """

    name: str
    summary: str
    families: frozenset[str]
    run: RunFunction | None = field(default=None, compare=False, repr=False)
    options: "type[BaseModel] | None" = field(default=None, compare=False, repr=False)
    default_for: frozenset[str] = frozenset()
    model_format: str = "glb"
    plugin: str = ""  # filled in by the plugin manager


class Registries:
    """What plugins provide, by kind, as the core receives it (never the global manager).

    Each kind is a name -> spec mapping computed on first access (so a command that needs no
    exporters never runs exporter hooks). Build one from explicit mappings for tests, or get
    the plugin manager's with `grammarkit.plugins.get_plugin_manager().registries()`.
    """

    KINDS = ("operations", "functions", "constraints", "exporters", "backends", "fits")

    def __init__(self, loaders: dict[str, Callable[[], dict]] | None = None, *,
                 rebuild: Callable[[], "Registries"] | None = None, **mappings: dict):
        # rebuild: these are exactly what a fresh process's plugin manager provides (the entry
        # points, under the same environment), and `rebuild` (a module-level function, given
        # by the plugin manager: this floor never imports it) makes them again in a worker
        # process, so they travel by reference (see __reduce__)
        self._rebuild = rebuild
        self._loaders = dict(loaders or {})
        self._values: dict[str, dict] = {}
        for kind, mapping in mappings.items():
            if kind not in self.KINDS:
                raise TypeError(f"Registries: unknown kind {kind!r}")
            self._values[kind] = dict(mapping)

    def __reduce__(self) -> Any:
        """Pickled by reference when they are the installed plugins' (a worker process
        rebuilds its own from the entry points); other registries hold functions that need
        not pickle, so they refuse, and the executor keeps such work in the calling process."""
        if self._rebuild is None:
            import pickle

            raise pickle.PicklingError("these registries were built in this process (plugins "
                                       "registered at run time or given by hand)")
        return (self._rebuild, ())

    def _get(self, kind: str) -> dict:
        value = self._values.get(kind)
        if value is None:
            loader = self._loaders.get(kind)
            value = dict(loader()) if loader is not None else {}
            self._values[kind] = value
        return value

    @property
    def operations(self) -> dict[str, OperationSpec]:
        return self._get("operations")

    @property
    def functions(self) -> dict[str, FunctionSpec]:
        return self._get("functions")

    @property
    def constraints(self) -> dict[str, ConstraintSpec]:
        return self._get("constraints")

    @property
    def exporters(self) -> dict[str, ExporterSpec]:
        return self._get("exporters")

    @property
    def backends(self) -> dict[str, BackendSpec]:
        return self._get("backends")

    @property
    def fits(self) -> dict[str, FitSpec]:
        return self._get("fits")

