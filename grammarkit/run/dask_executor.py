"""The executor protocol on Dask distributed: a local cluster, or a cluster somewhere else.

    from grammarkit.run.dask_executor import DaskExecutor

    with DaskExecutor(workers=2) as ex:                          # a LocalCluster of 2 processes
        with ex.session(load_state, "grammars/paris.grammar") as s:
            for result in s.map(derive_one, range(100)):         # results in item order
                ...

    DaskExecutor("tcp://scheduler:8786", connect_timeout=10)     # an existing cluster

It implements the same three calls as `LocalExecutor` (see grammarkit.run.executor), so back
ends and `grammarkit batch` never know which one runs them, and results do not depend on it:
`fn(state, item)` sees only the session state and its item.

How a session reaches the workers. A session is a *recipe*: `init`, its arguments and the log of
`update(fn, *args)` calls. The recipe (not the state, which may hold things that do not pickle,
such as compiled closures) is scattered to every worker once (`broadcast=True`) and again after
each `update`, as a new version. On a worker, the first task of a version builds the state from
the recipe (or brings the previous version up to date by replaying only the new updates) and
keeps it for the following tasks; a handful of versions are kept per worker process.

How `map` keeps memory bounded. Items are submitted in chunks, at most `max_in_flight` chunks at
a time (by default four per worker thread), and results are yielded in item order as the oldest
chunk completes, so a run of 100,000 items holds a few hundred items' results at most. Chunks
start with one item; once the first results report how long an item takes, a chunk holds about
`CHUNK_SECONDS` of work, and on a large cluster enough items that the scheduler (about a
millisecond per task) stays under half load (capped at `MAX_CHUNK` items).

Why Dask and not Ray: Dask distributed is pure Python (a ~1.5 MB wheel plus tornado, msgpack,
cloudpickle), starts a `LocalCluster` of processes in a couple of seconds (tests and benchmarks
run on a real multi-process cluster), and is BSD-licensed; Ray ships a ~60 MB binary wheel with
its own object store and raylet daemons, which buys nothing for tasks of tens of milliseconds
whose inputs are kilobytes.
"""
from __future__ import annotations

import itertools
import logging
import re
import threading
import time
import uuid
import warnings
from collections import OrderedDict, deque
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

from ..errors import GrammarkitError
from .executor_protocol import (
    GUARD_HINT, WorkerError, default_workers, main_without_phantom_file, portable_error,
    refuse_in_worker_bootstrap,
)

__all__ = ["DaskExecutor", "DaskSession", "DaskUnavailable", "SchedulerUnreachable", "parse_address"]

DEFAULT_CONNECT_TIMEOUT = 10.0  # seconds to reach a scheduler before giving up
CHUNK_SECONDS = 0.25  # aim for chunks of about this much work once an item's cost is known
MAX_CHUNK = 64
# What one task costs the scheduler (Dask's docs say about 1 ms; 0.2-2.5 ms measured by
# benchmarks/bench_batch.py on a busy 2-core machine). Chunks grow with the cluster so that the
# scheduler stays under half load: workers / (chunk x item time) <= 0.5 / TASK_SECONDS.
TASK_SECONDS = 1e-3
IN_FLIGHT_PER_THREAD = 4
INSTALL_HINT = 'pip install "grammarkit[dask]"'


class DaskUnavailable(GrammarkitError):
    """Dask distributed is not installed."""


class SchedulerUnreachable(GrammarkitError):
    """The scheduler address did not answer (in time, or as a Dask scheduler)."""


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError as exc:
        raise DaskUnavailable(f"the dask executor needs Dask distributed, which is not installed "
                              f"({exc}); install it with: {INSTALL_HINT}") from None
    return distributed


