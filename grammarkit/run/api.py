"""Running a back end: options validated, results written by the one writer, shortfalls said.

    from grammarkit.run import run_backend, iter_results

    summary = run_backend("castle.grammar", backend="graph-sampler", n=50, seed=7, out="variants/")
    print(summary.written, summary.shortfall)

    for result in iter_results("grammars/paris.grammar", n=3):     # in memory, nothing written
        result.model.mesh  # a split Model

`run_backend` is what `grammarkit derive` calls; every back end goes through it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Generator, Iterator, Mapping, Sequence

from ..errors import GrammarkitError, PluginError
from .backend import BackendSpec, Request, Result
from .executor_protocol import WorkerError
from .writer import ModelFile, OutputFolder, WriteStopped

__all__ = ["RunSummary", "iter_results", "resolve_backend", "run_backend", "FORMAT_VERSION"]

FORMAT_VERSION = 1  # of run.json / manifest.jsonl


@dataclass
class RunSummary:
    """What a run did: the one summary of `run_backend`, `grammarkit derive` and `batch`."""

    backend: str
    requested: int
    written: int  # results written by this run
    resumed: int  # results already in the folder from an earlier, interrupted run
    out: Path | None
    manifest: Path | None
    shortfall: str | None  # why fewer results than requested exist (None: all of them)
    stats: dict = field(default_factory=dict)  # the back end's own summary
    seconds: float = 0.0
    # the results in the output: ok, or recorded as failed (a dataset run lists a failing item
    # with its error and goes on); `failures` holds the first few as {id, error}
    ok: int = 0
    failed: int = 0
    failures: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    executor: str = "local"
    workers: int = 1
    # a dataset run (`grammarkit batch`): what its items are ("lots" or "variations"), the
    # index files made from its manifest and the merged model
    kind: str | None = None
    index: list[Path] = field(default_factory=list)
    merged: Path | None = None

    @property
    def total(self) -> int:
        return self.written + self.resumed

    @property
    def items_per_second(self) -> float:
        return self.written / self.seconds if self.seconds > 0 else 0.0

    def lines(self) -> list[str]:
        """The summary for people: what was written, what fell short and why."""
        if self.kind is not None:
            return self._dataset_lines()
        where = f" to {self.out}/" if self.out else ""
        out = [f"wrote {self.written} result{'s' if self.written != 1 else ''}{where} "
               f"({self.backend}, {self.seconds:.1f} s)"
               + (f"; manifest {self.manifest}" if self.manifest and self.total else "")]
        if self.shortfall:
            out.append(f"made {self.total} of {self.requested}: {self.shortfall}")
        return out

    def _dataset_lines(self) -> list[str]:
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
        from ..jsonable import to_jsonable

        def text(path: Path | None) -> str | None:
            return str(path) if path else None

        if self.kind is not None:
            return to_jsonable({
                "kind": self.kind, "requested": self.requested, "written": self.written,
                "resumed": self.resumed, "ok": self.ok, "failed": self.failed,
                "out": text(self.out), "manifest": text(self.manifest),
                "index": [str(p) for p in self.index], "merged": text(self.merged),
                "failures": self.failures, "warnings": self.warnings, "shortfall": self.shortfall,
                "executor": self.executor, "workers": self.workers,
                "seconds": round(self.seconds, 3),
                "items_per_second": round(self.items_per_second, 3)})
        return to_jsonable({"backend": self.backend, "requested": self.requested,
                            "written": self.written, "resumed": self.resumed,
                            "out": text(self.out), "manifest": text(self.manifest),
                            "shortfall": self.shortfall, "seconds": round(self.seconds, 3),
                            **({"stats": self.stats} if self.stats else {})})


def _registries(registries: Any) -> Any:
    if registries is not None:
        return registries
    from ..plugins import default_registries  # the run layer's one read of the installed plugins

    return default_registries()


def _grammar(grammar: Any, registries: Any) -> Any:
    from ..ir.grammar import Grammar

    if isinstance(grammar, Grammar) and not grammar.imports:
        return grammar
    from ..dsl import load

    if isinstance(grammar, str) and "\n" not in grammar and grammar.endswith(".grammar"):
        grammar = Path(grammar)
    return load(grammar, registries=registries)


def resolve_backend(grammar: Any, name: str | None, registries: Any) -> BackendSpec:
    """The back end `name`, or the default one for the grammar's family; checks the family."""
    backends = registries.backends
    family = grammar.family
    if family == "empty":
        from ..errors import GrammarError
        from ..ir.base import Span

        source = getattr(grammar, "source_path", None)
        raise GrammarError("the grammar has no rules and no parts: there is nothing to derive",
                           Span(file=source, line=1, column=1, end_line=1, end_column=1)
                           if source else None, code="empty-grammar",
                           hint="a split grammar starts with a rule, e.g. `Lot --> extrude(10) "
                                "Mass`; a tiling grammar declares parts, e.g. `part A = box(1, 1, 1)`")
    if name is not None:
        spec = backends.get(name)
        if spec is None:
            known = ", ".join(sorted(backends)) or "none installed"
            raise PluginError(f"unknown back end {name!r}; known back ends: {known}")
    else:
        spec = next((s for s in backends.values() if family in s.default_for), None)
        if spec is None:
            known = ", ".join(sorted(backends)) or "none installed"
            raise GrammarkitError(f"no default back end for {family} grammars; pass --backend NAME "
                                  f"(known: {known})")
    if family not in spec.families:
        raise GrammarkitError(f"back end {spec.name!r} does not derive {family} grammars "
                              f"(it accepts: {', '.join(sorted(spec.families))})")
    if spec.run is None:
        raise PluginError(f"back end {spec.name!r} (plugin {spec.plugin!r}) has no run function")
    return spec


