"""The split engine as the built-in `split` back end (entry point `split-backend`).

Result `i` of a run is

- without `variations`: the grammar derived with seed `seed + i` and the given attrs (so a
  one-result run is exactly `grammarkit.derive(grammar, seed=seed, attrs=attrs)`);
- with `variations` (Nishida 2016): variation `i` of `grammarkit.split.variations`: attrs
  resampled in their ranges, stochastic choices re-rolled, snippets swapped per `variants`;
- with lots (`request.items`, a `grammarkit.run.lots.Lot` each, as `grammarkit batch --lots`
  gives them): a building on lot `i`'s polygon, with the lot's seed, attrs and choices.

Either way a result depends only on (seed, i) and the grammar (and lot `i`). When the run is
written to files, each item is derived, encoded and rendered in whichever process the executor
picks (models do not cross processes; their bytes do); in memory (`iter_results`) the Model
objects are yielded.

A `dataset` run (what `grammarkit batch` asks for) records every item: a failing one becomes a
manifest line with status "failed" and its error, and the run goes on (`fail_fast`: it stops,
without recording the failure); ids have six digits and the metrics time each phase.

This module stays light (pydantic only): the engine is imported when a run starts.
"""
from __future__ import annotations

import time
from typing import Any, Generator, Literal, Optional

from pydantic import BaseModel, ConfigDict, Field, field_validator

from ..errors import GrammarkitError
from ..hookspecs import hookimpl
from .backend import BackendSpec, Request, Result

__all__ = ["BACKEND", "BatchFailed", "RENDER_STYLES", "SplitOptions", "check_renders", "run"]

# name -> (renderer style, sketchy line style)
RENDER_STYLES = {"sketch": ("lines", True), "lines": ("lines", False), "shaded": ("shaded", False),
                 "shaded+lines": ("shaded+lines", False)}
MAX_RENDER_SIZE = 2048
LIMITS = ("max_depth", "max_shapes", "max_repeat", "max_triangles", "max_extent", "max_solids")


class BatchFailed(GrammarkitError):
    """An item failed and the run was asked to stop at the first failure (fail_fast)."""


def check_renders(render: Any) -> tuple[str, ...]:
    """Render style names from "sketch,shaded" or a sequence; unknown or repeated ones refused."""
    if render is None:
        return ()
    names = [r.strip() for r in (render.split(",") if isinstance(render, str) else render)]
    names = [n for n in names if n]
    for n in names:
        if n not in RENDER_STYLES:
            raise GrammarkitError(f"unknown render style {n!r}; known styles: "
                                  f"{', '.join(RENDER_STYLES)}")
    if len(set(names)) != len(names):
        raise GrammarkitError(f"render styles given twice: {', '.join(names)}")
    return tuple(names)


