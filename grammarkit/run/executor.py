"""The one executor for parallel work: split variations, sampler attempts, batch derives.

Work is expressed as a *session*: a state built once by `init(*args)` (a compiled grammar, a
sampler's pool of shapes), changed only by `update(fn, *args)` calls that every copy of the
state replays in the same order, and `map(fn, items)` calls that compute `fn(state, item)` for
each item and yield the results **in item order**. Because `fn` sees only the state and its
item, the results never depend on the number of workers or on which worker ran what.

    from grammarkit.run.executor import LocalExecutor

    with LocalExecutor(workers=2) as ex:
        with ex.session(load_state, "grammars/paris.grammar") as s:
            for result in s.map(derive_one, range(100)):
                ...

Functions passed to `session`, `update` and `map` must be picklable (module-level functions).

`LocalExecutor` runs everything in this process until the work is worth parallelising: it
times the items it runs itself and starts worker processes only when the remaining work is
larger than what starting them costs (spawning a Python that imports numpy and manifold3d
takes about a second per worker here). Workers belong to the executor that started them and
persist until its `close()`, so a second run on the same executor pays nothing; they die
with the parent (PR_SET_PDEATHSIG on Linux, and EOF on their pipe elsewhere), ignore Ctrl-C (the parent handles it), and a session interrupted
while work is out drops the workers it used.

A distributed engine plugs in by implementing the same three calls (`Executor`, in
grammarkit.run.executor_protocol);
back ends never see which one runs them.
"""
from __future__ import annotations

import itertools
import multiprocessing as mp
import pickle
import signal
import sys
import threading
import time
import weakref
from collections import deque
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Sequence, cast

if TYPE_CHECKING:  # pragma: no cover - types only
    from multiprocessing.connection import Connection

from .executor_protocol import (  # noqa: F401 - the protocol, re-exported where it always was
    GUARD_HINT, Executor, Session, WorkerError, default_workers, main_without_phantom_file,
    portable_error, refuse_in_worker_bootstrap,
)

__all__ = ["Executor", "LocalExecutor", "Session", "WorkerError", "default_workers", "make_executor"]

# Starting a spawned worker costs roughly this much wall time (import of numpy, trimesh,
# manifold3d and grammarkit on this 2-core machine); parallel work must save more than it.
SPAWN_SECONDS = 1.5
# Aim for chunks of about this much work: small enough that Ctrl-C and load balancing react
# quickly, large enough that pipe traffic stays negligible.
CHUNK_SECONDS = 0.15


# ---------------------------------------------------------------------------------------------
# worker processes
# ---------------------------------------------------------------------------------------------
def _die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent dies (even mid-computation)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except Exception:  # noqa: BLE001 - best effort; EOF on the pipe still ends the worker
        pass


def _worker_main(conn: Any) -> None:  # pragma: no cover - runs in the child process
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    try:
        _serve(conn)
    except (EOFError, OSError):
        return  # the parent went away (killed, or done with us): end quietly, no traceback


def _serve(conn: Any) -> None:  # pragma: no cover - runs in the child process
    states: dict[int, Any] = {}
    conn.send(("ready",))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        kind = msg[0]
        try:
            if kind == "init":
                _, sid, init, args, log = msg
                state = init(*args)
                for fn, fargs in log:
                    fn(state, *fargs)
                states[sid] = state
            elif kind == "update":
                _, sid, fn, args = msg
                fn(states[sid], *args)
            elif kind == "map":
                _, sid, chunk, fn, items = msg
                state = states[sid]
                out = []
                for item in items:
                    try:
                        out.append((True, fn(state, item)))
                    except Exception as exc:  # noqa: BLE001 - returned to the parent, in order
                        out.append((False, portable_error(exc)))
                        break
                conn.send(("done", chunk, out))
            elif kind == "drop":
                states.pop(msg[1], None)
            elif kind == "stop":
                return
        except Exception as exc:  # noqa: BLE001 - an init/update failure ends this worker's use
            try:
                conn.send(("failed", portable_error(exc)))
            except (OSError, pickle.PicklingError):
                return


