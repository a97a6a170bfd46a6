"""The Dask executor keeps the executor protocol on a real multi-process LocalCluster: results
in item order whatever the chunking, the session state shipped once and updated in order,
errors raised at their place, bounded work in flight; and an address that does not answer is
an error within the connect timeout."""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time

import pytest

from grammarkit.errors import GrammarkitError
from grammarkit.run.dask_executor import DaskExecutor, SchedulerUnreachable, parse_address
from grammarkit.run.executor import LocalExecutor, make_executor


# module-level functions: workers import them by reference
def make_state(base):
    return {"base": base, "log": [], "built_in": os.getpid()}


def add_to_log(state, value):
    state["log"].append(value)


def compute(state, item):
    if item == "boom":
        raise ValueError("item says boom")
    return (item * state["base"], tuple(state["log"]), os.getpid())


def slow(state, item):
    time.sleep(0.02)
    return item


def failing_init(_):
    raise RuntimeError("cannot build the state")


def test_results_are_in_item_order_and_match_the_local_executor(dask_executor):
    with dask_executor.session(make_state, 3) as session:
        first = list(session.map(compute, range(60)))
        session.update(add_to_log, "a")
        session.update(add_to_log, "b")
        second = list(session.map(compute, range(60, 75)))
    with LocalExecutor(1, parallel="never").session(make_state, 3) as local:
        expected = list(local.map(compute, range(60)))
        local.update(add_to_log, "a")
        local.update(add_to_log, "b")
        expected += list(local.map(compute, range(60, 75)))
    got = first + second
    assert [r[:2] for r in got] == [r[:2] for r in expected]
    assert second[-1][1] == ("a", "b")  # updates replayed in order on the workers
    assert {r[2] for r in got} - {os.getpid()}  # computed in the worker processes
    assert len({r[2] for r in got}) >= 2, "both workers should have taken part"


def test_an_error_is_raised_at_its_place_after_the_results_before_it(dask_executor):
    got = []
    with dask_executor.session(make_state, 1) as session:
        with pytest.raises(ValueError, match="boom"):
            for r in session.map(compute, [1, 2, 3, "boom", 5, 6]):
                got.append(r[0])
        # the session still works after an error
        assert [r[0] for r in session.map(compute, [7, 8])] == [7, 8]
    assert got == [1, 2, 3]


def test_a_failing_init_is_reported_before_any_work(dask_executor):
    with pytest.raises(RuntimeError, match="cannot build the state"):
        dask_executor.session(failing_init, 0)


def test_work_in_flight_is_bounded_and_chunks_grow_with_cheap_items(dask_executor, monkeypatch):
    client = dask_executor.client
    submitted, peak = [], [0]
    real_submit = client.submit

    def counting_submit(fn, recipe, f, chunk, **kw):
        submitted.append(len(chunk))
        future = real_submit(fn, recipe, f, chunk, **kw)
        peak[0] = max(peak[0], sum(1 for x in live if not x.done()) + 1)
        live.append(future)
        return future

    live: list = []
    monkeypatch.setattr(client, "submit", counting_submit)
    consumed = 0
    with dask_executor.session(make_state, 1) as session:
        for _ in session.map(compute, range(3000)):
            consumed += 1
    assert consumed == 3000
    assert peak[0] <= dask_executor.max_in_flight
    assert submitted[0] == 1  # the cost of an item is unknown at first
    assert max(submitted) > 8  # then chunks hold many cheap items


def test_the_caller_stopping_early_cancels_the_rest(dask_executor):
    with dask_executor.session(make_state, 1) as session:
        gen = session.map(slow, range(400))
        assert [next(gen) for _ in range(3)] == [0, 1, 2]
        gen.close()
        # nothing left behind blocks the next map
        t0 = time.monotonic()
        assert list(session.map(compute, [4]))[0][0] == 4
        assert time.monotonic() - t0 < 10


def test_make_executor_knows_dask_and_its_addresses():
    assert isinstance(make_executor(None, 2), LocalExecutor)
    assert parse_address("dask://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert parse_address("tcp://host:1") == "tcp://host:1"
    assert parse_address("host:8786") == "tcp://host:8786"
    for bad in ("dask://", "dask://host", "tcp://host:port", "ftp://host:1"):
        with pytest.raises(GrammarkitError, match="expected dask://HOST:PORT"):
            make_executor(bad if bad != "ftp://host:1" else "dask://" + bad, 1)
    with pytest.raises(GrammarkitError, match="unknown executor 'ray'.*local, dask"):
        make_executor("ray", 1)


def _closed_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def test_an_address_nobody_listens_on_errors_within_the_timeout():
    t0 = time.monotonic()
    with pytest.raises(SchedulerUnreachable, match=r"cannot reach a Dask scheduler: no answer within 2 s"):
        make_executor(f"dask://127.0.0.1:{_closed_port()}", connect_timeout=2)
    assert time.monotonic() - t0 < 8


def test_a_server_that_accepts_but_never_answers_errors_within_the_timeout():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)  # connections complete in the backlog; nothing is ever said
    port = server.getsockname()[1]
    try:
        t0 = time.monotonic()
        with pytest.raises(SchedulerUnreachable, match="cannot reach a Dask scheduler"):
            DaskExecutor(f"tcp://127.0.0.1:{port}", connect_timeout=2)
        assert time.monotonic() - t0 < 8
    finally:
        server.close()


def test_a_server_that_is_not_a_dask_scheduler_is_named_as_such():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    port = server.getsockname()[1]
    stop = threading.Event()

    def answer_like_a_web_server():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            with conn:
                try:
                    conn.recv(4096)
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n" * 4)
                except OSError:
                    pass

    thread = threading.Thread(target=answer_like_a_web_server, daemon=True)
    thread.start()
    try:
        t0 = time.monotonic()
        with pytest.raises(SchedulerUnreachable, match="cannot reach a Dask scheduler"):
            DaskExecutor(f"tcp://127.0.0.1:{port}", connect_timeout=2)
        assert time.monotonic() - t0 < 8
    finally:
        stop.set()
        thread.join(timeout=5)
        server.close()


def test_an_existing_cluster_is_used_through_its_address(dask_executor):
    address = dask_executor.client.scheduler.address
    with make_executor(address.replace("tcp://", "dask://"), connect_timeout=5) as remote:
        assert remote.cluster is None and remote.workers == 2
        with remote.session(make_state, 2) as session:
            assert [r[0] for r in session.map(compute, range(5))] == [0, 2, 4, 6, 8]


def test_without_dask_the_error_says_how_to_install_it():
    code = ("import sys; sys.modules['distributed'] = None\n"
            "from grammarkit.run.executor import make_executor\n"
            "from grammarkit.errors import GrammarkitError\n"
            "try:\n    make_executor('dask', 2)\nexcept GrammarkitError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert 'pip install "grammarkit[dask]"' in out.stdout, out.stderr