class SplitOptions(BaseModel):
    """Options of the `split` back end (`--option key=value`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    variations: bool = Field(False, description="resample ranged attrs, re-roll choices and swap "
                             "snippets per result (Nishida 2016 variations)")
    tree: bool = Field(False, description="attach the derivation tree as <id>.tree.json")
    max_depth: Optional[int] = Field(None, ge=1, description="rule applications along one path")
    max_shapes: Optional[int] = Field(None, ge=1, description="shapes per derivation")
    max_triangles: Optional[int] = Field(None, ge=1, description="triangles of one model")
    max_repeat: Optional[int] = Field(None, ge=1, description="repetitions of one repeat group")
    max_solids: Optional[int] = Field(None, ge=1, description="solids fed to the final union")
    max_extent: Optional[float] = Field(None, gt=0, allow_inf_nan=False,
                                        description="largest coordinate or size of a solid (m)")
    renders: tuple[str, ...] = Field((), description="PNG renders attached to each result as "
                                     "<id>.<style>.png: sketch, lines, shaded, shaded+lines")
    render_size: int = Field(256, ge=16, le=MAX_RENDER_SIZE, description="render width and "
                             "height in pixels")
    surfaces: Literal["solid", "cga"] = Field("solid", description="solid: one watertight "
                                              "solid per mass; cga: CityEngine's open faces")
    dataset: bool = Field(False, description="record every item as grammarkit batch does: a "
                          "failing one is listed with its error and the run goes on")
    # how the run treats a failure, not what it makes: left out of run.json (exclude), so the
    # same batch continues with or without it
    fail_fast: bool = Field(False, exclude=True, description="dataset: stop at the first "
                            "failing item (not recorded)")

    @field_validator("renders", mode="before")
    @classmethod
    def _renders(cls, value: Any) -> tuple[str, ...]:
        try:
            return check_renders(value)
        except GrammarkitError as exc:  # pydantic reports a ValueError as the option's problem
            raise ValueError(str(exc)) from None


def _limits(options: SplitOptions) -> Any:
    from ..split import Limits

    given = {k: getattr(options, k) for k in LIMITS if getattr(options, k) is not None}
    return Limits(**given)


def _message(exc: BaseException) -> str:
    """One line saying what went wrong, with the grammar location when there is one."""
    if isinstance(exc, GrammarkitError):
        d = exc.diagnostics[0]
        where = f"{d.span}: " if d.span is not None and d.span.line else ""
        return f"{where}{d.message}"
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


def _render(model: Any, name: str, size: int, seed: int) -> bytes:
    import io

    from ..geometry.render import LineStyle, render

    style, sketchy = RENDER_STYLES[name]
    line_style = LineStyle.sketch(seed=seed & 0x7FFFFFFF) if sketchy else None
    image = render(model, style=style, size=(size, size), line_style=line_style)
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return buf.getvalue()


class _State:
    """What every process deriving items of one run holds (built once per process)."""

    def __init__(self, grammar: Any, seed: int, attrs: dict, options: SplitOptions,
                 exporter: Any, preview: bool, registries: Any):
        from ..split import compile as compile_split

        self.grammar, self.seed, self.attrs = grammar, seed, attrs
        self.options, self.exporter, self.preview = options, exporter, preview
        # the installed plugins' registries travel by reference (grammarkit.registry); others
        # cannot be pickled, and the executor then keeps the work in this process
        self.registries = registries
        self.limits = _limits(options)
        self.name = grammar.name or "model"
        try:  # once per process, not in the first item's time
            compile_split(grammar, registries=registries)
        except GrammarkitError:
            pass  # the first item's derive reports it, as the item's error

    def result_id(self, index: int, lot: Any) -> str:
        if lot is not None:
            return str(lot.id)
        return f"{self.name}_{index:06d}" if self.options.dataset else f"{self.name}_{index:04d}"


def _init_state(grammar: Any, seed: int, attrs: dict, options: SplitOptions, exporter: Any,
                preview: bool, registries: Any) -> _State:
    return _State(grammar, seed, attrs, options, exporter, preview, registries)


def _derive(state: _State, index: int, lot: Any) -> tuple[Any, int | None]:
    """The model of item `index` (on `lot`, if given) and the seed it was made from."""
    from ..split import derive, variations

    if lot is not None:
        model = derive(state.grammar, seed=lot.seed, attrs={**state.attrs, **lot.attrs},
                       limits=state.limits, lot=lot.polygon, choices=dict(lot.choices) or None,
                       registries=state.registries, surfaces=state.options.surfaces)
        return model, lot.seed
    if state.options.variations:
        (var, model), = variations(state.grammar, 1, seed=state.seed, attrs=state.attrs,
                                   limits=state.limits, start=index, registries=state.registries,
                                   surfaces=state.options.surfaces)
        return model, var.seed
    seed = state.seed + index
    return derive(state.grammar, seed=seed, attrs=state.attrs, limits=state.limits,
                  registries=state.registries, surfaces=state.options.surfaces), seed


def _lot_fields(lot: Any) -> dict[str, Any]:
    fields = {"lot": lot.source_id if lot.source_id is not None else lot.id,
              "feature": lot.feature, "part": lot.part, "area_m2": round(lot.area, 3)}
    if lot.note:
        fields["note"] = lot.note
    return fields


def _failed(state: _State, index: int, lot: Any, seed: int | None, error: str,
            metrics: dict) -> Result:
    """The record of an item that could not be made (dataset runs)."""
    extra: dict[str, Any] = {"status": "failed", "error": error, "attrs": {}, "bindings": {}}
    if lot is not None:
        extra.update(_lot_fields(lot))
    return Result(id=state.result_id(index, lot), index=index, model=None, seed=seed,
                  metrics=metrics, extra=extra)


def _derive_item(state: _State, item: Any) -> Result:
    """Derive result `item` (an index, or (index, lot)); encode and render it when the run
    writes files. In a dataset run a failure is the item's record; otherwise it is raised."""
    index, lot = item if isinstance(item, tuple) else (item, None)
    opts = state.options
    seed: int | None = lot.seed if lot is not None else (
        None if opts.variations else state.seed + index)
    if lot is not None and lot.error is not None:  # an unusable polygon: nothing to derive
        if not opts.dataset:
            raise GrammarkitError(lot.error)
        return _failed(state, index, lot, seed, lot.error, {})
    t0 = time.perf_counter()
    try:
        model, seed = _derive(state, index, lot)
        t1 = time.perf_counter()
        payload: Any = model
        attachments: dict[str, bytes | str] = {}
        if opts.tree:
            attachments["tree.json"] = model.tree_json(indent=1)
        if state.exporter is not None:
            from ..geometry.exporters import encode_with

            payload = encode_with(state.exporter, model)
            if state.preview:
                from .api import preview_png

                attachments["png"] = preview_png(model)
        t2 = time.perf_counter()
        for name in opts.renders:
            attachments[f"{name}.png"] = _render(model, name, opts.render_size, int(seed or 0))
        t3 = time.perf_counter()
    except Exception as exc:  # noqa: BLE001 - a dataset records it as this item's failure
        if not opts.dataset:
            raise
        what = f"lot {lot.source_id or lot.id!r}" if lot is not None else f"variation {index}"
        return _failed(state, index, lot, seed, f"{what}: {_message(exc)}",
                       {"seconds": round(time.perf_counter() - t0, 4)})
    metrics: dict[str, Any] = {"triangles": model.triangle_count, "terminals": len(model.parts)}
    if opts.dataset:
        metrics.update({"derive_s": round(t1 - t0, 4), "encode_s": round(t2 - t1, 4),
                        "render_s": round(t3 - t2, 4), "seconds": round(t3 - t0, 4)})
    else:
        metrics.update({"shapes": model.shape_count, "seconds": round(t1 - t0, 4)})
    extra: dict[str, Any] = {"status": "ok", "error": None} if opts.dataset else {}
    extra.update({"attrs": model.attrs, "bindings": model.bindings})
    if model.warnings:
        extra["warnings"] = list(model.warnings)
    messages = list(getattr(model, "messages", ()) or ())
    if messages:  # CGA's print(): the command line shows them
        extra["messages"] = messages
    if lot is not None:
        extra.update(_lot_fields(lot))
    return Result(id=state.result_id(index, lot), index=index, model=payload, seed=seed,
                  metrics=metrics, extra=extra, attachments=attachments)


