"""Batch derivation: a building per lot, or a dataset of variations, on any executor.

    from grammarkit.run.batch import run_batch
    from grammarkit.run.executor import make_executor

    # one building per lot polygon of a GeoJSON file
    summary = run_batch("grammars/lots/block.grammar", "grammars/lots/block.geojson", "out/city",
                        merge="out/city.glb")

    # 100 variations with sketch and shaded renders and a Parquet index, on a Dask LocalCluster
    with make_executor("dask", 2) as ex:
        run_batch("grammars/paris.grammar", 100, "out/ds", render=("sketch", "shaded"),
                  index="parquet", executor=ex)

What gets written (grammarkit.run.writer's resumable folder):

- one model per item (`<id>.glb`), its renders (`<id>.sketch.png`, ...), all of one item
  written as one transaction, then its line in `manifest.jsonl`: id, index, seed, status
  ("ok" or "failed"), error, attrs, bindings, metrics (triangles, seconds), and for lots the
  lot's id, feature, polygon number, area;
- when every item is done: `index.jsonl` (and `index.parquet`), `dataset.json`
  (grammarkit.run.dataset) and, on request, the merged model of all items (`merge=`).

`run_batch` is the split back end (grammarkit.run.split_backend) run through
`grammarkit.run.run_backend` with `dataset=True`: the same request, executor, writer and
`RunSummary` as `grammarkit derive`; this module checks the batch's own arguments, reads the
lots and writes the index and the merged model once the items are in.

Each item depends only on the run's seed, its own seed and attrs, and the grammar: never on the
executor, the number of workers or where a run was interrupted. A failing item is recorded
with its error and the batch goes on (`fail_fast=True` stops at the first one, without
recording it). A write that fails (full disk, unwritable folder) stops the batch with the
manifest listing exactly the complete items; running the same batch again continues it.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from ..errors import GrammarkitError, LimitError
from ..fileio import OutputError
from .api import RunSummary, _registries
from .split_backend import MAX_RENDER_SIZE, RENDER_STYLES, BatchFailed, SplitOptions, check_renders
from .writer import WriteStopped

__all__ = ["BatchFailed", "BatchSummary", "RENDER_STYLES", "merge_models", "run_batch"]

BatchSummary = RunSummary  # the name batch's summary had; it is the one run summary
MAX_MERGE_TRIANGLES = 20_000_000  # a merged model beyond this is too big to hold and view
MAX_ITEMS = 10_000_000


def _footprint_warning(grammar: Any) -> str | None:
    """Lots are the axiom's face; an axiom rule that starts with footprint() discards it."""
    rules = getattr(grammar, "rules", ())
    if not rules:
        return None
    axiom = rules[0]
    items = getattr(getattr(axiom, "body", None), "items", ()) or ()
    first = items[0] if items else None
    if getattr(first, "kind", None) == "op" and getattr(first, "name", None) == "footprint":
        span = getattr(first, "span", None)
        where = f"{span}: " if span is not None else ""
        return (f"{where}the axiom rule {axiom.name!r} starts with footprint(), which replaces each "
                "lot's polygon: the buildings stand at their lots but do not follow their shapes "
                "(grammars/lots/block.grammar builds on the lot itself)")
    return None


def _load(grammar: Any, registries: Any) -> Any:
    from ..split import load_grammar

    g = load_grammar(grammar, registries)
    if g.family != "split":
        raise GrammarkitError(f"batch derives split grammars; {g.source_path or g.name} is a "
                              f"{g.family} grammar (use grammarkit derive --backend for its back ends)")
    return g


