"""The back-end contract: a typed request in, results yielded out; no files touched.

Every back end (the built-in `split` engine, the graph sampler, and third-party ones) is a
`BackendSpec` returned by the `grammarkit_backends` hook. Its `run(request)` is a generator:

    def run(request: Request) -> Iterator[Result]:
        for index in range(request.start, request.n):
            model = ...                                   # a Model, an Assembly, a Scene
            yield Result(id=f"variant_{index:05d}", index=index, seed=..., model=model)

The run layer (`grammarkit.run.run_backend`) validates options, opens the output folder, hands
the results to the one writer (files + manifest.jsonl) and reports shortfalls. A back end
never writes files, never starts processes of its own (it asks `request.executor`), and
never reads the global plugin manager (`request.registries` has what it needs).

Determinism: a result must depend only on (request.seed, its index) and the grammar, never
on the number of workers or on how the run was split up.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Iterator, Mapping

if TYPE_CHECKING:  # pragma: no cover - types only
    from pydantic import BaseModel

    from ..ir.grammar import Grammar
    from .executor import Executor


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
    """

    grammar: "Grammar"
    n: int = 1
    seed: int = 0
    start: int = 0
    iterations: int = 1
    attrs: Mapping[str, Any] = field(default_factory=dict)
    options: Any = None
    executor: "Executor | None" = None
    registries: Any = None
    progress: Callable[..., Callable[..., None]] = _no_progress
    deadline: float | None = None
    soft_deadline: float | None = None
    format: str | None = None
    preview: bool = False

    def check_deadline(self) -> None:
        """Raise `grammarkit.errors.LimitError` once the run's time budget is spent."""
        if self.deadline is None:
            return
        import time

        if time.monotonic() > self.deadline:
            from ..errors import LimitError

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