def run(request: Request) -> Generator[Result, None, dict]:
    from ..split import check_attrs

    attrs = dict(request.attrs)
    check_attrs(request.grammar, attrs, registries=request.registries)  # fails before any work
    options = request.options or SplitOptions()
    items = request.items
    if items is not None and len(items) < request.n:
        raise GrammarkitError(f"the split back end was given {len(items)} items for "
                              f"{request.n} results")
    work: Any = range(request.start, request.n) if items is None else \
        [(i, items[i]) for i in range(request.start, request.n)]
    if request.format is None:
        # in memory: Model objects cannot cross processes, so derive here
        state = _State(request.grammar, request.seed, attrs, options, None, False,
                       request.registries)
        for item in work:
            request.check_deadline()
            if request.time_is_up():
                return {}  # the graceful budget: stop before the next model
            yield _checked(_derive_item(state, item), options)
        return {}
    advance = request.progress(f"deriving {request.n} models of {request.grammar.name or 'model'}",
                               request.n)
    advance(request.start)
    exporter = request.registries.exporters[request.format]  # the run layer checked the format
    with request.executor.session(_init_state, request.grammar, request.seed, attrs, options,
                                  exporter, request.preview, request.registries) as session:
        for result in session.map(_derive_item, work):
            advance(1, file=result.id)
            yield _checked(result, options)
            # after the yield: the result in hand is written before a spent budget stops the run
            request.check_deadline()
            if request.time_is_up():
                break  # the graceful budget: the models out are cancelled, the written kept
    return {}


def _checked(result: Result, options: SplitOptions) -> Result:
    """`result`, unless it records a failure and the run stops at the first one."""
    if options.fail_fast and result.extra.get("status") == "failed":
        raise BatchFailed(str(result.extra.get("error")))
    return result


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