class _StopsHeld:
    """Hold a stop (SIGINT, SIGTERM) asked for while a worker process is being started, and
    hand it to the handler that was in place once the start is complete: a KeyboardInterrupt
    inside `Process.start()` cut the child's start-up data short, and the child printed
    multiprocessing's `EOFError: Ran out of input` traceback (issue 31).

    Only Python-level handlers are swapped, and only where a Python function handles the
    signal: the signal is never blocked nor re-sent (a re-sent SIGINT met the default
    disposition once and killed the process, exit -2), and a signal left to the system's
    default or ignored keeps that disposition untouched. Main thread only (the only one that
    may change handlers, and where Python runs them)."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.caught: list[int] = []
        self.previous: dict[int, Callable[[int, Any], Any]] = {}

    def _hold(self, signum: int, frame: Any) -> None:
        self.caught.append(signum)

    def __enter__(self) -> "_StopsHeld":
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                handler = signal.getsignal(sig)
                if callable(handler):
                    self.previous[sig] = handler
                    signal.signal(sig, self._hold)
        return self

    def __exit__(self, *exc: Any) -> None:
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)  # runs a still pending `_hold` first: nothing is lost

    def deliver(self) -> None:
        """Call the handler that was in place for the first stop held (in grammarkit's
        command it raises KeyboardInterrupt, here); nothing if no stop came."""
        if self.caught:
            self.previous[self.caught[0]](self.caught[0], None)


class _Worker:
    def __init__(self) -> None:
        ctx = mp.get_context("spawn")  # fork deadlocks in manifold3d's TBB thread pool
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child,), daemon=True)
        with main_without_phantom_file(), _StopsHeld() as stops:
            self.proc.start()
        child.close()
        if stops.caught:  # started completely; not the pool's yet, so it ends here
            self.kill()
            stops.deliver()
        self.ready = False
        self.busy = False  # taken by a session (WorkerPool)
        self.sessions: set[int] = set()

    def alive(self) -> bool:
        return self.proc.is_alive() and not self.conn.closed

    def kill(self) -> None:
        try:
            self.conn.close()
        except OSError:
            pass
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(timeout=5)


_SESSION_IDS = itertools.count(1)


class WorkerPool:
    """The worker processes of one executor: started on demand, reused by its later sessions,
    stopped by `close()` (the executor's). They also die with this process."""

    def __init__(self) -> None:
        self._workers: list[_Worker] = []
        self._lock = threading.Lock()
        _POOLS.add(self)

    def take(self, count: int) -> list[_Worker]:
        """`count` workers for a session: live idle ones first, new ones started for the rest."""
        with self._lock:
            self._workers[:] = [w for w in self._workers if w.alive()]
            free = [w for w in self._workers if not w.busy]
            taken = free[:count]
            while len(taken) < count:
                w = _Worker()
                self._workers.append(w)
                taken.append(w)
            for w in taken:
                w.busy = True
            return taken

    def warm(self, count: int) -> None:
        """Start workers until `count` are alive (they are idle: the next `take` gets them)."""
        with self._lock:
            self._workers[:] = [w for w in self._workers if w.alive()]
            while len(self._workers) < count:
                self._workers.append(_Worker())

    def release(self, workers: Sequence[_Worker], *, broken: bool) -> None:
        with self._lock:
            for w in workers:
                w.busy = False
                if broken or not w.alive():
                    w.kill()
                    if w in self._workers:
                        self._workers.remove(w)

    def idle(self) -> int:
        """Live workers not used by a session (a later session starts with these for free)."""
        with self._lock:
            return sum(1 for w in self._workers if w.alive() and not w.busy)

    def pids(self) -> list[int]:
        with self._lock:
            return [w.proc.pid for w in self._workers if w.alive() and w.proc.pid is not None]

    def close(self) -> None:
        """Stop every worker of this pool."""
        with self._lock:
            for w in self._workers:
                try:
                    w.conn.send(("stop",))
                except (OSError, BrokenPipeError):
                    pass
            for w in self._workers:
                w.proc.join(timeout=5)
                if w.proc.is_alive():
                    w.kill()
            self._workers.clear()


_POOLS: "weakref.WeakSet[WorkerPool]" = weakref.WeakSet()


def shutdown_workers() -> None:
    """Stop the workers of every local executor of this process (tests, notebooks)."""
    for pool in list(_POOLS):
        pool.close()


# ---------------------------------------------------------------------------------------------
# the local executor
# ---------------------------------------------------------------------------------------------
class _LocalSession:
    def __init__(self, executor: "LocalExecutor", init: Callable[..., Any], args: tuple):
        self.executor = executor
        self.sid = next(_SESSION_IDS)
        self.init, self.args = init, args
        self.state = init(*args)  # the parent's own copy: items it runs itself use it
        self.log: list[tuple[Callable, tuple]] = []
        self.workers: list[_Worker] = []
        self.closed = False
        self.local_only = False
        # work this session ran here, over all its maps (the start rule below reads it)
        self.spent, self.done, self.first = 0.0, 0, 0.0

    # -- state ------------------------------------------------------------------------------
    def update(self, fn: Callable[..., None], *args: Any) -> None:
        fn(self.state, *args)
        self.log.append((fn, args))
        for w in self.workers:
            if w.ready:
                w.conn.send(("update", self.sid, fn, args))

    # -- work -------------------------------------------------------------------------------
    def map(self, fn: Callable[[Any, Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        pending = deque(enumerate(items))
        if not pending:
            return
        want = self.executor.workers
        always = self.executor.parallel == "always"
        spent, done_here = 0.0, 0
        while pending:
            if want > 1 and not self.workers and not self.local_only and (always or self._worth_it(len(pending))):
                self._start_workers(want)
            if self.workers:
                yield from self._parallel(fn, pending, spent / done_here if done_here else None)
                return
            _, item = pending.popleft()
            t0 = time.perf_counter()
            result = fn(self.state, item)
            took = time.perf_counter() - t0
            spent += took
            done_here += 1
            self.spent += took
            self.done += 1
            if self.done == 1:
                self.first = took
            yield result

    def _worth_it(self, remaining: int) -> bool:
        """Start workers when the work left is expected to repay their start-up. The work left
        is the larger of this map's remaining items at the session's pace (its first item
        left out: it pays for caches the others reuse, and alone it made two workers start
        for a few milliseconds of work) and as much again as the session has run so far (a
        back end that maps batch after batch, such as the graph sampler, has more to come
        than one map shows; the rule of the ski rental: pay for the start once the work done
        equals its price)."""
        if self.done < 2:
            return False
        per_item = (self.spent - self.first) / (self.done - 1)
        work = max(per_item * remaining, self.spent)
        workers = self.executor.workers
        startup = max(0, workers - self.executor.pool.idle()) * SPAWN_SECONDS / max(1, min(workers, 2))
        return work * (1.0 - 1.0 / workers) > startup + self.executor.min_parallel_seconds

    def _start_workers(self, count: int) -> None:
        try:  # state that cannot be shipped (a lambda in it, say) is computed here instead
            pickle.dumps((self.init, self.args, self.log))
        except Exception:  # noqa: BLE001 - any pickling failure means: stay in this process
            self.local_only = True
            return
        self.workers = self.executor.pool.take(count)
        for w in self.workers:
            if w.ready:
                w.conn.send(("init", self.sid, self.init, self.args, list(self.log)))
                w.sessions.add(self.sid)

    def _parallel(self, fn: Callable, pending: deque, per_item: float | None) -> Iterator[Any]:
        """Hand chunks to workers as they become free, run items here while none is ready,
        and yield every result in item order."""
        from multiprocessing.connection import wait

        if per_item is None:  # nothing timed yet: a few chunks per worker
            size = max(1, min(64, len(pending) // (4 * len(self.workers))))
        else:
            # at least two chunks per worker: a map is a barrier (the graph sampler's batch of
            # 128 attempts in chunks of 50 left one worker idle for the last 28)
            share = -(-len(pending) // (2 * len(self.workers)))
            size = max(1, min(64, int(CHUNK_SECONDS / max(per_item, 1e-6)), share))
        results: dict[int, tuple[bool, Any]] = {}  # item position -> (ok, value)
        order = deque(pos for pos, _ in pending)
        chunk_ids = itertools.count()
        out: dict[Any, tuple[int, list[int]]] = {}  # worker conn -> (chunk id, positions)
        busy = False
        try:
            while order:
                # give work to every ready, idle worker
                for w in self.workers:
                    if not pending:
                        break
                    if w.ready and w.conn not in out:
                        batch = [pending.popleft() for _ in range(min(size, len(pending)))]
                        cid = next(chunk_ids)
                        w.conn.send(("map", self.sid, cid, fn, [item for _, item in batch]))
                        out[w.conn] = (cid, [pos for pos, _ in batch])
                        busy = True
                # yield what is complete, in order
                while order and order[0] in results:
                    ok, value = results.pop(order.popleft())
                    if not ok:
                        raise value
                    yield value
                if not order:
                    break
                if not out and pending and not any(w.ready for w in self.workers) \
                        and self.executor.parallel == "auto":
                    # workers still starting: do the next item here meanwhile
                    pos, item = pending.popleft()
                    try:
                        results[pos] = (True, fn(self.state, item))
                    except Exception as exc:  # noqa: BLE001 - raised in order below
                        results[pos] = (False, exc)
                    self._poll_ready(timeout=0)
                    continue
                if not self.workers:  # none could start: the rest runs here, in order
                    while pending:
                        pos, item = pending.popleft()
                        try:
                            results[pos] = (True, fn(self.state, item))
                        except Exception as exc:  # noqa: BLE001 - raised in order below
                            results[pos] = (False, exc)
                            break
                    continue
                conns = list(out) + [w.conn for w in self.workers if not w.ready]
                for conn in cast("list[Connection]", wait(conns, timeout=1.0)):
                    w = next(x for x in self.workers if x.conn is conn)
                    try:
                        msg = conn.recv()
                    except (EOFError, OSError):
                        if not w.ready:
                            self._failed_start(w)
                            continue
                        raise WorkerError("a worker process died (out of memory?); "
                                          "try fewer workers") from None
                    self._handle(w, msg, out, results)
                if not out and not pending and order and order[0] not in results:
                    raise WorkerError("internal error: a result went missing")  # pragma: no cover
                busy = bool(out)
        except BaseException:
            # results of chunks still out would arrive later on the pipes: drop those workers
            if busy or out:
                self.executor.pool.release(self.workers, broken=True)
                self.workers = []
            raise

    def _poll_ready(self, timeout: float) -> None:
        from multiprocessing.connection import wait

        starting = [w.conn for w in self.workers if not w.ready]
        ready = cast("list[Connection]", wait(starting, timeout=timeout)) if starting else []
        for conn in ready:
            w = next(x for x in self.workers if x.conn is conn)
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                self._failed_start(w)
                continue
            self._handle(w, msg, {}, {})

    def _failed_start(self, w: _Worker) -> None:
        """A worker died before it was ready (e.g. a main script without the
        `if __name__ == "__main__":` guard re-ran itself in it): the work goes on without it,
        here if need be; results are the same either way."""
        import warnings

        self.workers.remove(w)
        self.executor.pool.release([w], broken=True)
        if not self.workers:
            self.local_only = True
            warnings.warn("grammarkit: worker processes could not start; continuing in this "
                          f"process; {GUARD_HINT}", RuntimeWarning, stacklevel=4)

    def _handle(self, w: _Worker, msg: tuple, out: dict, results: dict) -> None:
        if msg[0] == "ready":
            w.ready = True
            w.conn.send(("init", self.sid, self.init, self.args, list(self.log)))
            w.sessions.add(self.sid)
        elif msg[0] == "done":
            _, cid, values = msg
            _, positions = out.pop(w.conn)
            for pos, value in zip(positions, values):
                results[pos] = value
            if len(values) < len(positions):  # the chunk stopped at a failing item
                failed = positions[len(values) - 1]
                for pos in positions[len(values):]:
                    results.setdefault(pos, results[failed])
        elif msg[0] == "failed":
            raise msg[1]

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        for w in self.workers:
            if w.ready and w.alive():
                try:
                    w.conn.send(("drop", self.sid))
                except (OSError, BrokenPipeError):
                    pass
        self.executor.pool.release(self.workers, broken=False)
        self.workers = []

    def __enter__(self) -> "_LocalSession":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class LocalExecutor:
    """This process plus, when it pays, persistent worker processes on this machine.

    workers: the most processes to use (default: the CPUs this process may run on; 1 runs
             everything in this process).
    parallel: "auto" starts workers when the work is expected to repay their start-up;
             "always" hands every map to workers (tests, benchmarks); "never" stays here.
    min_parallel_seconds: with "auto", parallel work must be expected to save this much.
    """

    name = "local"

    def __init__(self, workers: int | None = None, *, parallel: str = "auto",
                 min_parallel_seconds: float = 0.5):
        refuse_in_worker_bootstrap()  # a script without the __main__ guard, again in a worker
        if parallel not in ("auto", "always", "never"):
            raise ValueError(f"parallel must be 'auto', 'always' or 'never', not {parallel!r}")
        self.workers = default_workers() if workers is None else max(1, int(workers))
        if parallel == "never":
            self.workers = 1
        self.parallel = parallel
        self.min_parallel_seconds = float(min_parallel_seconds)
        self.pool = WorkerPool()  # this executor's worker processes, stopped by close()

    def session(self, init: Callable[..., Any], *args: Any) -> _LocalSession:
        return _LocalSession(self, init, args)

    def warm(self, count: int | None = None) -> None:
        """Start worker processes now (up to `count`, default `workers`), without waiting for
        them: their start-up (imports) then overlaps with the caller's own preparation, and
        the next session that goes parallel finds them idle, so its start costs nothing. For
        callers that know a long run is coming (the graph sampler at large -n); nothing with
        one worker or parallel="never"."""
        want = self.workers if count is None else min(self.workers, int(count))
        if want <= 1 or self.parallel == "never":
            return
        self.pool.warm(want)

    def close(self) -> None:
        """Stop the worker processes this executor started (its later sessions would have
        reused them; a closed executor starts new ones if used again)."""
        self.pool.close()

    def __enter__(self) -> "LocalExecutor":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def make_executor(spec: str | None = None, workers: int | None = None, **options: Any) -> Executor:
    """An executor from a `--executor` value: None or "local" (the default); "dask" (a Dask
    LocalCluster of `workers` processes); "dask://host:port" or "tcp://host:port" (an existing
    Dask cluster). `options` go to the executor (e.g. connect_timeout= for Dask). Dask is
    imported only here, when asked for (`pip install "grammarkit[dask]"`)."""
    if spec in (None, "", "local"):
        return LocalExecutor(workers, **options)
    text = str(spec).strip()
    if text == "dask" or text.startswith(("dask://", "tcp://", "tls://")):
        from .dask_executor import DaskExecutor

        return DaskExecutor(None if text == "dask" else text, workers, **options)
    from ..errors import GrammarkitError

    raise GrammarkitError(f"unknown executor {spec!r}; known executors: local, dask, "
                          "dask://HOST:PORT")
