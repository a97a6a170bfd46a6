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

Each item depends only on the run's seed, its own seed and attrs, and the grammar: never on the
executor, the number of workers or where a run was interrupted. A failing item is recorded
with its error and the batch goes on (`fail_fast=True` stops at the first one, without
recording it). A write that fails (full disk, unwritable folder) stops the batch with the
manifest listing exactly the complete items; running the same batch again continues it.
"""
from __future__ import annotations

import io
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from ..errors import GrammarkitError, LimitError
from ..fileio import OutputError

__all__ = ["BatchFailed", "BatchSettings", "BatchSummary", "RENDER_STYLES", "merge_models",
           "run_batch"]

FORMAT_VERSION = 1
# name -> (renderer style, sketchy line style)
RENDER_STYLES = {"sketch": ("lines", True), "lines": ("lines", False), "shaded": ("shaded", False),
                 "shaded+lines": ("shaded+lines", False)}
MAX_RENDER_SIZE = 2048
MAX_MERGE_TRIANGLES = 20_000_000  # a merged model beyond this is too big to hold and view
MAX_ITEMS = 10_000_000


class BatchFailed(GrammarkitError):
    """An item failed and the batch was asked to stop at the first failure (fail_fast)."""


@dataclass(frozen=True)
class BatchSettings:
    """What every process deriving items of one batch holds (picklable; shipped once)."""

    grammar: Any
    mode: str  # "lots" or "variations"
    seed: int
    attrs: Mapping[str, Any]
    sample: bool  # variations: resample attrs, re-roll choices, swap snippets (Nishida 2016)
    exporter: Any  # the ExporterSpec of `fmt`
    fmt: str
    renders: tuple[str, ...]
    render_size: int
    limits: Mapping[str, int]


@dataclass
class BatchSummary:
    kind: str
    requested: int
    written: int = 0  # items recorded by this run (ok or failed)
    resumed: int = 0  # items already recorded by an earlier run
    ok: int = 0  # ok items in the folder
    failed: int = 0  # failed items in the folder
    out: Path | None = None
    manifest: Path | None = None
    index: list[Path] = field(default_factory=list)
    merged: Path | None = None
    failures: list[dict] = field(default_factory=list)  # the first few: {id, error}
    warnings: list[str] = field(default_factory=list)
    shortfall: str | None = None  # why fewer items than requested are in the folder
    executor: str = "local"
    workers: int = 1
    seconds: float = 0.0
    derive_seconds: float = 0.0  # summed over this run's items (the workers' time)
    write_seconds: float = 0.0  # spent writing this run's items (on the writer thread)

    @property
    def items_per_second(self) -> float:
        return self.written / self.seconds if self.seconds > 0 else 0.0

    def lines(self) -> list[str]:
        """The summary for people: what was written, what fell short and why."""
        out = [f"wrote {self.written} item{'s' if self.written != 1 else ''} to {self.out}/ "
               f"({self.ok} ok, {self.failed} failed in the folder; {self.seconds:.1f} s, "
               f"{self.items_per_second:.2f} items/s); manifest {self.manifest}"]
        if self.index:
            out.append("index: " + ", ".join(str(p) for p in self.index))
        if self.merged:
            out.append(f"merged model: {self.merged}")
        if self.shortfall:
            out.append(f"made {self.ok + self.failed} of {self.requested}: {self.shortfall}")
        return out

    def to_dict(self) -> dict:
        return {"kind": self.kind, "requested": self.requested, "written": self.written,
                "resumed": self.resumed, "ok": self.ok, "failed": self.failed,
                "out": str(self.out) if self.out else None,
                "manifest": str(self.manifest) if self.manifest else None,
                "index": [str(p) for p in self.index], "merged": str(self.merged) if self.merged else None,
                "failures": self.failures, "warnings": self.warnings, "shortfall": self.shortfall,
                "executor": self.executor,
                "workers": self.workers, "seconds": round(self.seconds, 3),
                "items_per_second": round(self.items_per_second, 3)}


# ---------------------------------------------------------------------------------------------
# the worker side
# ---------------------------------------------------------------------------------------------
class _WorkerState:
    def __init__(self, settings: BatchSettings):
        from ..split import Limits
        from ..split import compile as compile_split

        self.settings = settings
        self.limits = Limits(**dict(settings.limits))
        compile_split(settings.grammar)  # once per process, not in the first item's time
        self.name = settings.grammar.name or "model"


def _init_state(settings: BatchSettings) -> _WorkerState:
    return _WorkerState(settings)


def _message(exc: BaseException) -> str:
    """One line saying what went wrong, with the grammar location when there is one."""
    if isinstance(exc, GrammarkitError):
        d = exc.diagnostics[0]
        where = f"{d.span}: " if d.span is not None and d.span.line else ""
        return f"{where}{d.message}"
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


def _png(model: Any, name: str, size: int, seed: int) -> bytes:
    from ..geometry.render import LineStyle, render

    style, sketchy = RENDER_STYLES[name]
    line_style = LineStyle.sketch(seed=seed & 0x7FFFFFFF) if sketchy else None
    image = render(model, style=style, size=(size, size), line_style=line_style)
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return buf.getvalue()


def _make_item(state: _WorkerState, item: Any) -> dict:
    """Derive, encode and render one item; a failure is returned (recorded), never raised."""
    s = state.settings
    t0 = time.perf_counter()
    out: dict[str, Any] = {"ok": False, "error": None, "files": {}, "attrs": {}, "bindings": {},
                           "metrics": {}, "warnings": []}
    if s.mode == "lots":
        lot = item
        out["seed"] = lot.seed
        if lot.error is not None:
            out["error"] = lot.error
            return out
    else:
        out["seed"] = None if s.sample else s.seed + item
    try:
        from ..geometry.exporters import encode_with
        from ..split import derive, variations

        if s.mode == "lots":
            model = derive(s.grammar, seed=lot.seed, attrs={**s.attrs, **lot.attrs},
                           limits=state.limits, lot=lot.polygon, choices=dict(lot.choices) or None)
        elif s.sample:
            (var, model), = variations(s.grammar, 1, seed=s.seed, attrs=s.attrs, limits=state.limits,
                                       start=item)
            out["seed"] = var.seed
        else:
            model = derive(s.grammar, seed=s.seed + item, attrs=s.attrs, limits=state.limits)
        t1 = time.perf_counter()
        out["files"][s.fmt] = encode_with(s.exporter, model)
        t2 = time.perf_counter()
        for name in s.renders:
            out["files"][f"{name}.png"] = _png(model, name, s.render_size, int(out["seed"] or 0))
        t3 = time.perf_counter()
        out["ok"] = True
        out["attrs"], out["bindings"] = dict(model.attrs), dict(model.bindings)
        out["warnings"] = list(model.warnings)
        out["metrics"] = {"triangles": model.triangle_count, "terminals": len(model.parts),
                          "derive_s": round(t1 - t0, 4), "encode_s": round(t2 - t1, 4),
                          "render_s": round(t3 - t2, 4)}
    except Exception as exc:  # noqa: BLE001 - recorded as this item's failure; the batch goes on
        what = f"lot {lot.source_id or lot.id!r}" if s.mode == "lots" else f"variation {item}"
        out["error"] = f"{what}: {_message(exc)}"
        out["files"] = {}
    out["metrics"]["seconds"] = round(time.perf_counter() - t0, 4)
    return out


# ---------------------------------------------------------------------------------------------
# the parent side
# ---------------------------------------------------------------------------------------------
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


def _check_renders(render: Sequence[str] | str | None) -> tuple[str, ...]:
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


def _load(grammar: Any) -> Any:
    from ..split import load_grammar

    g = load_grammar(grammar)
    if g.family != "split":
        raise GrammarkitError(f"batch derives split grammars; {g.source_path or g.name} is a "
                              f"{g.family} grammar (use grammarkit derive --backend for its back ends)")
    return g


def _entry(outcome: dict, item: Any, mode: str, name: str, fmt: str) -> tuple[dict, dict]:
    """The manifest line and the files of one item's outcome."""
    if mode == "lots":
        item_id, index = item.id, item.index
    else:
        item_id, index = f"{name}_{item:06d}", item
    files = {f"{item_id}.{suffix}": data for suffix, data in outcome["files"].items()}
    attachments = {suffix: f"{item_id}.{suffix}" for suffix in outcome["files"] if suffix != fmt}
    entry: dict[str, Any] = {
        "id": item_id, "index": index, "seed": outcome.get("seed"), "parents": [],
        "metrics": outcome["metrics"], "file": f"{item_id}.{fmt}" if outcome["ok"] else None,
        "attachments": attachments, "status": "ok" if outcome["ok"] else "failed",
        "error": outcome["error"], "attrs": outcome["attrs"], "bindings": outcome["bindings"]}
    if outcome.get("warnings"):
        entry["warnings"] = outcome["warnings"]
    if mode == "lots":
        entry.update({"lot": item.source_id if item.source_id is not None else item.id,
                      "feature": item.feature, "part": item.part, "area_m2": round(item.area, 3)})
        if item.note:
            entry["note"] = item.note
    return entry, files


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


