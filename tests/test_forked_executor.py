"""Run children forked from the warmed-up server (mjasc.campaigns.forked): the same results as a
new interpreter's child, a child that dies, a closed child that leaves (the time limit:
tests/test_executor.py, for both kinds of child)."""

import os
import signal
import threading

import pytest

from mjasc.campaigns.engine import without_timing
from mjasc.campaigns.executor import IsolatedExecutor, execute_in_process
from mjasc.campaigns.forked import ForkedExecutor, forking_safe
from tests.test_executor import SLOW_S, _alive, _req


def test_forking_is_safe_under_pytest():
    assert forking_safe()  # (python -m pytest: a package's __main__, never re-imported)


def test_a_forked_child_gives_the_same_results_as_this_process():
    a = execute_in_process(_req())
    ex = ForkedExecutor()
    try:
        ex.start()
        assert ex.wait_ready(120) and ex.pid is not None and not ex._fallback
        b = ex.run(_req(), time_limit_s=120)
        c = ex.run(_req(k=1), time_limit_s=120)  # the same child serves the next run
    finally:
        ex.close()
    assert a["status"] == b["status"] == c["status"] == "completed"
    assert without_timing(a["summary"]) == without_timing(b["summary"])
    assert b["worker"] == c["worker"] == f"{os.uname().nodename}:{ex.pid}"


def test_a_dying_forked_child_costs_only_its_run():
    ex = ForkedExecutor()
    try:
        assert ex.run(_req(), time_limit_s=120)["status"] == "completed"
        pid = ex.pid
        threading.Timer(2.0, lambda: os.kill(pid, signal.SIGKILL)).start()
        dead = ex.run(_req(duration=SLOW_S), time_limit_s=120)
        assert dead["status"] == "crashed" and "signal 9" in dead["error"]
        assert ex.run(_req(), time_limit_s=120)["status"] == "completed" and ex.pid != pid
    finally:
        ex.close()


def test_a_closed_forked_child_leaves():
    ex = ForkedExecutor()
    assert ex.wait_ready(120)
    pid = ex.pid
    ex.close()
    assert ex._process is None and not _alive(pid)
    assert ex.wait_ready(120) and ex.run(_req(), time_limit_s=120)["status"] == "completed"  # a new fork
    ex.close()


@pytest.mark.parametrize("kind", [ForkedExecutor, IsolatedExecutor])
def test_closing_a_child_while_a_thread_waits_on_its_run_ends_that_run(kind):
    """The campaign's Ctrl-C closes the children from the driver's thread while the workers' threads
    wait on their runs: close() must neither raise (a forked child's close raced the run's thread
    reaping the same child: "process object is closed") nor leave the child; the run ends crashed.
    Repeated with different delays so that each side of the race is taken."""
    for delay_s in (0.0, 0.3):
        waiting = threading.Event()

        class Observed(kind):  # says when the run's thread waits on the child's answer
            def _recv(self, deadline):
                waiting.set()
                return super()._recv(deadline)

            def _line(self, deadline):
                waiting.set()
                return super()._line(deadline)

        ex = Observed()
        assert ex.wait_ready(120)
        pid = ex.pid if kind is ForkedExecutor else ex._proc.pid
        waiting.clear()
        out = {}
        t = threading.Thread(target=lambda: out.setdefault("r", ex.run(_req(duration=SLOW_S), time_limit_s=120)))
        t.start()
        assert waiting.wait(60)
        threading.Event().wait(delay_s)
        ex.close()
        t.join(60)
        assert not t.is_alive() and out["r"]["status"] == "crashed", (delay_s, out)
        assert not _alive(pid)


