"""The one executor: results in item order whatever the workers, state replayed in order,
errors raised in order, persistent workers, interruption and parent death handled."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from grammarkit.run.executor import LocalExecutor, WorkerError


# module-level functions: they must pickle by reference into spawned workers
def make_state(base):
    return {"base": base, "log": []}


def add_to_log(state, value):
    state["log"].append(value)


def compute(state, item):
    if item == "boom":
        raise ValueError("item says boom")
    return (item * state["base"], tuple(state["log"]), os.getpid())


def slow(state, item):
    time.sleep(0.05)
    return item


def run(workers, parallel, items, updates=((),)):
    out = []
    with LocalExecutor(workers, parallel=parallel) as exe:
        with exe.session(make_state, 3) as session:
            for batch, ups in zip(items, updates):
                for u in ups:
                    session.update(add_to_log, u)
                out.extend(session.map(compute, batch))
    return out


def test_results_are_in_item_order_and_independent_of_workers():
    items = [list(range(40)), list(range(40, 55))]
    updates = [("a",), ("b", "c")]
    one = run(1, "never", items, updates)
    two = run(2, "always", items, updates)
    assert [r[:2] for r in one] == [r[:2] for r in two]
    assert [r[0] for r in two] == [3 * i for i in range(55)]
    assert two[-1][1] == ("a", "b", "c")  # updates replayed in order in every worker
    assert {r[2] for r in two} - {os.getpid()}  # really computed elsewhere


def test_an_error_is_raised_at_its_place_after_the_results_before_it():
    got = []
    with LocalExecutor(2, parallel="always").session(make_state, 1) as session:
        with pytest.raises(ValueError, match="boom"):
            for r in session.map(compute, [1, 2, 3, "boom", 5]):
                got.append(r[0])
    assert got == [1, 2, 3]


def test_workers_persist_across_sessions_and_close_with_their_executor():
    exe = LocalExecutor(2, parallel="always")
    for _ in range(2):
        with exe.session(make_state, 3) as session:
            assert len(list(session.map(compute, range(8)))) == 8
        pids = sorted(exe.pool.pids())
        assert len(pids) == 2
        if _ == 0:
            first = pids
    assert pids == first  # the second session reused the executor's workers
    procs = [w.proc for w in exe.pool._workers]
    exe.close()  # the pool belongs to the executor: closing it stops them
    assert exe.pool.pids() == [] and not any(p.is_alive() for p in procs)
    other = LocalExecutor(2, parallel="always")
    assert other.pool.pids() == []  # another executor never sees them
    other.close()


def test_auto_stays_in_process_for_small_work():
    with LocalExecutor(2, parallel="auto") as exe:
        with exe.session(make_state, 3) as session:
            out = list(session.map(compute, range(20)))
        assert exe.pool.pids() == []
    assert {r[2] for r in out} == {os.getpid()}


def test_auto_goes_parallel_when_the_work_pays():
    with LocalExecutor(2, parallel="auto", min_parallel_seconds=0.0).session(make_state, 1) as session:
        out = list(session.map(slow, range(120)))  # 6 s of work in process
    assert out == list(range(120))


def test_interruption_mid_map_drops_the_workers_it_used(monkeypatch):
    import multiprocessing.connection

    exe = LocalExecutor(2, parallel="always")
    with exe.session(make_state, 1) as session:
        list(session.map(slow, range(4)))  # workers up
    used = [w.proc for w in exe.pool._workers]
    real = multiprocessing.connection.wait
    calls = []

    def interrupted(*args, **kw):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kw)

    monkeypatch.setattr(multiprocessing.connection, "wait", interrupted)
    with pytest.raises(KeyboardInterrupt):
        with exe.session(make_state, 1) as session:
            list(session.map(slow, range(64)))
    monkeypatch.undo()
    for p in used:
        p.join(timeout=5)
    assert not any(p.is_alive() for p in used)
    with exe.session(make_state, 3) as session:  # fresh workers, no stale replies
        assert list(session.map(compute, range(6)))[5][0] == 15
    exe.close()


def test_workers_die_with_their_parent(tmp_path):
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(os.path.dirname(__file__))!r})
        from test_executor import make_state, slow

        from grammarkit.run.executor import LocalExecutor
        s = LocalExecutor(2, parallel="always").session(make_state, 1)
        it = s.map(slow, range(100000))
        next(it)
        print(" ".join(str(p) for p in s.executor.pool.pids()), flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    pids = [int(p) for p in proc.stdout.readline().split()]
    assert len(pids) == 2
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    deadline = time.time() + 10
    while time.time() < deadline and any(_alive(p) for p in pids):
        time.sleep(0.1)
    assert not any(_alive(p) for p in pids)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


def test_unpicklable_errors_come_back_as_worker_errors():
    with LocalExecutor(2, parallel="always").session(make_state, 1) as session:
        with pytest.raises((WorkerError, ValueError)):
            list(session.map(raise_unpicklable, [1, 2, 3, 4]))


class _Unpicklable(Exception):
    def __init__(self, a, b):
        super().__init__(a)
        self.lock = __import__("threading").Lock()


def raise_unpicklable(state, item):
    raise _Unpicklable("no pickle", 2)


def test_code_from_standard_input_can_start_workers():
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(os.path.dirname(__file__))!r})
        from test_executor import make_state, compute
        from grammarkit.run.executor import LocalExecutor
        with LocalExecutor(2, parallel="always").session(make_state, 2) as s:
            print([r[0] for r in s.map(compute, range(6))])
    """)
    r = subprocess.run([sys.executable, "-"], input=code, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[0, 2, 4, 6, 8, 10]"


def test_a_script_without_main_guard_still_finishes(tmp_path):
    script = tmp_path / "noguard.py"
    script.write_text(textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(os.path.dirname(__file__))!r})
        from test_executor import make_state, compute
        from grammarkit.run.executor import LocalExecutor
        with LocalExecutor(2, parallel="always").session(make_state, 2) as s:
            print([r[0] for r in s.map(compute, range(6))])
    """))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "[0, 2, 4, 6, 8, 10]"
    assert "could not start" in r.stderr and 'if __name__ == "__main__":' in r.stderr
    # the copies of the script in the workers stop at once, with one line and no traceback
    assert "this script is running again in a starting worker process" in r.stderr
    assert "Traceback" not in r.stderr, r.stderr