def _plugin_failure(spec: BackendSpec, exc: BaseException) -> PluginError:
    return PluginError(f"back end {spec.name!r} (plugin {spec.plugin or 'unknown'!r}) failed: "
                       f"{type(exc).__name__}: {exc}")


def _drive(spec: BackendSpec, request: Request) -> Generator[Result, None, dict]:
    """Iterate a back end's generator, turning its crashes into errors that name it; returns
    the generator's return value (its summary, a dict)."""
    assert spec.run is not None  # resolve_backend refuses a back end without a run function
    gen = iter(spec.run(request))
    try:
        while True:
            try:
                result = next(gen)
            except StopIteration as stop:
                return stop.value if isinstance(stop.value, dict) else {}
            except (GrammarkitError, KeyboardInterrupt, MemoryError):
                raise
            except WorkerError as exc:  # a worker process died, the cluster went away
                name = getattr(request.executor, "name", type(request.executor).__name__)
                raise GrammarkitError(f"the {name} executor failed: {exc}",
                                      code="executor") from None
            except OSError as exc:
                from ..errors import ShapeError

                where = exc.filename or "a file"
                raise ShapeError(f"{where}: back end {spec.name!r}: {exc.strerror or exc}") from None
            except (Exception, SystemExit) as exc:  # noqa: BLE001 - a plugin bug: name it
                raise _plugin_failure(spec, exc) from None
            if not isinstance(result, Result):
                raise PluginError(f"back end {spec.name!r} (plugin {spec.plugin or 'unknown'!r}) "
                                  f"yielded a {type(result).__name__}, not a grammarkit.run.Result")
            yield result
    finally:
        close = getattr(gen, "close", None)  # a generator; a plain iterator has nothing to close
        if close is not None:
            close()