class _Writer:
    """Writes outcomes in item order on a thread of its own, so that writing an item (atomic
    files, an fsync'd manifest line and folder: ~10 ms on a local disk) overlaps with deriving
    the next ones instead of adding to them. At most `depth` outcomes wait (bounded memory).

    After a failed write nothing more is written (the manifest stays a prefix of the items);
    the error is raised in the caller's thread by the next `put` or by `close`."""

    def __init__(self, folder: Any, summary: BatchSummary, total: int,
                 progress: Callable | None, depth: int = 32):
        import queue
        import threading

        self.folder, self.summary, self.total, self.progress = folder, summary, total, progress
        self.queue: Any = queue.Queue(maxsize=depth)
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, name="grammarkit-batch-writer", daemon=True)
        self.thread.start()

    def put(self, entry: dict, files: dict, seconds: float) -> None:
        import queue

        while True:
            self.check()
            try:
                self.queue.put((entry, files, seconds), timeout=0.2)
                return
            except queue.Full:
                continue

    def check(self) -> None:
        if self.error is not None:
            raise self.error

    def close(self) -> None:
        """Write what is queued (unless a write failed) and stop the thread."""
        self.queue.put(None)
        self.thread.join()
        self.folder.sync()

    def _run(self) -> None:
        folder = self.folder
        while True:
            job = self.queue.get()
            if job is None:
                return
            if self.error is not None:
                continue  # after a failure: drop the rest, the manifest stays consistent
            entry, files, seconds = job
            t0 = time.perf_counter()
            try:
                folder.add(entry, files)
            except OSError as exc:  # a full disk, a folder gone read-only
                if isinstance(exc, OutputError):  # already names the path and the problem
                    what = str(exc)
                else:
                    what = f"{folder.path}: cannot write {entry['id']}: {exc.strerror or exc}"
                done = ("nothing was written" if folder.done == 0 else
                        f"manifest.jsonl lists the {folder.done} complete items")
                self.error = OutputError(f"{what}; the batch stopped ({done}); fix the cause and "
                                         "run the same command again to continue")
                continue
            except BaseException as exc:  # noqa: BLE001 - raised in the caller's thread
                self.error = exc
                continue
            self.summary.write_seconds += time.perf_counter() - t0
            self.summary.written += 1
            self.summary.derive_seconds += seconds
            if self.progress is not None:
                try:
                    self.progress(folder.done, self.total, entry)
                except BaseException as exc:  # noqa: BLE001 - a broken callback stops the batch
                    self.error = exc