def merge_models(folder: str | Path, entries: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """One GLB of every ok item's GLB (grammarkit.run.merge), written atomically to `path`."""
    from .merge import merge_glb

    folder, path = Path(folder), Path(path)
    ok = [e for e in entries if e.get("status", "ok") == "ok" and e.get("file")]
    triangles = sum(int((e.get("metrics") or {}).get("triangles") or 0) for e in ok)
    if triangles > MAX_MERGE_TRIANGLES:
        raise GrammarkitError(f"{path}: not merged: the {len(ok)} models have {triangles:,} triangles "
                              f"(more than {MAX_MERGE_TRIANGLES:,}); use the per-item files")
    if not ok:
        raise GrammarkitError(f"{path}: not merged: no item was built")
    return merge_glb([(e["id"], folder / e["file"]) for e in ok], path)


class _Progress:
    """run_batch's `progress(done, total, entry)`, fed by the run layer: the back end's first
    progress call gives the items done before this run, each written entry one more."""

    def __init__(self, progress: Callable | None, total: int):
        self.progress, self.total = progress, total
        self.done = 0
        self.started = False

    def factory(self, description: str, total: int | None = None) -> Callable[..., None]:
        def advance(n: int = 1, **fields: Any) -> None:
            if not self.started:  # the split back end's advance(start), before any item
                self.started = True
                self.done = n
                if self.progress is not None:
                    self.progress(n, self.total, None)
        return advance

    def on_result(self, entry: dict) -> None:
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total, entry)


def _check_numbers(render_size: Any, index: str, timeout: Any, time_limit: Any) -> None:
    if isinstance(render_size, bool) or not isinstance(render_size, int) \
            or not 16 <= render_size <= MAX_RENDER_SIZE:
        raise GrammarkitError(f"render size must be a whole number of pixels in [16, {MAX_RENDER_SIZE}], "
                              f"got {render_size!r}")
    if index not in ("jsonl", "parquet"):
        raise GrammarkitError(f"index must be 'jsonl' or 'parquet', not {index!r}")
    for what, value in (("timeout", timeout), ("time_limit", time_limit)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                  or not value > 0):
            raise GrammarkitError(f"{what} must be a positive number of seconds, got {value!r}")


def _check_limits(limits: Mapping[str, Any] | None) -> dict[str, Any]:
    from ..split import Limits

    values = {k: v for k, v in dict(limits or {}).items() if v is not None}
    try:
        Limits(**values)
    except TypeError as exc:
        raise GrammarkitError(f"limits: {exc}") from None
    return values