def _request(grammar: Any, spec: BackendSpec, registries: Any, *, n: int, seed: int, start: int,
             iterations: int, attrs: Mapping[str, Any] | None, options: Any, executor: Any,
             workers: int | None, progress: Callable | None, timeout: float | None,
             format: str | None, preview: bool, time_limit: float | None = None,
             items: Sequence[Any] | None = None) -> Request:
    from .executor import make_executor
    from .executor_protocol import refuse_in_worker_bootstrap
    from .options import parse_options

    refuse_in_worker_bootstrap()  # a script without the __main__ guard, again in a worker

    for what, value, lo in (("n", n, 0), ("iterations", iterations, 0), ("start", start, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < lo:
            raise GrammarkitError(f"{what} must be a whole number >= {lo}, got {value!r}")
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise GrammarkitError(f"seed must be an integer, got {seed!r}")
    for what, seconds in (("timeout", timeout), ("time_limit", time_limit)):
        if seconds is not None and (isinstance(seconds, bool) or not isinstance(seconds, (int, float))
                                    or not seconds > 0):
            raise GrammarkitError(f"{what} must be a positive number of seconds, got {seconds!r}")
    opts = parse_options(spec.options, options, backend=spec.name)
    if executor is None:
        executor = make_executor(None, workers)
    kwargs: dict[str, Any] = {}
    if progress is not None:
        kwargs["progress"] = progress
    return Request(grammar=grammar, n=n, seed=seed, start=start, iterations=iterations,
                   attrs=dict(attrs or {}), options=opts, executor=executor, registries=registries,
                   deadline=None if timeout is None else time.monotonic() + float(timeout),
                   soft_deadline=None if time_limit is None else time.monotonic() + float(time_limit),
                   format=format, preview=preview, items=items, **kwargs)


def iter_results(grammar: Any, *, backend: str | None = None, n: int = 1, seed: int = 0,
                 iterations: int = 1, attrs: Mapping[str, Any] | None = None, options: Any = None,
                 executor: Any = None, workers: int | None = 1, progress: Callable | None = None,
                 timeout: float | None = None, time_limit: float | None = None,
                 registries: Any = None) -> Iterator[Result]:
    """Results of a back end, in memory (models as objects; nothing is written).

    `time_limit` (seconds) is the graceful budget: no new result is started after it (the
    ones made are kept); `timeout` is the hard stop, a LimitError."""
    registries = _registries(registries)
    g = _grammar(grammar, registries)
    spec = resolve_backend(g, backend if backend is not None else
                           ("split" if g.family == "split" else None), registries)
    request = _request(g, spec, registries, n=n, seed=seed, start=0, iterations=iterations,
                       attrs=attrs, options=options, executor=executor, workers=workers,
                       progress=progress, timeout=timeout, format=None, preview=False,
                       time_limit=time_limit)
    count = 0
    try:
        for result in _drive(spec, request):
            if count >= n:
                break
            count += 1
            yield result
    finally:
        if executor is None:  # made for this call: its worker processes end with it
            request.executor.close()


def encode_result(result: Result, fmt: str, registries: Any) -> bytes:
    """The model file's bytes: as the back end encoded it, or through the exporter registry."""
    if isinstance(result.model, (bytes, bytearray)):
        return bytes(result.model)
    from ..geometry.exporters import encode_with

    spec = registries.exporters.get(fmt)
    if spec is None:
        known = ", ".join(sorted(registries.exporters)) or "none"
        raise GrammarkitError(f"unknown output format {fmt!r}; known formats: {known}")
    return encode_with(spec, result.model)


def preview_png(model: Any, size: tuple[int, int] = (640, 640)) -> bytes:
    """A shaded picture of a split Model, an Assembly or a mesh, as PNG bytes."""
    import io

    from ..geometry.render import render

    buf = io.BytesIO()
    render(model, style="shaded+lines", size=size).save(buf, format="PNG")
    return buf.getvalue()


def run_backend(grammar: Any, *, out: "str | Path | ModelFile", backend: str | None = None, n: int = 1,
                seed: int = 0, iterations: int = 1, attrs: Mapping[str, Any] | None = None,
                options: Any = None, executor: Any = None, workers: int | None = None,
                format: str | None = None, preview: bool = False, progress: Callable | None = None,
                timeout: float | None = None, time_limit: float | None = None,
                overwrite: bool = False, inputs: tuple[Path, ...] = (), registries: Any = None,
                on_result: Callable[[dict], None] | None = None,
                items: Sequence[Any] | None = None, run_info: Mapping[str, Any] | None = None,
                finish: Callable[[Any, RunSummary], None] | None = None) -> RunSummary:
    """Run a back end into the folder `out` (see grammarkit.run.writer for its layout), or
    write its one result as named files: `out=ModelFile("paris.glb", {"png": "paris.png"})`.

    Re-running the same call into the same folder continues after the last complete result;
    a different call is refused unless `overwrite=True`. `inputs` are files no output may
    replace. `time_limit` (seconds) is the graceful budget: past it no new result is made, the
    ones written stay, and the summary says so; `timeout` is the hard stop, a LimitError.
    `items` are the inputs results are made from (`Request.items`: the lots of a batch);
    `run_info` adds fields to run.json (what the items are, so that other items are another
    run); `finish(folder, summary)` is called with the folder still locked once the results
    are in (a batch writes its index and merged model there). `on_result(entry)` is called
    after each result is written.
    Returns a RunSummary; `shortfall` says why fewer than `n` results exist (the time limit,
    the back end's own cap such as its iterations, or the back end running out of results).
    """
    from ..jsonable import to_jsonable
    from .writer import grammar_hash

    t0 = time.perf_counter()
    registries = _registries(registries)
    g = _grammar(grammar, registries)
    spec = resolve_backend(g, backend, registries)
    fmt = (format or spec.model_format).lower().lstrip(".")
    if fmt not in registries.exporters:
        known = ", ".join(sorted(registries.exporters)) or "none"
        raise GrammarkitError(f"unknown output format {fmt!r}; known formats: {known}")
    request = _request(g, spec, registries, n=n, seed=seed, start=0, iterations=iterations,
                       attrs=attrs, options=options, executor=executor, workers=workers,
                       progress=progress, timeout=timeout, format=fmt, preview=preview,
                       time_limit=time_limit, items=items)
    run = {"version": FORMAT_VERSION, "backend": spec.name, "grammar": g.name,
           "grammar_hash": grammar_hash(g), "seed": seed, "iterations": iterations,
           "attrs": to_jsonable(dict(attrs or {})), "format": fmt, "preview": bool(preview),
           "options": request.options.model_dump(mode="json") if request.options is not None else {},
           "n": n, **dict(run_info or {})}
    extra_inputs = [Path(g.source_path)] if getattr(g, "source_path", None) else []
    protected = tuple(Path(p) for p in (*inputs, *extra_inputs))
    try:
        if isinstance(out, ModelFile):  # one result as named files: no folder, no manifest
            out.protected = (*out.protected, *protected)
            ModelFile.__post_init__(out)  # check the outputs against every input, before any work
            sink: Any = out
        else:
            sink = OutputFolder(Path(out), run, protected=protected, overwrite=overwrite)
        with sink as folder:  # a folder stays locked until the run ends
            summary = _write_results(spec, request, folder, registries, n, fmt, preview,
                                     on_result, t0, time_limit)
            if finish is not None:
                finish(folder, summary)
            summary.seconds = time.perf_counter() - t0
            return summary
    finally:
        if executor is None:  # made for this call: its worker processes end with it
            request.executor.close()


def shortfall_reason(request: Request, stats: Any, time_limit: float | None) -> str:
    """Why a run made fewer results than asked, in the user's terms."""
    reason = stats.get("shortfall") if isinstance(stats, dict) else None
    if request.time_is_up():
        # the back end's own account (what it tried, where the candidates went) still says
        # why the results were few when the clock stopped it
        limit = f"the time limit ({time_limit:g} s) was reached" if time_limit else \
            "the time limit was reached"
        return f"{limit}; {reason}" if reason and reason != "the time limit was reached" else limit
    return reason or "the back end is exhausted: it produced no more results"


def _write_results(spec: BackendSpec, request: Request, folder: Any, registries: Any, n: int,
                   fmt: str, preview: bool, on_result: Callable[[dict], None] | None,
                   t0: float, time_limit: float | None) -> RunSummary:
    """Drive the back end and hand each new result to the writer, until `n` are in the folder.

    A folder run writes on a write-behind thread (grammarkit.run.write_behind), so that the
    next results are derived while one is written; `on_result` still runs in this thread."""
    summary = RunSummary(spec.name, n, 0, folder.resumed, folder.path, folder.manifest, None,
                         executor=getattr(request.executor, "name", type(request.executor).__name__),
                         workers=int(getattr(request.executor, "workers", 1) or 1))
    if folder.done >= n:
        summary.stats = {"note": f"the folder already holds {folder.done} results of this run"}
        _count(summary, folder.entries)
        return summary
    start = folder.done
    request = Request(**{**request.__dict__, "start": start})
    sink = _Sink(folder, on_result)
    gen = _drive(spec, request)
    stats: dict = {}
    try:
        while start + sink.handed < n:
            try:
                result = next(gen)
            except StopIteration as stop:
                stats = stop.value or {}
                break
            if result.index < start:
                # recomputed by a back end that cannot start in the middle: already on disk
                listed = folder.entries[result.index].get("id")
                if listed != result.id:
                    raise GrammarkitError(f"{folder.path}: the back end made {result.id!r} where the "
                                          f"manifest lists {listed!r}; the run is not reproducible "
                                          "(use another folder or --overwrite)")
                continue
            sink.put(*_files_and_entry(spec, result, registries, fmt, preview))
            # after the hand-over: the result in hand is kept when the time budget is spent
            request.check_deadline()
            if start + sink.handed < n and request.time_is_up():
                break  # the graceful budget: keep what was written, say so below
        else:
            # the back end was asked for n: let it finish so that its summary comes back
            try:
                next(gen)
            except StopIteration as stop:
                stats = stop.value or {}
    except KeyboardInterrupt:
        sink.close(abandon=True)  # stop now: the result being written ends, the queue is dropped
        raise
    except BaseException:
        sink.close(quiet=True)  # what was handed over is written, then the run's error is raised
        raise
    finally:
        gen.close()
    sink.close()
    summary.written = folder.done - start
    summary.stats = stats
    if folder.done < n:
        summary.shortfall = shortfall_reason(request, stats, time_limit)
    _count(summary, folder.entries)
    return summary


class _Sink:
    """Where `_write_results` hands results: a write-behind thread for a folder (unless
    GRAMMARKIT_WRITE_BEHIND=0), or the sink's own `add` (a ModelFile, or synchronous writes);
    `on_result` is called in the caller's thread for each result written."""

    def __init__(self, folder: Any, on_result: Callable[[dict], None] | None):
        from .write_behind import WriteBehind, write_behind_enabled

        self.folder, self.on_result = folder, on_result
        self.behind = WriteBehind(folder) if isinstance(folder, OutputFolder) \
            and write_behind_enabled() else None
        self.handed = 0
        self.closed = False

    def put(self, files: dict[str, bytes | str], entry: dict) -> None:
        if self.behind is not None:
            self.behind.put(entry, files)
            self.handed += 1
            self._report(self.behind.written())
            return
        self.handed += 1
        if not isinstance(self.folder, OutputFolder):  # a ModelFile: one result, named files
            self._report([self.folder.add(entry, files)])
            return
        try:
            self._report([self.folder.add(entry, files)])
        except OSError as exc:  # a full disk, a folder gone read-only: the manifest stays a prefix
            raise WriteStopped(str(exc), self.folder.done) from None

    def _report(self, entries: list[dict]) -> None:
        if self.on_result is not None:
            for entry in entries:
                self.on_result(entry)

    def close(self, abandon: bool = False, quiet: bool = False) -> None:
        """Wait for the writes; report what was written. `quiet`: a run that is failing anyway
        (its error is the one to raise, not a write's or a callback's that follows from it)."""
        if self.closed or self.behind is None:
            self.closed = True
            return
        self.closed = True
        try:
            self.behind.close(abandon=abandon)
        except Exception:  # noqa: BLE001 - quiet: the run's own error is raised instead
            if not quiet:
                raise
        finally:
            if not abandon:
                try:
                    self._report(self.behind.written())
                except Exception:  # noqa: BLE001 - quiet: as above
                    if not quiet:
                        raise


def _files_and_entry(spec: BackendSpec, result: Result, registries: Any, fmt: str,
                     preview: bool) -> tuple[dict[str, bytes | str], dict]:
    """One result's files ({name: data}) and manifest line."""
    from ..jsonable import to_jsonable

    # a data-only result (model None, e.g. a shape string) has no model file
    files: dict[str, bytes | str] = {} if result.model is None else \
        {f"{result.id}.{fmt}": encode_result(result, fmt, registries)}
    attachments = dict(result.attachments)
    if preview and "png" not in attachments and result.model is not None \
            and not isinstance(result.model, (bytes, bytearray)):
        attachments["png"] = preview_png(result.model)
    for suffix, data in attachments.items():
        files[f"{result.id}.{suffix}"] = data
    entry = {"id": result.id, "index": result.index, "seed": result.seed,
             "parents": list(result.parents), "metrics": to_jsonable(result.metrics),
             "file": None if result.model is None else f"{result.id}.{fmt}",
             "attachments": {s: f"{result.id}.{s}" for s in attachments}}
    for key, value in result.extra.items():
        if key in entry:
            raise PluginError(f"back end {spec.name!r}: manifest field {key!r} is reserved")
        entry[key] = to_jsonable(value)
    return files, entry


def _count(summary: RunSummary, entries: Sequence[Mapping[str, Any]]) -> None:
    """The ok and failed results among the folder's entries (a dataset run records failures)."""
    failed = [e for e in entries if e.get("status") == "failed"]
    summary.failed = len(failed)
    summary.ok = len(entries) - len(failed)
    summary.failures = [{"id": e["id"], "error": e.get("error")} for e in failed[:20]]