def parse_address(spec: str) -> str:
    """`dask://host:port` (or `tcp://host:port`, `tls://...`, `host:port`) as a scheduler address."""
    text = spec.strip()
    if text.startswith("dask://"):
        text = "tcp://" + text[len("dask://"):]
    elif "://" not in text:
        text = "tcp://" + text
    m = re.fullmatch(r"(tcp|tls|inproc|ucx)://(\[[0-9a-fA-F:]+\]|[^:/\[\]]+)(?::(\d+))?/?", text)
    if not m or (m.group(1) in ("tcp", "tls") and m.group(3) is None):
        raise GrammarkitError(f"--executor {spec}: expected dask://HOST:PORT (or tcp://HOST:PORT), "
                              "e.g. dask://127.0.0.1:8786")
    return text.rstrip("/")


# ---------------------------------------------------------------------------------------------
# the worker side: session states built from recipes, kept per worker process
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Recipe:
    """Everything a worker needs to build a session's state: init, its args, the update log."""

    session: str  # unique per session (uuid)
    init: Callable[..., Any]
    args: tuple
    log: tuple  # ((fn, args), ...) in the order the parent applied them

    @property
    def version(self) -> int:
        return len(self.log)


_MAX_STATES = 4  # session versions kept per worker process
_states: "OrderedDict[tuple[str, int], Any]" = OrderedDict()
_busy: dict[tuple[str, int], int] = {}  # tasks currently using a state (do not mutate it)
_states_lock = threading.Lock()


def _state_for(recipe: _Recipe) -> tuple[Any, tuple[str, int]]:
    """The state of this recipe's version in this worker process, built or brought up to date."""
    key = (recipe.session, recipe.version)
    with _states_lock:
        state = _states.get(key)
        if state is not None:
            _states.move_to_end(key)
            _busy[key] = _busy.get(key, 0) + 1
            return state, key
        # an older version of the same session nobody is using: replay only the new updates
        older = [k for k in _states if k[0] == recipe.session and k[1] < recipe.version
                 and not _busy.get(k)]
        base_key = max(older, key=lambda k: k[1]) if older else None
        base = _states.pop(base_key) if base_key is not None else None
    if base is not None and base_key is not None:
        state = base
        for fn, args in recipe.log[base_key[1]:]:
            fn(state, *args)
    else:
        state = recipe.init(*recipe.args)
        for fn, args in recipe.log:
            fn(state, *args)
    with _states_lock:
        _states[key] = state
        _busy[key] = _busy.get(key, 0) + 1
        while len(_states) > _MAX_STATES:
            old = next((k for k in _states if not _busy.get(k)), None)
            if old is None:
                break
            del _states[old]
    return state, key


def _release_state(key: tuple[str, int]) -> None:
    with _states_lock:
        left = _busy.get(key, 0) - 1
        if left > 0:
            _busy[key] = left
        else:
            _busy.pop(key, None)


def _run_chunk(recipe: _Recipe, fn: Callable[[Any, Any], Any], items: list) -> tuple[list, float]:
    """Compute `fn(state, item)` for a chunk: [(ok, value)], stopping at the first error (raised
    in order by the parent), and the seconds spent in `fn` (the parent sizes chunks with it)."""
    state, key = _state_for(recipe)
    try:
        out: list[tuple[bool, Any]] = []
        t0 = time.perf_counter()
        for item in items:
            try:
                out.append((True, fn(state, item)))
            except Exception as exc:  # noqa: BLE001 - returned to the parent, raised in order
                out.append((False, portable_error(exc)))
                break
        return out, time.perf_counter() - t0
    finally:
        _release_state(key)


def _drop_session(session: str) -> None:
    with _states_lock:
        for k in [k for k in _states if k[0] == session and not _busy.get(k)]:
            del _states[k]