def run_batch(grammar: Any, items: Any, out: str | Path, *, executor: Any = None,
              workers: int | None = None, seed: int = 0, attrs: Mapping[str, Any] | None = None,
              sample: bool | None = None, format: str = "glb",
              render: Sequence[str] | str | None = None, render_size: int = 256,
              merge: str | Path | None = None, index: str = "jsonl", fail_fast: bool = False,
              overwrite: bool = False, timeout: float | None = None,
              time_limit: float | None = None, limits: Mapping[str, int] | None = None, degrees: str = "project",
              holes: str = "refuse", units: str = "auto",
              progress: Callable[[int, int, dict | None], None] | None = None,
              registries: Any = None) -> RunSummary:
    """Derive a batch into the folder `out` (see the module docstring).

    items:    a lots file (path to .geojson/.json/.shp), a `LotSet` from
              `grammarkit.run.lots.read_lots`, or an int N (N variations of the grammar).
    executor: an Executor (`make_executor("dask", 2)`; not closed here) or None (local
              processes, at most `workers`).
    seed:     run seed. Variation i depends on (seed, i); a lot on its own seed (its `seed`
              property, else a hash of the run seed and its id).
    attrs:    attr overrides for every item (lots' own attrs override these).
    sample:   variations: resample ranged attrs, re-roll choices and swap snippets (default
              True); False derives seeds seed..seed+N-1 with the given attrs. Lots: not
              available (a lot's attrs come from its properties).
    render:   PNG renders per item: "sketch", "lines", "shaded", "shaded+lines" (the default
              camera: pitch 30, yaw -45, fov 45, framed), `render_size` pixels square.
    merge:    also write every ok model into one GLB (a .glb path; items in glb) at the end.
    index:    "jsonl" (always written) or "parquet" (also index.parquet; needs pyarrow).
    timeout:  the hard stop: a LimitError after this many seconds (resumable).
    time_limit: the graceful budget: no new item is started after this many seconds, the
              items made are written and indexed, and `summary.shortfall` says so.
    progress: `progress(done, total, entry)`: once at the start (entry None), then per item
              written.
    degrees, holes, units: how lots are read (grammarkit.run.lots.read_lots).

    Returns the run's `RunSummary` (`kind`, `ok`, `failed`, `failures`, `index`, `merged`).
    """
    from ..jsonable import to_jsonable
    from ..split import check_attrs
    from .api import run_backend  # looked up per call: tests/run/test_one_path.py watches it

    if isinstance(seed, bool) or not isinstance(seed, int):
        raise GrammarkitError(f"seed must be an integer, got {seed!r}")
    registries = _registries(registries)
    g = _load(grammar, registries)
    fmt = str(format).lower().lstrip(".")
    if fmt not in registries.exporters:
        raise GrammarkitError(f"unknown output format {fmt!r}; known formats: "
                              f"{', '.join(sorted(registries.exporters))}")
    renders = check_renders(render)
    _check_numbers(render_size, index, timeout, time_limit)
    attrs = dict(attrs or {})
    check_attrs(g, attrs, registries=registries)  # a bad --set fails before any work
    limit_values = _check_limits(limits)
    batch = _resolve_items(g, items, sample, seed=seed, degrees=degrees, holes=holes, units=units)
    merge_path = _check_merge(merge, fmt, Path(out), g, batch)

    options = SplitOptions(variations=batch.sample, dataset=True, fail_fast=fail_fast,
                           renders=renders, render_size=render_size, **limit_values)
    index_info = {"kind": batch.mode, "seed": seed, "format": fmt,
                  "renders": {"styles": list(renders), "size": render_size} if renders else None,
                  "lots": batch.lots_info}
    finish = _finisher(g, batch, index_info, parquet=index == "parquet", overwrite=overwrite,
                       merge_path=merge_path, registries=registries)
    counter = _Progress(progress, batch.n)
    try:
        summary = run_backend(
            g, out=out, backend="split", n=batch.n, seed=seed, attrs=attrs, options=options,
            executor=executor, workers=workers, format=fmt, progress=counter.factory,
            timeout=timeout, time_limit=time_limit, overwrite=overwrite,
            inputs=tuple(batch.inputs), registries=registries, on_result=counter.on_result,
            items=batch.lotset.lots if batch.lotset is not None else None,
            run_info={"kind": batch.mode, "lots": to_jsonable(batch.lots_info)}, finish=finish)
    except GrammarkitError as exc:
        raise _batch_error(exc, counter.done, batch.n, f"{Path(out)}/manifest.jsonl",
                           timeout) from None
    if summary.shortfall is not None:
        summary.shortfall += "; run the same command again to continue"
    return summary


@dataclass
class _Items:
    """What a batch derives: N variations, or a building per lot of `lotset`."""

    mode: str  # "variations" or "lots"
    n: int
    sample: bool
    lotset: Any  # a LotSet, or None for variations
    inputs: list[Path]  # files no output may replace (the grammar, the lots file)
    warnings: list[str] = field(default_factory=list)

    @property
    def lots_info(self) -> dict | None:
        return self.lotset.describe() if self.lotset is not None else None

    def ids(self, grammar: Any) -> set[str]:
        if self.lotset is not None:
            return {lot.id for lot in self.lotset.lots}
        return {f"{grammar.name or 'model'}_{i:06d}" for i in range(self.n)}


def _resolve_items(g: Any, items: Any, sample: bool | None, *, seed: int, degrees: str, holes: str,
                   units: str) -> _Items:
    """run_batch's `items` (a lots file, a LotSet or a number of variations), checked."""
    from .lots import LotSet, read_lots

    inputs = [Path(g.source_path)] if getattr(g, "source_path", None) else []
    if isinstance(items, bool):
        raise GrammarkitError("items must be a lots file, a LotSet or a number of variations")
    if isinstance(items, int):
        if not 1 <= items <= MAX_ITEMS:
            raise GrammarkitError(f"the number of variations must be in [1, {MAX_ITEMS:,}], got {items}")
        return _Items("variations", items, True if sample is None else bool(sample), None, inputs)
    lotset = items if isinstance(items, LotSet) else read_lots(
        items, seed=seed, degrees=degrees, holes=holes, units=units)
    inputs.append(lotset.path)
    if sample:
        raise GrammarkitError("sampled attrs (--attrs sample) apply to --variations; a lot's attrs "
                              "come from its properties (attrs, attr.<name>) and --set")
    batch = _Items("lots", len(lotset.lots), False, lotset, inputs)
    hint = _footprint_warning(g)
    if hint:
        batch.warnings.append(hint)
    if lotset.projection is not None:
        p = lotset.projection
        batch.warnings.append(f"{lotset.path}: coordinates are lon/lat degrees; projected to metres "
                              f"(local equirectangular about lon {p['lon0']:.6f}, lat {p['lat0']:.6f})")
    return batch