def test_a_child_killed_with_its_campaign_is_used_by_one_thread_at_a_time(monkeypatch):
    """The campaign's Ctrl-C kills the run children (SIGINT to the process group) while the
    driver's thread closes them: the run's thread reaps and closes its dead child while close()
    joins it. multiprocessing's Process is not thread-safe (a close() in one thread between
    another's check and its use of the process raises AssertionError or AttributeError there), so
    every call on a child's Process object is one thread's at a time. Checked with each call made
    to last 0.2 s, closing at once after the kill and once the run's thread is at it."""
    import time
    from multiprocessing.process import BaseProcess

    inside: dict = {}  # id of a process → the threads inside one of its calls
    overlaps = []

    def slowed(name):
        real = getattr(BaseProcess, name)

        def call(self, *args, **kwargs):
            users = inside.setdefault(id(self), set())
            if users:
                overlaps.append((name, threading.current_thread().name))
            users.add(threading.get_ident())
            try:
                time.sleep(0.2)
                return real(self, *args, **kwargs)
            finally:
                users.discard(threading.get_ident())
        return call

    for delay_s in (0.0, 0.3):
        ex = ForkedExecutor()
        assert ex.wait_ready(120)
        pid = ex.pid
        waiting = threading.Event()
        recv = ex._recv
        ex._recv = lambda deadline: (waiting.set(), recv(deadline))[1]
        out = {}
        t = threading.Thread(target=lambda: out.setdefault("r", ex.run(_req(duration=SLOW_S), time_limit_s=120)))
        t.start()
        assert waiting.wait(60)
        with monkeypatch.context() as m:
            for name in ("is_alive", "join", "kill", "close"):
                m.setattr(BaseProcess, name, slowed(name))
            os.kill(pid, signal.SIGKILL)
            threading.Event().wait(delay_s)
            ex.close()  # (raised nothing, and)
            t.join(60)
        assert not t.is_alive() and out["r"]["status"] == "crashed", (delay_s, out)
        assert not overlaps, (delay_s, overlaps)
        assert ex._process is None and not _alive(pid)


def _descendants() -> set:
    """The processes below this one (children, and the fork server's children)."""
    parents = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                parents[int(d)] = int(fields[1])
    out, new = set(), {os.getpid()}
    while new:
        new = {p for p, pp in parents.items() if pp in new} - out
        out |= new
    return out


@pytest.mark.parametrize("kind", [ForkedExecutor, IsolatedExecutor])
def test_a_released_child_starts_no_new_one_for_a_run_begun_before(kind, monkeypatch):
    """The campaign's Ctrl-C releases each worker's run child (release_isolated) while a worker's
    thread has already taken its executor and is starting a child for its next run: that child
    must not go on to run it (nothing would close it, and the cluster's shutdown waits for the
    run); the run ends crashed, and so does one given after the release, without a child."""
    import mjasc.campaigns.executor as ex_mod
    from mjasc.campaigns import forked

    forked.start_server()  # (the fork server is not a run's child)
    before = _descendants()
    held, go = threading.Event(), threading.Event()

    def holding(real):
        def call(*args, **kwargs):
            if threading.current_thread() is not threading.main_thread():
                held.set()
                assert go.wait(60)
            return real(*args, **kwargs)
        return call

    if kind is ForkedExecutor:  # (the run's thread is held as it forks its child)
        monkeypatch.setattr(forked, "start_server", holding(forked.start_server))
    else:  # (as it starts its new interpreter)
        monkeypatch.setattr(ex_mod, "child_environment", holding(ex_mod.child_environment))
    ex = kind()
    key = f"worker-test-release-{kind.__name__}"
    ex_mod.adopt_isolated(key, ex)
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("r", ex.run(_req(), time_limit_s=120)))
    t.start()
    assert held.wait(60)
    ex_mod.release_isolated(key)
    go.set()
    t.join(120)
    assert not t.is_alive() and out["r"]["status"] == "crashed" and "shutting down" in out["r"]["error"], out
    again = ex.run(_req(), time_limit_s=120)
    assert again["status"] == "crashed" and "shutting down" in again["error"]
    assert not ex.wait_ready(5)
    assert getattr(ex, "_process", None) is None and ex._proc is None
    assert not _descendants() - before
