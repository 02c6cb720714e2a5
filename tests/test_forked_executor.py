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