def _consume(results: Any, todo: Sequence[Any], folder: Any, summary: BatchSummary, mode: str,
             name: str, fmt: str, fail_fast: bool, progress: Callable | None, total: int,
             deadline: float | None, timeout: float | None,
             soft_deadline: float | None = None) -> bool:
    """Record every outcome in item order (files and manifest line), or stop cleanly: what was
    handed to the writer before a stop is written first, so the manifest is a prefix."""
    writer = _Writer(folder, summary, total, progress)
    stop: BaseException | None = None
    try:
        for item, outcome in zip(todo, results, strict=True):
            entry, files = _entry(outcome, item, mode, name, fmt)
            if not outcome["ok"] and fail_fast:
                stop = BatchFailed(outcome["error"])
                break
            writer.put(entry, files, float(outcome["metrics"].get("seconds") or 0.0))
            if soft_deadline is not None and time.monotonic() > soft_deadline:
                stop = TimeoutError()  # graceful: what was handed over is written, the rest waits
                break
            if deadline is not None and time.monotonic() > deadline:
                stop = LimitError("the batch's time budget (--timeout) is spent", None, code="timeout")
                break
    finally:
        writer.close()
    writer.check()
    if isinstance(stop, BatchFailed):
        raise BatchFailed(f"{stop} (stopped at the first failure: --fail-fast; {folder.done} items "
                          f"are complete in {folder.path}/manifest.jsonl)")
    if isinstance(stop, TimeoutError):
        return True
    if stop is not None:
        raise LimitError(f"the batch's time budget (--timeout {timeout:g} s) is spent after "
                         f"{folder.done} of {total} items; run the same command again to continue",
                         None, code="timeout")
    return False