# ---------------------------------------------------------------------------------------------
# the parent side
# ---------------------------------------------------------------------------------------------
class DaskSession:
    def __init__(self, executor: "DaskExecutor", init: Callable[..., Any], args: tuple):
        self.executor = executor
        self.client = executor.client
        self.id = uuid.uuid4().hex
        self.init, self.args = init, args
        # built here too: a failing init is reported now, with its own error, not from a worker
        self.state = init(*args)
        self.log: list[tuple[Callable, tuple]] = []
        self._recipe_future: Any = None
        self.closed = False
        self.per_item: float | None = None  # seconds of fn per item, measured by the workers

    # -- state ------------------------------------------------------------------------------
    def update(self, fn: Callable[..., None], *args: Any) -> None:
        fn(self.state, *args)
        self.log.append((fn, args))
        self._recipe_future = None  # the next map ships the new version

    def _recipe(self) -> Any:
        if self._recipe_future is None:
            recipe = _Recipe(self.id, self.init, tuple(self.args), tuple(self.log))
            try:
                [self._recipe_future] = self.client.scatter([recipe], broadcast=True, hash=False)
            except Exception as exc:  # noqa: BLE001 - unpicklable state, lost scheduler
                raise WorkerError(f"cannot ship the session to the Dask workers: "
                                  f"{type(exc).__name__}: {exc}") from None
        return self._recipe_future

    # -- work -------------------------------------------------------------------------------
    def _chunk_size(self) -> int:
        if self.per_item is None:
            return 1
        per = max(self.per_item, 1e-6)
        want = max(CHUNK_SECONDS / per, 2.0 * self.executor.workers * TASK_SECONDS / per)
        return max(1, min(MAX_CHUNK, int(want)))

    def map(self, fn: Callable[[Any, Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        """Yield `fn(state, item)` for every item, in item order (see the module docstring)."""
        from distributed import CancelledError, KilledWorker

        recipe = self._recipe()
        source = iter(items)
        window: deque = deque()  # futures of submitted chunks, oldest first
        limit = self.executor.max_in_flight
        try:
            while True:
                while len(window) < limit:
                    chunk = list(itertools.islice(source, self._chunk_size()))
                    if not chunk:
                        break
                    window.append(self.client.submit(_run_chunk, recipe, fn, chunk, pure=False))
                if not window:
                    return
                future = window.popleft()
                try:
                    values, seconds = future.result()
                except KilledWorker as exc:
                    raise WorkerError(f"a Dask worker died while computing (out of memory?): {exc}; "
                                      "try fewer workers or more memory per worker") from None
                except (CancelledError, OSError) as exc:
                    raise WorkerError(f"lost the Dask cluster while computing: "
                                      f"{type(exc).__name__}: {exc}") from None
                if values:
                    per = seconds / len(values)
                    self.per_item = per if self.per_item is None else 0.7 * self.per_item + 0.3 * per
                for ok, value in values:
                    if not ok:
                        raise value
                    yield value
        finally:
            if window:
                # results still out are not wanted any more (Ctrl-C, an error, the caller stopped)
                try:
                    self.client.cancel(list(window))
                except Exception:  # noqa: BLE001 - the cluster may be gone already
                    pass

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        self._recipe_future = None
        try:
            if self.client.status == "running":
                self.client.run(_drop_session, self.id)
        except Exception:  # noqa: BLE001 - best effort; the states age out anyway
            pass

    def __enter__(self) -> "DaskSession":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class DaskExecutor:
    """Parallel work on Dask distributed.

    address:         None starts a `LocalCluster` of `workers` processes (one thread each) on
                     this machine; otherwise the scheduler to connect to (`tcp://host:port`,
                     `dask://host:port`), whose workers are used as they are.
    workers:         LocalCluster processes (default: one per CPU); ignored with an address.
    connect_timeout: seconds to reach the scheduler; an address that does not answer in time
                     (or answers as something else than a Dask scheduler) is an error.
    max_in_flight:   chunks submitted and not yet yielded, at most (default: 4 per worker thread).
    """

    name = "dask"

    def __init__(self, address: str | None = None, workers: int | None = None, *,
                 connect_timeout: float = DEFAULT_CONNECT_TIMEOUT, max_in_flight: int | None = None,
                 silence_logs: int = logging.ERROR):
        refuse_in_worker_bootstrap()  # a script without the __main__ guard, again in a worker
        distributed = _import_distributed()
        if not (isinstance(connect_timeout, (int, float)) and connect_timeout > 0):
            raise GrammarkitError(f"connect_timeout must be a positive number of seconds, "
                                  f"got {connect_timeout!r}")
        self.cluster: Any = None
        self.address = None if address is None else parse_address(address)
        if self.address is None:
            n = default_workers() if workers is None else max(1, int(workers))
            try:
                # spawned workers re-import the main script: hide a main "file" that is not one
                # (code from standard input); its HTTP server (health checks) moves off a port
                # another cluster holds, which is no news to the user
                with main_without_phantom_file(), warnings.catch_warnings():
                    warnings.filterwarnings("ignore", message=r"Port \d+ is already in use")
                    self.cluster = distributed.LocalCluster(
                        n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                        silence_logs=silence_logs)
                self.client = distributed.Client(self.cluster, timeout=connect_timeout)
            except Exception as exc:  # noqa: BLE001 - ports, spawn failures: say what happened
                self._shutdown()
                raise GrammarkitError(f"cannot start a Dask LocalCluster of {n} processes: "
                                      f"{type(exc).__name__}: {exc} ({GUARD_HINT})"
                                      ) from None
        else:
            self.client = _connect(distributed, self.address, float(connect_timeout))
        threads = sum(self.client.nthreads().values()) or 1
        self.workers = threads
        self.max_in_flight = max(2, int(max_in_flight) if max_in_flight else IN_FLIGHT_PER_THREAD * threads)

    def session(self, init: Callable[..., Any], *args: Any) -> DaskSession:
        return DaskSession(self, init, args)

    def _shutdown(self) -> None:
        # the cluster restores the log level it silenced before it closes; its farewells
        # (workers retired, comms closed) are not news to the user
        logger = logging.getLogger("distributed")
        level = logger.level
        logger.setLevel(logging.ERROR)
        try:
            for thing in (getattr(self, "client", None), self.cluster):
                if thing is not None:
                    try:
                        thing.close()
                    except Exception:  # noqa: BLE001 - closing what may already be gone
                        pass
        finally:
            logger.setLevel(level)

    def close(self) -> None:
        """Disconnect; a LocalCluster started by this executor is shut down."""
        self._shutdown()
        self.cluster = None

    def __enter__(self) -> "DaskExecutor":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        where = self.address or "LocalCluster"
        return f"DaskExecutor({where}, {self.workers} worker threads)"


def _probe(address: str, timeout: float) -> None:
    """Open a Dask comm to `address` and complete its handshake within `timeout` seconds.

    distributed.Client's own timeout does not cover a server that accepts the connection and
    then says nothing (its clean-up after the handshake times out waits for ever), so the
    address is tried first with one overall deadline."""
    import asyncio

    from distributed.comm import connect

    async def attempt() -> None:
        comm = await connect(address, timeout=timeout)
        await comm.close()

    async def bounded() -> None:
        await asyncio.wait_for(attempt(), timeout)

    asyncio.run(bounded())


def _connect(distributed: Any, address: str, timeout: float) -> Any:
    """A Client of the scheduler at `address`, or SchedulerUnreachable within about `timeout`."""
    t0 = time.monotonic()
    try:
        _probe(address, timeout)
        return distributed.Client(address, timeout=max(1.0, timeout - (time.monotonic() - t0)))
    except Exception as exc:  # noqa: BLE001 - refused, timed out, or garbage from a non-Dask server
        waited = time.monotonic() - t0
        if isinstance(exc, TimeoutError) or (isinstance(exc, OSError) and "Timed out" in str(exc)):
            why = f"no answer within {timeout:g} s"
        else:
            # anything else that answers on that port (an HTTP proxy, ...) makes the Dask
            # protocol fail in odd ways (even a MemoryError from a garbage frame length)
            why = f"it did not answer as a Dask scheduler ({type(exc).__name__}: {str(exc)[:200]})"
        raise SchedulerUnreachable(
            f"--executor {address}: cannot reach a Dask scheduler: {why} (after {waited:.1f} s); "
            "start one with `dask scheduler` (and workers with `dask worker ADDRESS`), or use "
            "--executor dask for a local cluster") from None