def _check_merge(merge: str | Path | None, fmt: str, out: Path, g: Any, batch: _Items) -> Path | None:
    """The --merge path, checked against the format, the inputs and the items' own files."""
    from .writer import check_outputs

    merge_path = Path(merge) if merge is not None else None
    if merge_path is not None and (fmt != "glb" or merge_path.suffix.lower() != ".glb"):
        raise GrammarkitError(f"--merge {merge_path}: merging writes one GLB of the items' GLB files; "
                              "use --format glb and a .glb name")
    check_outputs({"-o": out, "--merge": merge_path}, inputs=batch.inputs)
    if merge_path is not None and merge_path.parent.resolve() == out.resolve():
        if merge_path.stem in batch.ids(g) or merge_path.name in ("manifest.jsonl", "run.json"):
            raise OutputError(f"{merge_path}: --merge would overwrite an item's file in {out}; "
                              "choose another name")
    return merge_path


def _finisher(g: Any, batch: _Items, info: dict, *, parquet: bool, overwrite: bool,
              merge_path: Path | None, registries: Any) -> Callable[[Any, RunSummary], None]:
    """run_backend's `finish` step of a batch: the index and the merged model."""

    def finish(folder: Any, summary: RunSummary) -> None:
        """With the folder still locked: the index and the merged model of what is in it."""
        summary.kind, summary.warnings = batch.mode, batch.warnings
        if folder.done > batch.n:
            raise GrammarkitError(f"{folder.path}: holds {folder.done} items of this run, more than "
                                  f"the {batch.n} asked for now; ask for at least {folder.done}")
        from .dataset import DATASET_JSON, INDEX_JSONL, INDEX_PARQUET, write_index

        if overwrite:  # an earlier run's index describes items that are gone
            for stale in (INDEX_JSONL, INDEX_PARQUET, DATASET_JSON):
                (folder.path / stale).unlink(missing_ok=True)
        entries = folder.entries
        if entries:
            from ..geometry.camera import Camera

            full = {"grammar": g.name, "grammar_hash": folder.run["grammar_hash"], **info}
            if full["renders"] is not None:
                full["renders"] = {**full["renders"], "camera": asdict(Camera())}
            summary.index = write_index(folder.path, grammar=g, entries=entries, parquet=parquet,
                                        info=full, registries=registries)
        if merge_path is not None:
            summary.merged = merge_models(folder.path, entries, merge_path)

    return finish


def _batch_error(exc: GrammarkitError, done: int, n: int, where: str,
                 timeout: float | None) -> GrammarkitError:
    """A run layer's stop said in a batch's terms (items, how to continue), or `exc` itself."""
    if isinstance(exc, BatchFailed):
        return BatchFailed(f"{exc} (stopped at the first failure: --fail-fast; {done} "
                           f"items are complete in {where})")
    if isinstance(exc, WriteStopped):
        return WriteStopped(exc.what, exc.done, "batch", "items")
    code = exc.diagnostics[0].code
    if isinstance(exc, LimitError) and code == "timeout":
        return LimitError(f"the batch's time budget (--timeout {timeout:g} s) is spent after "
                          f"{done} of {n} items; run the same command again to continue",
                          None, code="timeout")
    if code == "executor" and not isinstance(exc, LimitError):
        return GrammarkitError(f"{exc}; {done} items are complete in {where}; run the "
                               "same command again to continue")
    return exc
