"""The split engine as the built-in `split` back end (entry point `split-backend`).

Result `i` of a run is

- without `variations`: the grammar derived with seed `seed + i` and the given attrs (so a
  one-result run is exactly `grammarkit.derive(grammar, seed=seed, attrs=attrs)`);
- with `variations` (Nishida 2016): variation `i` of `grammarkit.split.variations`: attrs
  resampled in their ranges, stochastic choices re-rolled, snippets swapped per `variants`.

Either way a result depends only on (seed, i). When the run is written to files, each item is
derived and encoded in whichever process the executor picks (models do not cross processes;
their bytes do); in memory (`iter_results`) the Model objects are yielded.

This module stays light (pydantic only): the engine is imported when a run starts.
"""
from __future__ import annotations

import time
from typing import Any, Iterator, Optional

from pydantic import BaseModel, ConfigDict, Field

from ..hookspecs import hookimpl
from .backend import BackendSpec, Request, Result


class SplitOptions(BaseModel):
    """Options of the `split` back end (`--option key=value`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    variations: bool = Field(False, description="resample ranged attrs, re-roll choices and swap "
                             "snippets per result (Nishida 2016 variations)")
    tree: bool = Field(False, description="attach the derivation tree as <id>.tree.json")
    max_depth: Optional[int] = Field(None, ge=1, description="rule applications along one path")
    max_shapes: Optional[int] = Field(None, ge=1, description="shapes per derivation")
    max_triangles: Optional[int] = Field(None, ge=1, description="triangles of one model")


def _limits(options: SplitOptions) -> Any:
    from ..split import Limits

    given = {k: getattr(options, k) for k in ("max_depth", "max_shapes", "max_triangles")
             if getattr(options, k) is not None}
    return Limits(**given)


def _model_entry(model: Any, seconds: float) -> tuple[dict, dict]:
    metrics = {"triangles": model.triangle_count, "terminals": len(model.parts),
               "shapes": model.shape_count, "seconds": round(seconds, 4)}
    extra = {"attrs": model.attrs, "bindings": model.bindings}
    if model.warnings:
        extra["warnings"] = list(model.warnings)
    messages = list(getattr(model, "messages", ()) or ())
    if messages:  # CGA's print(): the command line shows them
        extra["messages"] = messages
    return metrics, extra


class _State:
    """What every process deriving items of one run holds (built once per process)."""

    def __init__(self, grammar: Any, seed: int, attrs: dict, options: SplitOptions,
                 exporter: Any, preview: bool, registries: Any):
        self.grammar, self.seed, self.attrs = grammar, seed, attrs
        self.options, self.exporter, self.preview = options, exporter, preview
        # the installed plugins' registries travel by reference (grammarkit.registry); others
        # cannot be pickled, and the executor then keeps the work in this process
        self.registries = registries
        self.limits = _limits(options)
        self.name = grammar.name or "model"


def _init_state(grammar: Any, seed: int, attrs: dict, options: SplitOptions, exporter: Any,
                preview: bool, registries: Any) -> _State:
    return _State(grammar, seed, attrs, options, exporter, preview, registries)


def _derive_item(state: _State, index: int) -> Result:
    """Derive result `index`; encode it (and its attachments) when the run writes files."""
    from ..split import derive, variations

    t0 = time.perf_counter()
    if state.options.variations:
        (var, model), = variations(state.grammar, 1, seed=state.seed, attrs=state.attrs,
                                   limits=state.limits, start=index, registries=state.registries)
        seed = var.seed
    else:
        seed = state.seed + index
        model = derive(state.grammar, seed=seed, attrs=state.attrs, limits=state.limits,
                       registries=state.registries)
    metrics, extra = _model_entry(model, time.perf_counter() - t0)
    attachments: dict[str, bytes | str] = {}
    if state.options.tree:
        attachments["tree.json"] = model.tree_json(indent=1)
    payload: Any = model
    if state.exporter is not None:
        from ..geometry.exporters import encode_with

        payload = encode_with(state.exporter, model)
        if state.preview:
            from .api import preview_png

            attachments["png"] = preview_png(model)
    return Result(id=f"{state.name}_{index:04d}", index=index, model=payload, seed=seed,
                  metrics=metrics, extra=extra, attachments=attachments)


def run(request: Request) -> Iterator[Result]:
    from ..split import check_attrs

    attrs = dict(request.attrs)
    check_attrs(request.grammar, attrs, registries=request.registries)  # fails before any work
    options = request.options or SplitOptions()
    indices = range(request.start, request.n)
    if request.format is None:
        # in memory: Model objects cannot cross processes, so derive here
        state = _State(request.grammar, request.seed, attrs, options, None, False,
                       request.registries)
        for i in indices:
            request.check_deadline()
            if request.time_is_up():
                return {}  # the graceful budget: stop before the next model
            yield _derive_item(state, i)
        return {}
    advance = request.progress(f"deriving {request.n} models of {request.grammar.name or 'model'}",
                               request.n)
    if request.start:
        advance(request.start)
    exporter = request.registries.exporters[request.format]  # the run layer checked the format
    with request.executor.session(_init_state, request.grammar, request.seed, attrs, options,
                                  exporter, request.preview, request.registries) as session:
        for result in session.map(_derive_item, indices):
            request.check_deadline()
            advance(1, file=result.id)
            yield result
            if request.time_is_up():
                break  # the graceful budget: the models out are cancelled, the written kept
    return {}


BACKEND = BackendSpec(
    name="split",
    summary="the split-grammar engine: buildings from CGA-style rules (and their variations)",
    families=frozenset({"split"}),
    run=run,
    options=SplitOptions,
    default_for=frozenset({"split"}),
)


@hookimpl
def grammarkit_backends() -> list[BackendSpec]:
    return [BACKEND]