def run_batch(grammar: Any, items: Any, out: str | Path, *, executor: Any = None,
              workers: int | None = None, seed: int = 0, attrs: Mapping[str, Any] | None = None,
              sample: bool | None = None, format: str = "glb",
              render: Sequence[str] | str | None = None, render_size: int = 256,
              merge: str | Path | None = None, index: str = "jsonl", fail_fast: bool = False,
              overwrite: bool = False, timeout: float | None = None,
              time_limit: float | None = None, limits: Mapping[str, int] | None = None, degrees: str = "project",
              holes: str = "refuse", units: str = "auto",
              progress: Callable[[int, int, dict | None], None] | None = None,
              registries: Any = None) -> BatchSummary:
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
              written (called from the batch's writer thread).
    degrees, holes, units: how lots are read (grammarkit.run.lots.read_lots).
    """
    from ..jsonable import to_jsonable
    from ..split import check_attrs
    from .executor import make_executor
    from .lots import LotSet, read_lots
    from .writer import OutputFolder, check_outputs, grammar_hash

    t0 = time.perf_counter()
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise GrammarkitError(f"seed must be an integer, got {seed!r}")
    g = _load(grammar)
    if registries is None:
        from ..plugins import get_plugin_manager

        registries = get_plugin_manager().registries()
    fmt = str(format).lower().lstrip(".")
    exporter = registries.exporters.get(fmt)
    if exporter is None:
        raise GrammarkitError(f"unknown output format {fmt!r}; known formats: "
                              f"{', '.join(sorted(registries.exporters))}")
    renders = _check_renders(render)
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
    soft_deadline = None if time_limit is None else time.monotonic() + float(time_limit)
    attrs = dict(attrs or {})
    check_attrs(g, attrs)  # a bad --set fails before any work, pointing at the attr
    limit_values = {k: int(v) for k, v in dict(limits or {}).items() if v is not None}
    from ..split import Limits

    try:
        Limits(**limit_values)
    except TypeError as exc:
        raise GrammarkitError(f"limits: {exc}") from None

    inputs = [Path(g.source_path)] if getattr(g, "source_path", None) else []
    warnings: list[str] = []
    lotset: LotSet | None = None
    if isinstance(items, bool):
        raise GrammarkitError("items must be a lots file, a LotSet or a number of variations")
    if isinstance(items, int):
        if not 1 <= items <= MAX_ITEMS:
            raise GrammarkitError(f"the number of variations must be in [1, {MAX_ITEMS:,}], got {items}")
        mode, work = "variations", list(range(items))
        sample = True if sample is None else bool(sample)
    else:
        lotset = items if isinstance(items, LotSet) else read_lots(
            items, seed=seed, degrees=degrees, holes=holes, units=units)
        inputs.append(lotset.path)
        if sample:
            raise GrammarkitError("sampled attrs (--attrs sample) apply to --variations; a lot's attrs "
                                  "come from its properties (attrs, attr.<name>) and --set")
        mode, work, sample = "lots", list(lotset.lots), False
        hint = _footprint_warning(g)
        if hint:
            warnings.append(hint)
        if lotset.projection is not None:
            p = lotset.projection
            warnings.append(f"{lotset.path}: coordinates are lon/lat degrees; projected to metres "
                            f"(local equirectangular about lon {p['lon0']:.6f}, lat {p['lat0']:.6f})")
    merge_path = Path(merge) if merge is not None else None
    if merge_path is not None and (fmt != "glb" or merge_path.suffix.lower() != ".glb"):
        raise GrammarkitError(f"--merge {merge_path}: merging writes one GLB of the items' GLB files; "
                              "use --format glb and a .glb name")
    check_outputs({"-o": Path(out), "--merge": merge_path}, inputs=inputs)
    if merge_path is not None and merge_path.parent.resolve() == Path(out).resolve():
        ids = {w.id if mode == "lots" else f"{g.name or 'model'}_{w:06d}" for w in work}
        if merge_path.stem in ids or merge_path.name in ("manifest.jsonl", "run.json"):
            raise OutputError(f"{merge_path}: --merge would overwrite an item's file in {out}; "
                              "choose another name")

    run = {"version": FORMAT_VERSION, "backend": "batch", "kind": mode, "grammar": g.name,
           "grammar_hash": grammar_hash(g), "seed": seed, "attrs": to_jsonable(attrs),
           "sample": sample, "format": fmt, "renders": list(renders),
           "render_size": render_size if renders else None, "limits": limit_values,
           "lots": lotset.describe() if lotset is not None else None, "n": len(work)}
    # the folder stays locked until the index and the merged model are written too
    with OutputFolder(Path(out), run, protected=tuple(inputs), overwrite=overwrite) as folder:
        summary = BatchSummary(kind=mode, requested=len(work), resumed=min(folder.done, len(work)),
                               out=folder.path, manifest=folder.manifest, warnings=warnings)
        if folder.done > len(work):
            raise GrammarkitError(f"{folder.path}: holds {folder.done} items of this run, more than the "
                                  f"{len(work)} asked for now; ask for at least {folder.done}")
        if overwrite:
            from .dataset import DATASET_JSON, INDEX_JSONL, INDEX_PARQUET

            for stale in (INDEX_JSONL, INDEX_PARQUET, DATASET_JSON):
                (folder.path / stale).unlink(missing_ok=True)

        own_executor = executor is None
        if executor is None:
            executor = make_executor(None, workers)
        summary.executor = getattr(executor, "name", type(executor).__name__)
        summary.workers = int(getattr(executor, "workers", 1) or 1)
        deadline = None if timeout is None else time.monotonic() + float(timeout)
        settings = BatchSettings(grammar=g, mode=mode, seed=seed, attrs=attrs, sample=bool(sample),
                                 exporter=exporter, fmt=fmt, renders=renders, render_size=render_size,
                                 limits=limit_values)
        if progress is not None:
            progress(folder.done, len(work), None)
        todo = work[folder.done:]
        try:
            if todo:
                with executor.session(_init_state, settings) as session:
                    results = session.map(_make_item, todo)
                    try:
                        if _consume(results, todo, folder, summary, mode, g.name or "model", fmt,
                                    fail_fast, progress, len(work), deadline, timeout,
                                    soft_deadline):
                            summary.shortfall = (f"the time limit ({time_limit:g} s) was reached; "
                                                 "run the same command again to continue")
                    finally:
                        results.close()  # results still out are cancelled, not left running
        except (GrammarkitError, KeyboardInterrupt):
            raise
        except RuntimeError as exc:  # WorkerError: a worker process died, the cluster went away
            raise GrammarkitError(f"the {summary.executor} executor failed: {exc}; {folder.done} items "
                                  f"are complete in {folder.path}/manifest.jsonl; run the same command "
                                  "again to continue") from None
        finally:
            if own_executor:
                executor.close()

        entries = folder.entries
        summary.ok = sum(1 for e in entries if e.get("status", "ok") == "ok")
        summary.failed = len(entries) - summary.ok
        summary.failures = [{"id": e["id"], "error": e.get("error")} for e in entries
                            if e.get("status") == "failed"][:20]
        if entries:
            from ..geometry.camera import Camera
            from .dataset import write_index

            info = {"grammar": g.name, "grammar_hash": run["grammar_hash"], "kind": mode, "seed": seed,
                    "format": fmt, "renders": {"styles": list(renders), "size": render_size,
                                               "camera": asdict(Camera())} if renders else None,
                    "lots": run["lots"]}
            summary.index = write_index(folder.path, grammar=g, entries=entries,
                                        parquet=index == "parquet", info=info)
        if merge_path is not None:
            summary.merged = merge_models(folder.path, entries, merge_path)
        summary.seconds = time.perf_counter() - t0
        return summary
